"""Acceptance of the discrepancy workflow on valvelab's pump model (fast compiled path).

Datasets are synthesised from the pump with an effect hidden (chosen and valued by a
seed, studies/discrepancy/confusion.py), realistic noise (10 um position noise, 10 kPa pressure
noise, 0.3 % delivery error, a +-1.12 % sensor scale error per valve and a +-0.2 ms
time offset) at the thesis's six disc runs (three operating conditions x two measured
valves). The workflow must name the hidden effect, recover its parameter within 20 %
and shrink the held-out gap by at least 70 %; with nothing hidden, or with a baseline
error it does not search (the discharge coefficient 3 % off), it must name nothing.

The default run holds the thesis's own story (the O-ring, ~20 s) and a representative
subset (nothing hidden, the discharge coefficient 3 % low, leakage behind reed valves;
~30 s); the full matrix (every hidden effect, two at once, nothing, the 3 %
discharge-coefficient error, ~20 min) is marked slow (``pytest -m slow``), the datasets it is known
to get wrong (KNOWN_MISSES, each set out in docs/discrepancy.md) as strict expected failures;
``python -m studies.discrepancy.confusion`` gives the confusion matrix over many seeds
(docs/discrepancy.md).
"""

import numpy as np
import pytest

from lumped.model.effects import Applied
from studies.discrepancy.confusion import CASES, MISMATCH, case_truth, run_case
from studies.discrepancy.model_choice import choose
from studies.discrepancy.workflow import RunCondition, Settings
from studies.discrepancy.pump_sim import for_valve_type, model_for, simulate

SETTINGS = Settings(workers=2)


#: library datasets (the workflow's own model form) named right that still leave a gap above the noise's: the fit
#: ends in a neighbouring valley (docs/discrepancy.md, Known limits); strict both ways, as KNOWN_MISSES below
LARGE_GAP_LEFT = {
    ("reed", "entrained_air+piston_leakage", 1):
        "the leak beside entrained air ends at a clearance 15 % short with Cd x1.03 (the truth's valley costs 10 fit "
        "units less), 21.9 gap units left where the noise leaves 12",
}


def check_found(r: dict, valve: str):
    assert r["correct"] and r["found"] == r["expected"], r
    for name, err in r["relative_errors"].items():
        if name == "flow_force.theta_jet":
            continue       # the data pin down the force, not the jet angle (docs/discrepancy.md): an effective angle
        assert abs(err) <= 0.2, (name, err, r["parameters"])
    if not r["found"] and r["unexplained"]["large"]:
        assert r["unexplained"]["sentences"], r                  # never silent on a large gap
    if r["model_form"] is None:
        # the library's own model form with its effects named: what is left is the noise's, not a "large gap" (the
        # seat + film fitted one at a time, not jointly, left 22-46 units where the limit is 12)
        known = LARGE_GAP_LEFT.get((valve, r["case"], r["seed"]))
        assert r["unexplained"]["large"] == bool(known), (known, r["unexplained"]["sentences"])
    for a in r["truth"]:
        # a discharge coefficient off in the data is recovered as the baseline nuisance, not named
        if a["name"] == "discharge_scale":
            assert r["baseline_nuisances"]["discharge_scale"]["scale"] == pytest.approx(a["scale"], abs=0.01), r
    if r["expected"]:
        # the gap a model can close: position RMS above the measurement noise, or the delivery error,
        # or the held-out cost with the pressure evidence (a 25 um reed leak: positions at the noise,
        # None, delivery 0.2-0.4 % off; it shows in the cylinder pressure)
        c0, c1 = r["held_out_cost"]
        reductions = (r["held_out_excess_reduction_pct"], r["held_out_delivery_reduction_pct"],
                      100 * (1 - c1 / c0) if c0 else None)
        assert any(x is not None and x >= 70 for x in reductions), r


