"""The pump, table and validate commands (CONTRACT.md): JSON, traces, refusals, exit status 2."""

import csv
import json

import pytest

CONTRACT_KEYS = {"valve", "speed_rpm", "load_pressure_pa", "delivery_cc_per_rev", "revolutions", "cpu_seconds",
                 "mass_balance_error"}


def test_pump_json_and_trace(cli, tmp_path):
    trace = tmp_path / "trace.csv"
    rc, out, err, obj = cli("pump", "--valve", "disc", "--speed-rpm", "593", "--load-pressure-mpa", "2.76",
                            "--revolutions", "3", "--trace", trace, "--json")
    assert rc == 0, err
    assert CONTRACT_KEYS <= set(obj)
    assert obj["valve"] == "disc" and obj["speed_rpm"] == 593 and obj["load_pressure_pa"] == pytest.approx(2.76e6)
    assert obj["delivery_cc_per_rev"] == pytest.approx(1.731, rel=0.01)        # Table 5.4 baseline
    assert obj["revolutions"] == 3 and obj["mass_balance_error"] < 1e-9 and obj["cyclic_steady"]
    rows = list(csv.reader(open(trace)))
    assert rows[0] == ["time_s", "valve_position_m", "cylinder_pressure_pa", "load_pressure_pa",
                       "inlet_position_m", "delivery_position_m"]
    assert float(rows[1][0]) == 0.0 and len(rows) > 1000
    assert out.count("\n") == 1                                                 # exactly one JSON object
    # never overwrite the user's file
    rc, out, err, obj = cli("pump", "--valve", "disc", "--speed-rpm", "593", "--load-pressure-mpa", "2.76",
                            "--trace", trace, "--json")
    assert rc == 2 and obj is None and "--trace" in err and "Traceback" not in err


def test_pump_fast_method_agrees_with_the_reference(cli):
    """The compiled path (default): same contract keys, delivery within 0.1 % of --method reference."""
    args = ("pump", "--valve", "reed", "--speed-rpm", "595", "--load-pressure-mpa", "2.76", "--revolutions", "3",
            "--json")
    rc, out, err, fast = cli(*args)                      # the fast path is the default
    assert rc == 0, err
    rc, out, err, ref = cli(*args, "--method", "reference")
    assert rc == 0, err
    assert CONTRACT_KEYS <= set(fast) and fast["method"] == "fast" and ref["method"] == "reference"
    assert fast["delivery_cc_per_rev"] == pytest.approx(ref["delivery_cc_per_rev"], rel=1e-3)
    assert fast["cpu_seconds_per_simulated_second"] < ref["cpu_seconds_per_simulated_second"]


@pytest.mark.parametrize("args, flag", [
    (["--speed-rpm", "-600"], "--speed-rpm"),
    (["--speed-rpm", "nan"], "--speed-rpm"),
    (["--load-pressure-mpa", "inf"], "--load-pressure-mpa"),
    (["--air-content", "1.2"], "--air-content"),
    (["--revolutions", "1"], "--revolutions"),
    (["--circuit", "open"], "--circuit"),
    (["--speed-rpm", "fast"], "--speed-rpm"),
    (["--reed-geometry", "prototype"], "--reed-geometry"),          # a disc pump has no reed
    (["--dead-volume-m3", "0"], "--dead-volume-m3"),
])
def test_pump_bad_flags_exit_2_naming_the_flag(args, flag, capsys):
    # in-process (studies.cli.main) to keep the suite fast; the subprocess path is tested above
    from studies.cli import main

    base = {"--valve": "disc", "--speed-rpm": "600", "--load-pressure-mpa": "2.76"}
    for k, v in zip(args[::2], args[1::2]):
        base[k] = v
    argv = ["pump", *[x for kv in base.items() for x in kv], "--json"]
    try:
        rc = main(argv)
    except SystemExit as e:                     # argparse's own errors
        rc = e.code
    out, err = capsys.readouterr()
    assert rc == 2 and out == ""
    assert flag in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_validate_quick_writes_tables_plots_and_summary(cli, tmp_path):
    out = tmp_path / "out"
    rc, stdout, err, obj = cli("validate", "--quick", "--valve", "disc", "--out", out, "--json", timeout=900)
    assert rc == 0, err
    for name in ("table_5_4.md", "table_5_4.csv", "table_2_3.md", "summary.md", "summary.json",
                 "fig_5_7_disc_inlet_baseline.png", "fig_5_12_disc_delivery_high_pressure.png"):
        assert (out / name).is_file(), name
    rows = list(csv.DictReader(open(out / "table_5_4.csv")))
    assert len(rows) == 6
    assert {"condition", "measured_valve", "modeled_cc", "measured_cc", "error_pct", "thesis_modeled_cc",
            "thesis_error_pct"} <= set(rows[0])
    for r in rows:     # the disc model reproduces the thesis's model (quick settings: 3 revolutions)
        assert float(r["modeled_cc"]) == pytest.approx(float(r["thesis_modeled_cc"]), rel=0.01)
    s = json.loads((out / "summary.json").read_text())
    assert s["tables"]["5.4"]["max_abs_diff_from_thesis_model_pct"] < 1.0
    assert "step 2/4" in err and "step 4/4" in err                            # progress on stderr
    assert obj["steps"]["pump_cases"]["cases"] == 6
    # the V&V 20 table (CONTRACT keys), cheaper with --quick and saying so
    assert len(obj["validation"]) == 6 and obj["reed_validation"] == []
    keys = {"case", "output", "S", "D", "E", "u_num", "u_input", "u_D", "u_val", "k", "U_val", "delta_model",
            "verdict", "contributors"}
    for r in obj["validation"]:
        assert keys <= set(r) and r["output"] == "delivery_cc_per_rev" and r["verdict"] in ("within", "model_form_error")
        assert r["E"] == pytest.approx(r["S"] - r["D"]) and r["U_val"] == pytest.approx(r["k"] * r["u_val"])
        assert r["u_input"] > 0 and r["u_D"] > 0 and r["contributors"][0][0] == "oil.air_content"
    assert obj["area_metric"]["disc"] > 0 and obj["area_metric"]["reed"] is None
    assert obj["uncertainty"]["quick"] and "cheaper" in obj["uncertainty"]["note"]
    for name in ("validation.md", "validation.csv", "validation.json", "validation.png"):
        assert (out / name).is_file(), name
    assert "within the validation uncertainty" in (out / "validation.md").read_text()
    # a second run may replace its own output, but not a user's folder
    user = tmp_path / "mine"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    rc, stdout, err = cli("validate", "--quick", "--valve", "disc", "--out", user)
    assert rc == 2 and "--out" in err


