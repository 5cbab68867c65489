"""Gap metrics and their wording, on traces whose answer is known by construction."""

import re

import numpy as np
import pytest

from studies.discrepancy.gap import (
    CycleTrace, GapScales, Nuisance, fit_nuisance, fold, noise_std, run_gap, valve_events, wrap_deg,
)
from studies.discrepancy.words import describe, findings
from studies.discrepancy.measured import Run, Trace
from studies.tables.thesis import experiments

GRID = np.arange(0.0, 360.0, 0.2)


def lift(theta, open_deg, close_deg, peak=1e-3, ramp=10.0, seat=0.0):
    span = np.mod(close_deg - open_deg, 360.0)
    s = np.mod(theta - open_deg, 360.0)
    f = np.clip(np.minimum(s / ramp, (span - s) / ramp), 0.0, 1.0)
    return peak * f + seat * (1 - np.ceil(f))


def measured_run(x_of_theta, rpm=600.0, valve="delivery", noise=0.0, seed=0, delivery=None, revs=1):
    n = int(revs * 60 / rpm * 1e4)
    t = np.arange(n) / 1e4
    th = np.mod(t * rpm * 6, 360)
    x = x_of_theta(th) + np.random.default_rng(seed).normal(0, noise, n) if noise else x_of_theta(th)
    return Run("r", "disc", rpm, 2.8e6, valve, delivery, None, Trace.measured(t, {valve: x}, speed_rpm=rpm))


def sim_of(x_of_theta, valve="delivery", delivery=1.7e-6):
    return CycleTrace(GRID, {valve: x_of_theta(GRID), "inlet" if valve == "delivery" else "delivery": GRID * 0},
                      delivery)


def test_noise_estimate_ignores_the_signal():
    run = measured_run(lambda th: lift(th, 200, 10), noise=1e-5, revs=3)
    assert noise_std(run.trace.positions["delivery"]) == pytest.approx(1e-5, rel=0.06)


@pytest.mark.parametrize("open_deg,close_deg", [(20.0, 190.0), (205.0, 8.0)])
def test_events_of_a_trapezoid(open_deg, close_deg):
    x = lift(GRID, open_deg, close_deg, ramp=10.0)
    ev = valve_events(GRID, x, threshold_m=0.5e-3, smooth_deg=0)
    # threshold at half the lift is crossed half a ramp after the opening starts
    assert wrap_deg(ev.opening_deg - (open_deg + 5.0)) == pytest.approx(0.0, abs=0.05)
    assert wrap_deg(ev.closing_deg - (close_deg - 5.0)) == pytest.approx(0.0, abs=0.05)
    assert ev.peak_m == pytest.approx(1e-3)


def test_late_closing_and_seat_in_words():
    # measured: closes 9 deg later than the model and sits 0.3 mm below the seat while closed
    meas = measured_run(lambda th: lift(th, 205, 9, seat=-3e-4), noise=5e-6)
    sim = sim_of(lambda th: lift(th, 205, 0))
    g = run_gap(meas, fold(meas), sim, Nuisance())
    v = g.valves[0]
    assert v.closing_error_deg == pytest.approx(9.0, abs=0.3)
    assert v.opening_error_deg == pytest.approx(0.0, abs=0.3)
    assert v.seated_error_m == pytest.approx(-3e-4, abs=5e-6)
    words = describe(findings(g, GapScales()), {"delivery": 1})
    late = next(s for s in words if "closes" in s)
    assert re.search(r"delivery valve closes (8\.[89]|9\.[01]) deg late", late), late
    seat = next(s for s in words if "sits" in s)
    assert "0.30 mm below" in seat and "suction stroke" in seat


def test_rms_of_a_known_offset():
    meas = measured_run(lambda th: np.full_like(th, 1e-4))
    g = run_gap(meas, fold(meas), sim_of(lambda th: th * 0), Nuisance())
    assert g.position_rms_m == pytest.approx(1e-4)


def test_nuisances_recovered():
    rpm, scale, offset = 743.0, 1.0112, 1.5e-4
    shift = offset * rpm * 6

    def truth(th):
        return lift(th, 205, 5)

    meas = measured_run(lambda th: scale * truth(th - shift), rpm=rpm, noise=1e-5)
    sims = {"r": sim_of(truth)}
    nu = fit_nuisance([meas], {"r": fold(meas)}, sims)
    assert nu.scale["delivery"] == pytest.approx(scale, abs=1.5e-3)
    assert nu.offset_s == pytest.approx(offset, abs=1e-5)
    assert run_gap(meas, fold(meas), sims["r"], nu).position_rms_m == pytest.approx(1e-5, rel=0.1)


@pytest.mark.parametrize("case", [c for c in experiments() if c["table"] == "5.4"])
def test_delivery_error_has_the_thesis_sign(case):
    # Table 5.4: % error = (modelled - measured) / measured
    meas = measured_run(lambda th: th * 0, delivery=case["measured_delivery"] * 1e6)
    sim = sim_of(lambda th: th * 0, delivery=case["thesis_modeled_delivery"])
    g = run_gap(meas, fold(meas), sim, Nuisance())
    assert g.delivery_error_pct == pytest.approx(case["thesis_error_pct"], abs=0.06)
