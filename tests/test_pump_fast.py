"""The fast stepper (compiled Rodas4P, Rodas5P with a flow force) against the reference stepper (scipy Radau): same physics, same results."""

from __future__ import annotations

import math

import numpy as np
import pytest

from geometry.errors import InputError
from lumped.solver import compiled
from lumped.solver import rhs as R
from lumped.solver import switching as sw
from lumped.solver.layout import G, N_MODE, OFF_IN, SWITCH, StateLayout
from lumped.run.simulate import simulate
from lumped.solver.layout import pack
from lumped.model.model_file import load_model, with_values
from studies.discrepancy import confusion
from studies.discrepancy.pump_sim import for_valve_type
from studies.discrepancy.workflow import RunCondition
from lumped.valves.kind import KINDS, VALVE
from lumped.model.random_designs import mixed_model, random_design
from studies.tables.thesis import experiments

DELIVERY_RTOL = 1e-3  # the acceptance: delivery within 0.1 % of the reference path
ANGLE_TOL = math.radians(0.5)


def _random_states(model, rng, k=6):
    p0 = pack(model, 650.0, 2.8e6)
    lay = StateLayout((1, 1))
    for _ in range(k):
        y = np.zeros(lay.n_states)
        y[lay.index("m_cyl")] = model.oil.density_at(2.8e6) * model.pump.dead_volume * (1 + rng.uniform(-0.01, 0.004))
        y[lay.index("inlet.x")], y[lay.index("delivery.x")] = rng.uniform(-2e-6, 1.2e-3, size=2)
        y[lay.index("inlet.u")], y[lay.index("delivery.u")] = rng.uniform(-0.5, 0.5, size=2)
        t = rng.uniform(0, 0.1)
        mode = np.zeros(N_MODE)
        sw.initial_mode(t, y, p0, mode)
        yield p0, y, mode, t


@pytest.mark.parametrize("name", [*(f"thesis-{k}" for k in KINDS), "mixed"])
@pytest.mark.parametrize("one_dof", [True, False])
def test_compiled_physics_is_the_reference_physics(name, one_dof):
    """lumped.solver.rhs.evaluate compiled by numba (both flavours, lumped.solver.compiled.physics) gives the Python
    function's numbers (every field and every derivative)."""
    model = mixed_model() if name == "mixed" else load_model(name)
    evaluate = compiled.cached("lumped.solver.rhs", "evaluate", one_dof)
    for p0, y, mode, t in _random_states(model, np.random.default_rng(5)):
        d_want, d_got = np.empty(len(y)), np.empty(len(y))
        want = R.evaluate(t, y.tolist(), p0.tolist(), mode.tolist(), d_want)
        got = evaluate(t, y, p0, mode, d_got)
        assert np.allclose(tuple(got), tuple(want), rtol=1e-12, atol=1e-300)
        assert np.allclose(d_got, d_want, rtol=1e-12, atol=1e-300)
        assert got._fields == want._fields


def _angles(res):
    return [res.inlet.opening_angle, res.delivery.opening_angle, res.inlet.closing_angle, res.delivery.closing_angle]


def _compare(model, speed, load, air, revolutions=3, counts=False, every=True, rtol=None):
    r = simulate(model, speed, load, air_content=air, revolutions=revolutions, method="reference")
    f = simulate(model, speed, load, air_content=air, revolutions=revolutions, method="fast", rtol=rtol,
                 atol=None if rtol is None else rtol / 100.0)
    assert f.method == "fast" and r.method == "reference" and f.revolutions == r.revolutions
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=DELIVERY_RTOL)
    # every revolution, not just the last, follows the reference (every=False: from the second)
    first = 0 if every else 1
    assert np.allclose(f.deliveries[first:], r.deliveries[first:], rtol=DELIVERY_RTOL)
    assert f.mass_balance_error < 1e-9
    for pos in ("inlet", "delivery"):
        assert f.valves[pos].peak_opening == pytest.approx(r.valves[pos].peak_opening, rel=0.01)
    for fa, ra in zip(_angles(f), _angles(r)):
        assert (fa is None) == (ra is None)
        if fa is not None:
            d = abs(fa - ra) % (2 * math.pi)
            assert min(d, 2 * math.pi - d) < ANGLE_TOL
    if counts:
        assert [v.stop_contacts for v in f.valves.values()] == [v.stop_contacts for v in r.valves.values()]
    return r, f