def test_a_warm_started_revolution_is_the_cyclic_steady_state():
    """The workflow simulates two revolutions from a near neighbour's state at top dead centre, two or more from
    anywhere else (studies/discrepancy/pump_sim.py): both within 1e-4 of the delivery and, at the measurement
    times, 1 um and 1 kPa RMS of eight revolutions of the pump started at rest (the noise is 10 um, 10 kPa)."""
    from lumped.run.simulate import simulate as pump
    from studies.discrepancy.gap import periodic_interp
    from studies.discrepancy.pump_sim import FIT_RTOL, WARM_REVOLUTIONS

    c = RunCondition("r", "disc", 743.0, 2.81e6, 0.013)
    seat = lambda k: (Applied.of("seat_compliance", "delivery", {"k_seat": k}),)
    ref = pump(model_for(c, seat(1.5e6)), c.speed_rpm, c.load_pressure_pa, revolutions=8, rtol=FIT_RTOL,
               atol=FIT_RTOL / 100, trace=True, trace_points=7200).trace
    sim = for_valve_type("disc")
    cold = sim(c, seat(1.5e6))                                   # via the baseline's cycle, until steady
    warm = sim(c, seat(1.5e6), (sim(c, seat(1.55e6)).state, True))   # from a 3 % neighbour
    assert warm.revolutions == WARM_REVOLUTIONS and cold.revolutions >= 2
    th = np.linspace(0.0, 360.0, 3000, endpoint=False)
    for tr in (cold, warm):
        assert tr.delivery_m3_per_rev == pytest.approx(
            pump(model_for(c, seat(1.5e6)), c.speed_rpm, c.load_pressure_pa, revolutions=8, rtol=FIT_RTOL,
                 atol=FIT_RTOL / 100).delivery_per_rev, rel=1e-4)
        for v in ("inlet", "delivery"):
            d = periodic_interp(th, tr.crank_deg, tr.positions[v]) - periodic_interp(th, ref.crank_deg,
                                                                                       getattr(ref, f"{v}_position"))
            assert np.sqrt(np.mean(d**2)) < 1e-6
        d = periodic_interp(th, tr.crank_deg, tr.cylinder_pressure_pa) - periodic_interp(th, ref.crank_deg,
                                                                                          ref.cylinder_pressure)
        assert np.sqrt(np.mean(d**2)) < 1e3


def test_the_trace_is_sampled_finely_enough_to_interpolate():
    """The simulated trace is kept at the integrator's steps, their midpoints and 720 even angles: linear
    interpolation between them is within 0.5 kPa and 0.3 um RMS of the same integration's dense output at 20,000
    angles (a squeeze film's delivery-opening spike included; 1,440 even points left up to 9 kPa)."""
    from lumped.run.simulate import simulate as pump
    from studies.discrepancy.gap import periodic_interp
    from studies.discrepancy.pump_sim import TIGHT_RTOL, revolution

    c = RunCondition("r", "disc", 593.0, 2.76e6, 0.013)
    m = model_for(c, (Applied.of("squeeze_film", "both", {"C2": 7.4e-11}),))
    tr = revolution(m, c.speed_rpm, c.load_pressure_pa, None, TIGHT_RTOL, 200_000)
    dense = pump(m, c.speed_rpm, c.load_pressure_pa, revolutions=tr.revolutions, rtol=TIGHT_RTOL,
                 atol=TIGHT_RTOL / 100, trace=True, trace_points=20_000).trace
    th = dense.crank_deg
    dp = periodic_interp(th, tr.crank_deg, tr.cylinder_pressure_pa) - np.asarray(dense.cylinder_pressure)
    assert np.sqrt(np.mean(dp**2)) < 500.0
    for v in ("inlet", "delivery"):
        dx = periodic_interp(th, tr.crank_deg, tr.positions[v]) - np.asarray(getattr(dense, f"{v}_position"))
        assert np.sqrt(np.mean(dx**2)) < 3e-7


