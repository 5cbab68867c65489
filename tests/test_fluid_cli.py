"""``valvelab flow``, ``valvelab check MODEL``, ``fluid = "predicted"`` and the lift-dependent Cd of the pump model."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import fea.fluid  # noqa: F401  (registers the predicted forms)
from lumped import load_model
from lumped.model.model_file import with_values
from lumped.valves.kind import valve_flow
from lumped.solver.layout import OFF_IN, pack

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def cache(tmp_path_factory, monkeypatch):
    """An empty fluid cache: the thesis disc's forms must come from the shipped files, nothing is computed."""
    folder = tmp_path_factory.mktemp("fluid-cache")
    monkeypatch.setenv("VALVELAB_CACHE_DIR", str(folder))
    return folder


def valvelab(*args, cwd=None):
    import os

    r = subprocess.run([sys.executable, "-m", "studies", *args], capture_output=True, text=True, cwd=cwd,
                       env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg",
                            "HOME": os.environ["VALVELAB_CACHE_DIR"],
                            "VALVELAB_CACHE_DIR": os.environ["VALVELAB_CACHE_DIR"]}, timeout=600)
    return r.returncode, r.stdout, r.stderr


def test_flow_orifice_json_has_the_contract_keys():
    rc, out, err = valvelab("flow", "thesis-disc:delivery", "--fidelity", "orifice", "--lift-mm", "0.3,0.9",
                            "--reynolds", "10,50", "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert d["valve"] == "thesis-disc:delivery" and d["fidelity"] == "orifice" and len(d["points"]) == 4
    p = d["points"][0]
    for key in ("lift", "reynolds", "flow", "dp", "cd", "force", "force_coefficient", "flow_force",
                "pressure_load_multiplier", "u_num"):
        assert key in p
    assert p["lift"] == pytest.approx(0.3e-3) and p["cd"] == pytest.approx(0.2044, abs=1e-4)   # eq 2.48 at Re 10


def test_flow_thin_film_squeeze_and_displacement():
    rc, out, err = valvelab("flow", "thesis-disc", "--fidelity", "thin_film", "--lift-mm", "0.05", "--reynolds", "5",
                            "--squeeze", "--displacement", "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert d["film"]["C1"] == pytest.approx(0.7137, abs=2e-4) and d["film"]["F4"] is None
    assert set(d["displacement"]) >= {"f1", "f2", "A_Q_closing", "A_Q_opening"}


def test_flow_axisymmetric_point_and_plot(tmp_path):
    plot = tmp_path / "flow.png"
    rc, out, err = valvelab("flow", "thesis-disc", "--fidelity", "axisymmetric", "--lift-mm", "1.0",
                            "--reynolds", "20", "--resolution", "2", "--plot", str(plot), "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert 0.2 < d["points"][0]["cd"] < 0.4 and d["mesh"]["dofs"] > 1000
    assert plot.stat().st_size > 10_000


@pytest.mark.parametrize("args, field", [
    (("--fidelity", "axisymmetric", "--lift-mm", "1.5"), "--lift-mm"),
    (("--fidelity", "thin_film", "--reynolds", "0"), "--reynolds"),
    (("--fidelity", "orifice", "--reynolds", "-2,5"), "--reynolds"),
    (("--fidelity", "cfd"), "--fidelity"),
    (("--fidelity", "3d"), "--fidelity")])
def test_flow_bad_input_exits_2_naming_the_field(args, field):
    rc, out, err = valvelab("flow", "thesis-disc", *args, "--json")
    assert rc == 2 and out == ""
    assert field in err and len(err.strip().splitlines()) == 1


def test_flow_port_wider_than_the_disc_exits_2(tmp_path):
    f = tmp_path / "wide.toml"
    f.write_text('[valves]\nport.diameter = 12e-3\n')
    rc, out, err = valvelab("flow", f"{f}:inlet", "--fidelity", "axisymmetric", "--json")
    assert rc == 2 and "port.diameter" in err


def test_the_thesis_discs_forms_are_shipped(cache):
    import time

    from fea.fluid.compact import compact_forms, valve_key
    from fea.fluid.point import load_fluid_valve

    for pos in ("inlet", "delivery"):
        v = load_fluid_valve(f"thesis-disc:{pos}")
        t = time.perf_counter()
        data = compact_forms(v, progress=False)
        assert time.perf_counter() - t < 2.0 and data["key"] == valve_key(v)
        assert data["provenance"]["lifts"][-1] == pytest.approx(v.params.stop_gap)
    assert not list(cache.iterdir())             # nothing computed, nothing cached


def test_contract_flow_example_has_the_keys_flow_prints():
    import re

    text = (ROOT / "CONTRACT.md").read_text()
    example = json.loads(re.search(r'```json\n(\{"valve": "thesis-disc:inlet", "fidelity": "axisymmetric".*?)```',
                                   text, re.S).group(1))
    rc, out, err = valvelab("flow", "thesis-disc", "--fidelity", "orifice", "--json")
    d = json.loads(out)
    assert set(example) <= set(d) and set(example["points"][0]) <= set(d["points"][0])


def test_empirical_is_the_default_and_predicted_replaces_the_fluid_constants(cache):
    emp = load_model("thesis-disc")
    assert emp.inlet.fluid == "empirical" and emp.inlet.cd_lift_exponent == 0.0 and emp.inlet.force_coefficient == 1.0
    pre = with_values(emp, {"valves.fluid": "predicted"})
    for pos in ("inlet", "delivery"):
        v = pre.valve(pos)
        assert v.fluid == "predicted"
        assert v.cd_inf != emp.inlet.cd_inf and v.f1 < 1.0 and 0.3 < v.force_coefficient < 1.0
        assert v.jet_angle != emp.inlet.bevel_angle and v.viscous_drag > 10.0
        # everything else is the thesis's
        assert v.spring_stiffness == emp.valve(pos).spring_stiffness and v.stop_gap == emp.valve(pos).stop_gap
    assert not list(cache.iterdir())


def test_pump_reports_each_valves_fluid(tmp_path):
    f = tmp_path / "pred.toml"
    f.write_text('base = "thesis-disc"\n[valves.inlet]\nfluid = "predicted"\n')
    rc, out, err = valvelab("pump", "--model", str(f), "--revolutions", "2", "--max-revolutions", "2", "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert d["fluid"] == {"inlet": "predicted", "delivery": "empirical"}
    assert 1.0 < d["delivery_cc_per_rev"] < 2.3


def test_lift_exponent_flow_slope_matches_differences():
    """dQ/dx of the orifice flow with Cd at Re (x / x_stop)^k: the perimeter term against central differences."""
    model = with_values(load_model("thesis-disc"), {"valves.inlet.discharge.lift_exponent": 0.6})
    p, o = pack(model, 593.0, 2.76e6), OFF_IN
    x, dp, rho, mu = 0.4e-3, 2e4, 876.0, 0.0683
    q, cd, aq, dqp, dqx = valve_flow(x, 0.0, dp, rho, mu, p, o, 1)
    h = 1e-9
    qp = valve_flow(x + h, 0.0, dp, rho, mu, p, o, 1)[0]
    qm = valve_flow(x - h, 0.0, dp, rho, mu, p, o, 1)[0]
    assert dqx == pytest.approx((qp - qm) / (2 * h), rel=1e-5)
    # and the effective Reynolds number is what makes Cd smaller below the stop
    q0 = valve_flow(x, 0.0, dp, rho, mu, pack(load_model("thesis-disc"), 593.0, 2.76e6), o, 1)[0]
    assert q < q0