@pytest.mark.parametrize("index", [0, 5, 6, 11])
def test_fast_matches_reference_on_validation_cases(index):
    """Two disc and two reed cases of Tables 5.4 / 5.6 (all 12: the slow test below), contact counts equal."""
    c = experiments()[index]
    _compare(f"thesis-{c['valve']}", c["speed_rpm"], c["load_pressure"], c["air_content"], counts=True)


@pytest.mark.slow
@pytest.mark.parametrize("index", range(12))
def test_fast_matches_reference_on_all_validation_cases(index):
    c = experiments()[index]
    r, f = _compare(f"thesis-{c['valve']}", c["speed_rpm"], c["load_pressure"], c["air_content"], revolutions=5,
                    counts=True)
    assert f.cyclic_steady == r.cyclic_steady


@pytest.mark.parametrize("seed, valve", [(1, "disc"), (2, "reed"), (3, "mixed"), (4, "ball"), (5, "ball/reed"),
                                         (18, "ball")])
def test_fast_matches_reference_on_random_designs(seed, valve):
    speed, load, air, model = random_design(np.random.default_rng(seed), valve)
    _compare(model, speed, load, air)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(10, 30))
def test_fast_matches_reference_on_many_random_designs(seed):
    """Design 18 (a ball pump at 649.7 rpm, 3.65 MPa) opened its inlet 7-9 deg late on the fast path before the
    ball's seat velocity tolerance and the accuracy check (lumped.run.accuracy); it passes now."""
    from lumped.model.random_designs import VALVES

    valve = VALVES[seed % len(VALVES)]
    speed, load, air, model = random_design(np.random.default_rng(seed), valve)
    _compare(model, speed, load, air)


def test_complete_circuit_on_the_fast_path():
    """Accumulator, needle valve and load line compiled too: delivery and mean load pressure within 0.1 %."""
    kw = dict(circuit="complete", revolutions=5, max_revolutions=40)
    r = simulate("thesis-disc", 593.0, 2.76e6, method="reference", **kw)
    f = simulate("thesis-disc", 593.0, 2.76e6, method="fast", **kw)
    assert f.circuit == "complete" and f.method == "fast" and f.cyclic_steady and r.cyclic_steady
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=DELIVERY_RTOL)
    assert f.mean_load_pressure == pytest.approx(r.mean_load_pressure, rel=DELIVERY_RTOL)
    assert f.mean_load_pressure == pytest.approx(2.76e6, rel=1e-3)
    assert f.needle_area == pytest.approx(r.needle_area, rel=5e-3)


def test_trace_follows_the_reference():
    r = simulate("thesis-reed", 743.0, 2.76e6, revolutions=3, trace=True, trace_points=720, method="reference")
    f = simulate("thesis-reed", 743.0, 2.76e6, revolutions=3, trace=True, trace_points=720, method="fast")
    assert np.allclose(f.trace.time, r.trace.time)
    for name, tol in (("inlet_position", 2e-5), ("delivery_position", 2e-5), ("cylinder_pressure", 5e4)):
        a, b = getattr(f.trace, name), getattr(r.trace, name)
        # the same curve up to integration error (a median, the valve-opening ringing is sharp)
        assert np.median(np.abs(a - b)) < tol / 10 and np.mean(np.abs(a - b)) < tol


def test_bad_input_is_refused_on_both_paths():
    for method in ("fast", "reference"):
        with pytest.raises(InputError) as exc:
            simulate("thesis-disc", -5.0, 2.8e6, method=method)
        assert exc.value.field == "speed_rpm"
    with pytest.raises(InputError) as exc:
        simulate("thesis-disc", 600.0, 2.8e6, contact_atol=-1.0)
    assert exc.value.field == "contact_atol"


def test_leakage_and_velocities_follow_the_reference():
    model = with_values(load_model("thesis-disc"), {"effects.piston_leakage": True})
    r = simulate(model, 593.0, 2.76e6, revolutions=2, trace=True, trace_points=360, method="reference")
    f = simulate(model, 593.0, 2.76e6, revolutions=2, trace=True, trace_points=360, method="fast")
    assert r.leakage_per_rev > 0
    assert f.leakage_per_rev == pytest.approx(r.leakage_per_rev, rel=1e-3)
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=DELIVERY_RTOL)
    assert np.median(np.abs(f.trace.inlet_velocity - r.trace.inlet_velocity)) < 1e-3