def test_baseline_uses_each_valve_types_thesis_pump():
    # synth and the fits share model_for: the reed pump's manifolds hold the inferred
    # V_tdc = 4.0e-5 m^3 (docs/errata.md, "Reed pump delivery offset"), the disc pump Table 5.1's
    reed = model_for(RunCondition("r", "reed", 600.0, 2.8e6, 0.008), ())
    disc = model_for(RunCondition("d", "disc", 593.0, 2.79e6, 0.013), ())
    assert reed.pump.dead_volume == pytest.approx(4.0e-5)
    assert disc.pump.dead_volume == pytest.approx(2.17e-5)
    assert reed.oil.air_content == pytest.approx(0.008) and disc.oil.air_content == pytest.approx(0.013)


def test_compliant_seat_sinks_by_the_pressure_force_over_k():
    # closed delivery valve during suction: the pressure difference over the Poiseuille-weighted
    # disc (C1 A_disc dP, eq 2.13) plus the spring preload, over k_seat (eq 2.20)
    c = RunCondition("r", "disc", 593.0, 2.79e6, 0.013)
    k = 1.5e6
    sim = simulate(c, (Applied.of("seat_compliance", "delivery", {"k_seat": k}),))
    d = model_for(c, ()).delivery
    p_cyl = float(np.min(sim.cylinder_pressure_pa))
    force = d.c1 * d.disc_area * (c.load_pressure_pa - p_cyl) + d.spring_stiffness * d.spring_preload
    assert float(np.min(sim.positions["delivery"])) == pytest.approx(-force / k, rel=0.03)


@pytest.mark.slow  # the same story runs in the default suite as docs/examples/ex05_oring_story.py
def test_thesis_oring_story():
    """Section 5.4.5: the delivery valve's O-ring compliance, found from the traces (k_seat 1.5e6 N/m)."""
    r = run_case("oring", [("seat_compliance", "delivery", {"k_seat": (1.5e6, 1.5e6)})], "disc", 0,
                 choose(valve_type="disc"), SETTINGS)
    check_found(r, "disc")
    assert r["targets"] == {"seat_compliance": "delivery"}
    assert r["gap_after"]["position_rms_m"] < 0.3 * r["gap_before"]["position_rms_m"]
    assert r["gap_after"]["delivery_error_pct"] < r["gap_before"]["delivery_error_pct"]


@pytest.mark.parametrize("valve,case", [("disc", "none"), ("disc", "cd-3%"), ("reed", "piston_leakage"),
                                       ("reed", "fluid_damping (strong)")])
def test_representative_cases(valve, case):
    check_found(run_case(case, CASES[valve][case], valve, 1, choose(valve_type=valve), SETTINGS), valve)


def test_squeeze_film_model_is_smooth_in_its_coefficient():
    """The workflow's simulator must respond smoothly to a parameter, or a fit's finite differences and
    the held-out test read integration error as evidence: with a squeeze film, C2 x (1 -+ 1e-2) must move
    the cylinder-pressure trace antisymmetrically (second difference below 20 % of the first; 65-138 % at the fast
    path's default rtol of 1e-3, studies/discrepancy/pump_sim.py)."""
    truth, conds = case_truth(CASES["disc"]["squeeze_film"], "disc", 3)
    c = next(c for c in conds if c.speed_rpm == 591.0 and c.load_pressure_pa == 3.67e6)
    c2 = truth[0].value_dict["C2"]
    from studies.discrepancy.gap import periodic_interp

    sim = for_valve_type("disc")
    th = np.linspace(0.0, 360.0, 3600, endpoint=False)
    p = []
    for f in (1 - 1e-2, 1.0, 1 + 1e-2):
        tr = sim(c, (Applied.of("squeeze_film", "both", {"C2": c2 * f}),))
        p.append(periodic_interp(th, tr.crank_deg, tr.cylinder_pressure_pa))
    first, second = p[2] - p[0], p[2] - 2 * p[1] + p[0]
    assert np.sqrt(np.mean(second**2)) < 0.2 * np.sqrt(np.mean(first**2))


