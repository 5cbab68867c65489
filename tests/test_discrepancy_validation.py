"""The discrepancy workflow's validation of the baseline (ASME V&V 20 per run), its robust pressure loss, and the
mismatched-model generator: each checked against independent numbers (closed forms, quadrature, the fields
each model-form variant must change)."""

import math

import numpy as np
import pytest

from lumped.model.effects import Applied
from lumped.model.model_file import load_model
from studies.discrepancy import mismatch, validation as val
from studies.discrepancy.gap import robust_pressure
from studies.discrepancy.workflow import RunCondition


def test_rows_combine_the_three_uncertainties_as_vv20():
    """E = S - D; u_input from the perturbed outputs in quadrature; u_D as given; U_val = 2 u_val (infinite dof);
    angles wrapped (a closing at 359 deg measured at 1 deg is 2 deg early, not 358)."""
    base = {"delivery_cc_per_rev": 1.80, "inlet_closing_deg": 359.0,
            "measured": {"delivery_cc_per_rev": 1.70, "inlet_closing_deg": 1.0}}
    fine = {"delivery_cc_per_rev": 1.80, "inlet_closing_deg": 359.0}
    pert = [("oil.air_content", {"delivery_cc_per_rev": 1.83, "inlet_closing_deg": 359.2}),
            ("oil.viscosity", {"delivery_cc_per_rev": 1.76, "inlet_closing_deg": 358.5})]
    u_d = {"delivery_cc_per_rev": (0.02, math.inf, "stated"), "inlet_closing_deg": (0.1, math.inf, "spacing")}
    rows = {r["output"]: r for r in val.rows("run1", base, fine, pert, u_d)}
    d = rows["delivery_cc_per_rev"]
    assert d["E"] == pytest.approx(0.10)
    assert d["u_input"] == pytest.approx(math.hypot(0.03, 0.04))
    assert d["U_val"] == pytest.approx(2.0 * math.hypot(0.05, 0.02))
    assert d["verdict"] == "within" and d["contributors"][0][0] == "oil.viscosity"
    c = rows["inlet_closing_deg"]
    assert c["E"] == pytest.approx(-2.0)
    assert c["u_input"] == pytest.approx(math.hypot(0.2, 0.5))
    assert c["U_val"] == pytest.approx(2.0 * math.sqrt(0.2**2 + 0.5**2 + 0.1**2))
    assert c["verdict"] == "model_form_error" and c["delta_model"][1] < 0


def test_beyond_counts_an_output_only_where_most_runs_show_it():
    rows = [{"run": f"r{i}", "output": "delivery_cc_per_rev", "unit": "cc/rev", "E": e, "U_val": 0.1,
             "verdict": "within" if abs(e) <= 0.1 else "model_form_error"} for i, e in enumerate((0.2, 0.3, 0.05))]
    rows = [dict(r, D=1.7) for r in rows]
    rows += [{"run": f"r{i}", "output": "inlet_opening_deg", "unit": "deg", "E": e, "U_val": 1.0, "D": 50.0,
              "verdict": "within" if abs(e) <= 1.0 else "model_form_error"} for i, e in enumerate((3.0, 0.2, 0.1))]
    # beyond U_val but within the gap's tolerance (20 um): not a disagreement
    rows += [{"run": f"r{i}", "output": "delivery_seated_mm", "unit": "mm", "E": -0.012, "U_val": 0.005, "D": -0.25,
              "verdict": "model_form_error"} for i in range(3)]
    b = val.beyond(rows)
    assert [x["output"] for x in b] == ["delivery_cc_per_rev"] and b[0]["runs"] == ["r0", "r1"]
    assert "2 of 3 runs" in val.sentence(b[0])