def _fake_props(reed=None, mesh_size=None):
    import numpy as np

    from lumped.reed.mode_function import ReedProperties
    return ReedProperties(fidelity="analytic", omega_n=2500.0, kappa=6.4e6, gamma1=1.62, gamma2=0.70, gamma3=0.87,
                          h_eff=1.2e-3, s=np.linspace(0, 0.0254, 9), psi=np.linspace(0, 1, 9) ** 2)


def test_pump_takes_reed_parameters_from_a_reed_model(monkeypatch, capsys):
    """--reed-geometry/--reed-fidelity go through the fidelity registry (lumped.reed.fidelities)."""
    import lumped.reed.fidelities as rf
    from studies.cli import main

    monkeypatch.setattr(rf, "reed_model", lambda fidelity, field=None: _fake_props)
    rc = main(["pump", "--valve", "reed", "--speed-rpm", "595", "--load-pressure-mpa", "2.76", "--revolutions", "2",
               "--reed-geometry", "prototype", "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    obj = json.loads(out)
    assert "analytic model of prototype" in obj["reed_parameters"]
    # a softer reed (6.4 vs 7.709 MPa/m) opens wider than Table 3.13's
    rc = main(["pump", "--valve", "reed", "--speed-rpm", "595", "--load-pressure-mpa", "2.76", "--revolutions", "2",
               "--json"])
    ref = json.loads(capsys.readouterr()[0])
    assert obj["peak_opening_m"]["inlet"] > ref["peak_opening_m"]["inlet"]
    assert ref["reed_parameters"] == "Table 3.13"


def test_reed_parameter_chain_feeds_the_pump():
    """Step 1 of validate: the multi-fidelity check's selection becomes the pump's reed parameters."""
    from studies.validation import chain as V

    out = V.reed_parameter_chain(fidelities=("analytic", "beam"), progress=False)
    assert [r["fidelity"] for r in out["rows"]] == ["analytic", "beam"]
    props = out["selected"]
    # analytic and beam FE are the same theory: they agree, so the cheaper analytic one is selected
    assert props.fidelity == "analytic" and not out["flagged"]
    assert 6.0e6 < props.kappa < 7.5e6          # prototype: FEA 6.353 MPa/m, E-B a few % stiffer
    m = V.reed_model_from(props)
    assert m.inlet.stiffness == props.kappa and m.delivery.gamma1 == props.gamma1
    assert m.delivery.preload == pytest.approx(-0.18e-3)    # the empirical rest stays Table 3.13's


def test_pump_uncertainty_gives_u_num_and_u_input(cli):
    """valvelab pump --uncertainty: u_num and u_input of the delivery and each valve's angles (CONTRACT);
    a model without declarations has u_input 0."""
    rc, out, err, obj = cli("pump", "--valve", "disc", "--revolutions", "3", "--uncertainty", "--json", timeout=600)
    assert rc == 0, err
    u = obj["uncertainty"]
    assert set(u) == {"delivery_cc_per_rev", "inlet_opening_angle_deg", "inlet_closing_angle_deg",
                      "delivery_opening_angle_deg", "delivery_closing_angle_deg"}
    for name, d in u.items():
        assert {"u_num", "u_input", "contributors"} <= set(d)
        assert d["u_num"] is not None and 0 <= d["u_num"] < d["u_input"], (name, d)
    # the air content's 0.0029 at ~22 cc/rev per unit R (thesis disc pump)
    assert u["delivery_cc_per_rev"]["contributors"][0][0] == "oil.air_content"
    assert 0.03 < u["delivery_cc_per_rev"]["u_input"] < 0.1