#: the datasets of the slow matrix below that the workflow gets wrong, each a limit measured and set out in
#: docs/discrepancy.md ("Known limits" and the matrices' worst parameter errors); strict: a fix fails the test
#: until its entry goes
KNOWN_MISSES = {
    ("reed", "quadratic_drag", 1):
        "the reed's quadratic drag alone leaves no gap above the noise: nothing is named (docs/discrepancy.md, "
        "Known limits)",
    ("disc", "flow_force [jet_weak]", 1):
        "a flow force of another jet law: its effective L_t 26.6 % off (the force itself is matched)",
    ("reed", "added_mass+quadratic_drag", 1):
        "the drag gains 1.33 held-out units beside the added mass, under the 1.5 floor: the added mass named alone "
        "(docs/discrepancy.md)",
}


def _known(valve: str, case: str, seed: int, *values):
    """A pytest param of ``values``; a KNOWN_MISSES dataset as a strict expected failure."""
    why = KNOWN_MISSES.get((valve, case, seed))
    return pytest.param(*values, marks=pytest.mark.xfail(strict=True, reason=why) if why else ())


@pytest.mark.slow
@pytest.mark.parametrize("case,seed", [_known("disc", c, s, c, s) for s in (1, 2, 3) for c in CASES["disc"]])
def test_hidden_effect_named_disc(case, seed):
    check_found(run_case(case, CASES["disc"][case], "disc", seed, choose(valve_type="disc"), SETTINGS), "disc")


@pytest.mark.slow
@pytest.mark.parametrize("case", [_known("reed", c, 1, c) for c in CASES["reed"]])
def test_hidden_effect_named_reed(case):
    check_found(run_case(case, CASES["reed"][case], "reed", 1, choose(valve_type="reed"), SETTINGS), "reed")


@pytest.mark.slow
def test_a_fit_lost_to_the_cd_factors_trade_is_found_from_the_factors_prior():
    """The thesis reed's added mass, seed 1 (Gamma_f 3.85, no Cd error): the baseline fits the Cd factor at 0.969
    without it, and the candidate's profile linearised there ends at Gamma_f 4.08 with the held-out gap 169 ->
    190 units (nothing named); fitted again from the factor's prior (Settings.second_start) it is named within
    1 %. The same dataset without the second start names nothing: the mechanism, not the seed, finds it."""
    from dataclasses import replace

    sim = choose(valve_type="reed")
    on = run_case("added_mass", CASES["reed"]["added_mass"], "reed", 1, sim, SETTINGS)
    assert on["found"] == ["added_mass"] and abs(on["relative_errors"]["added_mass.Gamma_f"]) < 0.01, on
    off = run_case("added_mass", CASES["reed"]["added_mass"], "reed", 1, sim, replace(SETTINGS, second_start=False))
    assert off["found"] == [], off


@pytest.mark.slow
@pytest.mark.parametrize("valve,case", [_known(v, c, 1, v, c) for v in ("disc", "reed") for c in MISMATCH[v]])
def test_hidden_effect_named_in_data_of_another_model_form(valve, case):
    """Data made with a model form the library lacks (studies/discrepancy/mismatch.py), seed 1: the hidden effect
    named (nothing where nothing is hidden), its parameter within 20 % (a leak's effective clearance), the
    held-out gap shrunk by 70 %, and what is left said when it is large."""
    check_found(run_case(case, MISMATCH[valve][case], valve, 1, choose(valve_type=valve), SETTINGS), valve)


@pytest.mark.slow
@pytest.mark.parametrize("model,case", [("disc_20mm_pump", c) for c in ("piston_leakage", "seat_compliance@inlet",
                                                                        "squeeze_film", "none")]
                         + [("reed_stiff_pump", c) for c in ("added_mass", "seat_compliance@delivery", "none")])
def test_hidden_effect_named_on_another_pump(model, case):
    """Two pumps that are not the thesis rigs, given as model files (docs/examples/): a 20 mm bore disc pump and
    the reed pump with a 20 % thicker reed, at three conditions around their operating points."""
    from pathlib import Path

    sim = choose(model=str(Path(__file__).resolve().parents[1] / "docs" / "examples" / f"{model}.toml"))
    kind = sim.context.label
    check_found(run_case(case, CASES[kind][case], kind, 1, sim, SETTINGS), kind)