def test_the_robust_pressure_loss():
    """Pure noise keeps E[c^2 ln(1 + Z^2/c^2)] of its variance (0.947 at c = 5, by quadrature, checked here by
    Monte Carlo); a residual of one deviation keeps 98 % of its square; one of 100 deviations weighs
    c^2 ln(1 + 400) = 150 variances, not 10,000."""
    rng = np.random.default_rng(0)
    z = rng.normal(0.0, 1.0, 400_000)
    t, noise = robust_pressure(1e4 * z, 1e4, 5.0)
    assert np.mean(t**2) == pytest.approx(noise**2, rel=0.01)
    assert (noise / 1e4) ** 2 == pytest.approx(np.mean(25.0 * np.log1p(z**2 / 25.0)), rel=0.01)
    one, _ = robust_pressure(np.array([1e4]), 1e4, 5.0)
    assert (one[0] / 1e4) ** 2 == pytest.approx(25 * math.log(1.04))
    big, _ = robust_pressure(np.array([-1e6]), 1e4, 5.0)
    assert big[0] < 0 and (big[0] / 1e4) ** 2 == pytest.approx(25 * math.log(401.0))
    same, n = robust_pressure(np.array([3.0]), 1e4, 0.0)
    assert same[0] == 3.0 and n == 1e4


@pytest.mark.parametrize("name", sorted(mismatch.VARIANTS))
def test_every_model_form_variant_changes_what_it_says(name):
    """Each variant of the mismatched-model generator changes the fields its text names, and only through the
    model (or the noise): the library's own form is left for the fits."""
    from studies.discrepancy.pump_sim import PumpSimulator

    v = mismatch.VARIANTS[name]
    kind = v.kinds[0]
    sim = PumpSimulator(load_model(f"thesis-{kind}"))
    ms, noise = mismatch.mismatched(sim, name, np.random.default_rng(1))
    vals = dict(ms.values)
    for k, (lo, hi) in (v.ranges or {}).items():
        lo, hi = sorted((abs(lo), abs(hi)))
        x = abs(vals[k] - 1.0) + 1.0 if k == "scale" else abs(vals[k])
        assert lo <= x <= hi
    for k, (lo, hi) in (v.noise or {}).items():
        lo, hi = sorted((abs(lo), abs(hi)))
        assert lo <= abs(noise[k]) <= hi
    cond = RunCondition("r", kind, 600.0, 2.8e6, 0.01)
    effects = {"film_tension": (Applied.of("squeeze_film", "both", {"C2": 7e-11}),),
               "film_gap": (Applied.of("squeeze_film", "both", {"C2": 7e-11}),),
               "jet_weak": (Applied.of("flow_force", "both", {"theta_jet": 1.2, "L_t": 0.01}),),
               "seat_underdamped": (Applied.of("seat_compliance", "delivery", {"k_seat": 2e6}),)}.get(name, ())
    plain, changed = sim.model_for(cond, effects), ms.model_for(cond, effects)
    from lumped.model.effect_library import resolve
    plain = resolve(plain)
    d = plain.delivery
    c = changed.delivery
    checks = {
        "film_tension": lambda: c.squeeze_tensile_strength == vals["sigma_t"] and d.squeeze_tensile_strength == 0.0,
        "film_gap": lambda: c.squeeze_min_gap == vals["h_r"] and d.squeeze_min_gap == 1e-6,
        "jet_weak": lambda: c.flow_force_steady == vals["steady"] and c.flow_force_transient == vals["transient"],
        "seat_underdamped": lambda: c.seat_damping == pytest.approx(
            vals["zeta"] * 2 * math.sqrt(d.seat_stiffness * d.contact_mass)),
        "air_isothermal": lambda: changed.oil.polytropic_exponent == 1.0 and plain.oil.polytropic_exponent == 1.4,
        "leak_length": lambda: changed.pump.seal_length == vals["L"],
        "cd_error": lambda: c.cd_inf == pytest.approx(d.cd_inf * vals["scale"]),
        "sensor": lambda: changed == plain and noise["vibration_m"] > 0,
    }
    assert checks[name]()