def test_cyclic_steady_state_is_judged_at_the_fast_paths_accuracy():
    """A design the reference finds cyclic after five revolutions is cyclic on the fast path too,
    although its revolution-to-revolution noise at rtol 1e-3 is ~6e-4 (before this was allowed
    for, 10 % of random designs were wrongly flagged not cyclic)."""
    args = ("thesis-disc", 854.421904517335, 1958595.0694370186)   # a random draw, change 5.9e-4 at rtol 1e-3
    air = 0.021386707876997053
    r = simulate(*args, air_content=air, revolutions=5, method="reference")
    f = simulate(*args, air_content=air, revolutions=5, method="fast")
    assert r.cyclic_steady and f.cyclic_steady
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=DELIVERY_RTOL)
    # a design that has not settled is still reported as such: two revolutions from rest
    assert not simulate(*args, air_content=air, revolutions=2).cyclic_steady


def test_a_stop_contact_needs_a_real_excursion():
    """A return to the stop counts only after the element was CONTACT_EXCURSION x gap clear of it."""
    from types import SimpleNamespace

    from lumped.solver.layout import Event
    from lumped.run.postprocess import CONTACT_EXCURSION, stop_arrivals
    from lumped.solver.problem import PumpProblem

    problem = PumpProblem.build(load_model("thesis-disc"), 600.0, 2.8e6)
    gap = problem.model.delivery.stop_gap
    xi = problem.layout.index("delivery.x")

    def span(dip):
        # delivery valve: arrives at t=1, leaves at t=2, x dips by `dip` at t=2.5, back at t=3
        def sample(ts):
            y = np.zeros((len(ts), problem.layout.n_states))
            y[:, xi] = gap - dip * np.sin(np.pi * np.clip(ts - 2.0, 0.0, 1.0))
            return y, None
        ev = [Event(1.0, "delivery", "contact", "free", "stop"), Event(2.0, "delivery", "contact", "stop", "free"),
              Event(3.0, "delivery", "contact", "free", "stop")]
        return SimpleNamespace(events=ev, sample=sample)

    assert stop_arrivals(span(1e-9), problem, 1) == 1           # a nanometre: one contact
    assert stop_arrivals(span(3 * CONTACT_EXCURSION * gap), problem, 1) == 2   # a rebound: two


def _flow_force_model():
    """The discrepancy workflow's disc model with a flow force (jet 54 deg, L_t 12.5 mm) and Cd x 0.998 at
    593 rpm / 2.76 MPa: where the fast path lifted the inlet disc off 1.2 deg late while its opening
    decided the lift-off (a jet angle 2e-5 rad larger: 4.7 deg)."""
    from lumped.model.effects import Applied

    effects = (Applied.of("discharge_scale", "both", {"scale": 0.998}),
               Applied.of("flow_force", "both", {"theta_jet": math.radians(54), "L_t": 0.0125}))
    return for_valve_type("disc").model_for(RunCondition("r", "disc", 593.0, 2.76e6, 0.013), effects)


def test_lift_off_follows_the_reference_on_a_flow_force_model():
    _compare(_flow_force_model(), 593.0, 2.76e6, None, revolutions=2)


@pytest.mark.parametrize("rtol", [1e-4, 1e-5])
def test_rodas5p_follows_the_reference_on_a_flow_force_model_in_fewer_steps(rtol, monkeypatch):
    """Where a valve carries a flow force the fast path steps with Rodas5P at rtol <= 1e-4
    (lumped.solver.steppers.rodas_order): it matches scipy's Radau as Rodas4P must (delivery 0.1 %, angles 0.5 deg)
    and takes at least a quarter fewer steps than Rodas4P at the same tolerance (the transient force's
    slaved velocity, which Rodas4P's error estimate over-reads), with the same delivery to 2e-4."""
    from lumped.solver import steppers

    model = _flow_force_model()
    assert steppers.rodas_order(rtol, True) == 5 and steppers.rodas_order(1e-3, True) == 4
    _, five = _compare(model, 593.0, 2.76e6, None, revolutions=2, rtol=rtol)
    monkeypatch.setattr(steppers, "RODAS5P_FLOW_RTOL", 0.0)           # Rodas4P at the same tolerance
    four = simulate(model, 593.0, 2.76e6, revolutions=2, method="fast", rtol=rtol, atol=rtol / 100.0)
    assert five.steps < 0.75 * four.steps
    assert five.delivery_per_rev == pytest.approx(four.delivery_per_rev, rel=2e-4)


