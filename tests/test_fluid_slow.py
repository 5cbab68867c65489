"""Slow checks of the fluid references: mesh ladders and the shipped compact forms recomputed (``pytest -m slow``)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from fea.convergence import gci
from fea.fluid import compact
from fea.fluid.axisymmetric import AxiOptions, solve_point
from fea.fluid.point import load_fluid_valve
from fea.fluid.valve_mesh import disc_domain

pytestmark = pytest.mark.slow

DATA = Path(compact.__file__).parent / "data"


@pytest.mark.parametrize("key", ["cd", "dp"])
def test_axisymmetric_gci_estimates_the_error_of_the_default_mesh(key):
    """The GCI of the middle mesh of (2, 4, 8) against a finer mesh (16): its Richardson error estimate within
    a factor 1.5 of the error, and the band (Fs = 1.25) covering it."""
    v = load_fluid_valve("thesis-disc:inlet")
    d = disc_domain(v.params)
    vals = {n: solve_point(v, d, 1.0e-3, 100.0, n, AxiOptions())[key] for n in (2, 4, 8, 16)}
    g = gci([vals[8], vals[4], vals[2]], sizes=[1 / 8, 1 / 4, 1 / 2])
    assert g.converging
    true = abs(vals[4] - vals[16])
    estimate = abs(vals[4] - g.extrapolated)
    assert 1 / 1.5 <= estimate / true <= 1.5, (vals, estimate, true)
    assert g.band(1) >= true


def test_shipped_forms_of_the_thesis_inlet_valve_recompute(tmp_path, monkeypatch):
    monkeypatch.setenv("VALVELAB_CACHE_DIR", str(tmp_path))
    v = load_fluid_valve("thesis-disc:inlet")
    shipped = json.loads((DATA / "thesis-disc-inlet.json").read_text())
    fresh = compact.compact_forms(v, recompute=True, progress=True)
    assert fresh["key"] == shipped["key"] and len(fresh["points"]) == len(shipped["points"])
    for a, b in zip(fresh["points"], shipped["points"]):
        assert (a["lift"], a["reynolds"]) == (b["lift"], b["reynolds"])
        for k in ("cd", "force_coefficient", "dp"):
            assert a[k] == pytest.approx(b[k], rel=2e-3), (a["lift"], a["reynolds"], k)
    for k in ("force_coefficient_orifice", "jet_angle", "f1", "f2", "c_visc"):
        assert fresh["forms"][k] == pytest.approx(shipped["forms"][k], rel=5e-3), k
    assert fresh["provenance"]["wall_seconds"] < 1800          # the 10 min target is measured by the benchmark


def test_cd_of_the_stop_against_the_bench_is_reported_not_tuned():
    """The prediction is not fitted to eq 2.48: it deviates, and the docs quote the deviation it has."""
    from lumped.fluid.orifice import discharge_coefficient

    shipped = json.loads((DATA / "thesis-disc-inlet.json").read_text())
    stop = max(p["lift"] for p in shipped["points"])
    dev = {p["reynolds"]: p["cd"] / float(discharge_coefficient(math.sqrt(p["reynolds"]), 0.972, -1.0801, 0.1058,
                                                                 0.9505)) - 1
           for p in shipped["points"] if p["lift"] == stop}
    assert dev[10.0] == pytest.approx(-0.008, abs=0.005)
    assert dev[100.0] == pytest.approx(-0.106, abs=0.01)