@pytest.mark.parametrize("method", ["fast", "reference"])
def test_disc_lifts_off_where_the_pressure_balances_the_spring(method):
    """A seated disc has no flow and no speed, so it lifts off where C1 (P_tank - P_cyl) A_disc = k_spr x_pre
    (eqs 2.13, 2.14, 2.19): the cylinder pressure at the located inlet opening, read off a 0.01 deg trace,
    matches that closed form to the pressure change of 0.02 deg."""
    model = _flow_force_model()
    r = simulate(model, 593.0, 2.76e6, revolutions=2, trace=True, trace_points=36_000, method=method)
    tr = r.trace
    deg = tr.crank_deg
    v = model.inlet
    dp_star = v.spring_stiffness * v.spring_preload / (v.c1 * v.disc_area)
    pc = np.interp(math.degrees(r.inlet.opening_angle), deg, tr.cylinder_pressure)
    rate = np.interp(math.degrees(r.inlet.opening_angle), deg[1:], np.diff(tr.cylinder_pressure) / np.diff(deg))
    assert abs((model.pump.tank_pressure - pc) - dp_star) < 0.02 * abs(rate)


@pytest.mark.slow
@pytest.mark.parametrize("valve, case", [(v, c) for v in ("disc", "reed") for c in confusion.CASES[v]])
def test_fast_matches_reference_on_the_discrepancy_models(valve, case):
    """Every hidden effect of the discrepancy workflow's confusion cases (seed 1), at the thesis's three runs, on
    the fast path at the tolerance the workflow simulates that model with (studies/discrepancy/pump_sim.py:
    rtol 1e-4, 1e-5 with a squeeze film or an added mass): delivery within 0.1 %, angles within 0.5 deg, from
    the second revolution on (the workflow reads the second; the start from rest of a sticking or heavy valve
    differs by 1-2 % in the first). At the fast path's default rtol 1e-3 four of these models missed: a
    delivery-valve film's peak opening 13.2 % above the reference's (2.3 % beside an inlet seat), the reed's
    added mass with the quadratic drag 0.16 % in delivery, entrained air with a leak an angle by 0.61 deg:
    why the workflow does not simulate them there."""
    from studies.discrepancy.pump_sim import fit_rtol

    truth, conds = confusion.case_truth(confusion.CASES[valve][case], valve, 1)
    for c in conds[:3]:
        cond = RunCondition("r", valve, c.speed_rpm, c.load_pressure_pa, c.air_content)
        model = for_valve_type(valve).model_for(cond, truth)
        _compare(model, c.speed_rpm, c.load_pressure_pa, None, every=False, rtol=fit_rtol(model))


def test_only_a_valve_near_lift_off_has_its_force_evaluated():
    """A settled seated valve's switching function is its deflection -x while it sits deeper than
    DEEP_FRACTION of the load-pressure deflection (held for sure: no force evaluation), and the
    force's -a_f m / k_seat nearer lift-off; the two measure the same deflection, so they agree
    where a valve's deflection is its quasi-static one."""
    p = pack(load_model("thesis-disc"), 593.0, 2.76e6)
    o = OFF_IN
    k, area = p[o + VALVE.seat_k], p[o + VALVE.contact_area]
    delta = p[G.load_pressure] * area / k
    mode = np.zeros(N_MODE)                  # both valves on their seats, liquid cylinder
    lay = StateLayout((1, 1))
    g = np.empty(sw.N_SWITCHES + lay.n_states)
    y = np.zeros(lay.n_states)
    y[lay.index("m_cyl")] = 1e-3
    for depth, force in ((0.5 * delta, False), (0.01 * delta, True)):
        assert sw.force_decides(depth, 0.0, p, o, k) == force
        y[lay.index("inlet.x")] = -depth
        sw.switch_values(0.0, y, p, mode, g)
        a_f = sw.free_accelerations(0.0, y, p, mode, np.empty(lay.n_states))[0]
        assert g[SWITCH.inlet_seat] == (-a_f * p[o + VALVE.moving_mass] / k if force else depth)
    assert not sw.force_decides(0.01 * delta, 1.0, p, o, k)      # moving: the deflection decides
