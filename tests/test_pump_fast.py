"""The compiled pump path against the reference path (lumped.pump.simulate): same physics, same results."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lumped import pump as ref
from lumped import pump_fast as fast
from lumped import rodas
from lumped.params import OFF_DEL, V_XSTOP, pack, thesis_model
from studies.random_designs import random_design
from studies.thesis import experiments

DELIVERY_RTOL = 1e-3  # the acceptance: delivery within 0.1 % of the reference path


def _random_states(valve, rng, k=6):
    model = thesis_model(valve)
    p0 = pack(model, 650.0, 2.8e6)
    y0 = ref._initial_state(model, p0, ref.N_SIMPLIFIED)
    for _ in range(k):
        y = y0.copy()
        y[ref.S_MCYL] *= 1 + rng.uniform(-0.01, 0.004)
        y[ref.S_XIN], y[ref.S_XDEL] = rng.uniform(-2e-6, 1.2e-3, size=2)
        y[ref.S_UIN], y[ref.S_UDEL] = rng.uniform(-0.5, 0.5, size=2)
        mode = ref.auto_mode(y, p0)
        yield model, p0, y, mode, rng.uniform(0, 0.1)


@pytest.mark.parametrize("valve", ["disc", "reed"])
def test_compiled_physics_is_the_reference_physics(valve):
    """lumped.pump.evaluate compiled by numba gives the Python function's numbers."""
    rng = np.random.default_rng(5)
    evaluate = fast.cached(fast._evaluate)
    for model, p0, y, mode, t in _random_states(valve, rng):
        want = ref.evaluate(t, y.tolist(), p0.tolist(), mode)
        got = evaluate(t, y, fast._extended(p0, mode), tuple(mode))
        assert np.allclose(got, want, rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("valve", ["disc", "reed"])
def test_analytic_jacobian_equals_plain_differences(valve):
    """The chain-rule Jacobian and df/dt (no rhs call) agree with 6-call forward differences."""
    scope = dict(rodas.solve.py_func.__globals__, rhs=fast._rhs)
    plain = rodas._rebind(rodas.fd_jacobian, scope, f"test_plain_pump_{fast.DIGEST}", cache=True)
    analytic, rhs = fast.cached(fast._jacobian), fast.cached(fast._rhs)
    rng = np.random.default_rng(6)
    n = ref.N_SIMPLIFIED
    seen = set()
    for i, (model, p0, y, mode, t) in enumerate(_random_states(valve, rng, k=12)):
        if i % 3 == 1:      # inlet seated (pressed in by nanometres), delivery on its stop
            y[ref.S_XIN] = -rng.uniform(1e-10, 1e-8)
            y[ref.S_XDEL] = p0[OFF_DEL + V_XSTOP] * (1 + rng.uniform(1e-6, 1e-4))
            mode = ref.auto_mode(y, p0)
        seen.add((mode[0], mode[2]))
        for stale in (False, True):
            p = fast._extended(p0, mode)
            atol = ref._atol_vector(n, 1e-4, p0, model)
            f0 = np.empty(n)
            rhs(t, y, p, f0)
            if stale:                 # P_cyl left by another call: the Jacobian must not use it
                p[fast.STASH + 1] *= 1.001
            ja, fa, jb, fb = np.empty((n, n)), np.empty(n), np.empty((n, n)), np.empty(n)
            assert analytic(t, y, p, f0, ja, fa, np.empty(n), np.empty(n), atol, 1e-4, 5, 1e-6) == 0
            assert plain(t, y, p, f0, jb, fb, np.empty(n), np.empty(n), atol, 1e-4, 5, 1e-6) == 6
            scale = np.abs(jb).max(axis=0) + 1e-300
            assert np.all(np.abs(ja - jb) <= 1e-5 * scale + 1e-9 * np.abs(jb).max())
            assert np.allclose(fa, fb, rtol=2e-4, atol=2e-4 * np.abs(fb).max())
    assert (ref.SEAT, ref.STOP) in seen and (ref.FREE, ref.FREE) in seen


def _compare(valve, speed, load, air, revolutions=3, params=None):
    r = ref.simulate(valve, speed, load, air_content=air, revolutions=revolutions, params=params)
    f = fast.simulate(valve, speed, load, air_content=air, revolutions=revolutions, params=params)
    assert f.method == "fast" and f.revolutions == r.revolutions
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=DELIVERY_RTOL)
    # every revolution, not just the last, follows the reference
    assert np.allclose(f.deliveries, r.deliveries, rtol=DELIVERY_RTOL)
    assert f.mass_balance_error < 1e-9
    for a, b in zip(f.peak_opening, r.peak_opening):
        assert a == pytest.approx(b, rel=0.01)
    for fa, ra in zip(f.opening_angle + f.closing_angle, r.opening_angle + r.closing_angle):
        assert (fa is None) == (ra is None)
        if fa is not None:
            d = abs(fa - ra) % (2 * math.pi)
            assert min(d, 2 * math.pi - d) < math.radians(0.5)  # 0.16 deg on the 12 cases; grazing lift-offs move most
    # stop_contacts is not compared here: where a disc leaves its stop grazing (u ~ 0), the
    # count depends on the velocity tolerance (see test_same_switches_at_tight_tolerance)
    return r, f


def test_same_switches_at_tight_tolerance():
    """At the reference's tolerances the fast path makes the very same switches."""
    r = ref.simulate("disc", 593.0, 2.76e6, revolutions=2)
    f = fast.simulate("disc", 593.0, 2.76e6, revolutions=2, rtol=1e-6, atol=1e-6)
    assert f.events == r.events and f.stop_contacts == r.stop_contacts
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=1e-5)


@pytest.mark.parametrize("index", [0, 5, 6, 11])
def test_fast_matches_reference_on_validation_cases(index):
    """Two disc and two reed cases of Tables 5.4 / 5.6 (all 12: the slow test below)."""
    c = experiments()[index]
    _compare(c["valve"], c["speed_rpm"], c["load_pressure"], c["air_content"])


@pytest.mark.slow
@pytest.mark.parametrize("index", range(12))
def test_fast_matches_reference_on_all_validation_cases(index):
    c = experiments()[index]
    r, f = _compare(c["valve"], c["speed_rpm"], c["load_pressure"], c["air_content"], revolutions=5)
    assert f.cyclic_steady == r.cyclic_steady


@pytest.mark.parametrize("seed, valve", [(1, "disc"), (2, "reed")])
def test_fast_matches_reference_on_random_designs(seed, valve):
    rng = np.random.default_rng(seed)
    speed, load, air, model = random_design(rng, valve)
    _compare(valve, speed, load, air, params=model)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(10, 30))
def test_fast_matches_reference_on_many_random_designs(seed):
    rng = np.random.default_rng(seed)
    valve = ("disc", "reed")[seed % 2]
    speed, load, air, model = random_design(rng, valve)
    _compare(valve, speed, load, air, params=model)


def test_trace_follows_the_reference():
    r = ref.simulate("reed", 743.0, 2.76e6, revolutions=3, trace=True, trace_points=720)
    f = fast.simulate("reed", 743.0, 2.76e6, revolutions=3, trace=True, trace_points=720)
    assert np.allclose(f.trace.time, r.trace.time)
    for name, tol in (("inlet_position", 2e-5), ("delivery_position", 2e-5), ("cylinder_pressure", 5e4)):
        a, b = getattr(f.trace, name), getattr(r.trace, name)
        # the same curve up to integration error (a median, the valve-opening ringing is sharp)
        assert np.median(np.abs(a - b)) < tol / 10 and np.mean(np.abs(a - b)) < tol


def test_bad_input_is_refused_like_the_reference():
    from geometry.errors import InputError

    with pytest.raises(InputError) as exc:
        fast.simulate("disc", -5.0, 2.8e6)
    assert exc.value.field == "speed_rpm"
    with pytest.raises(InputError) as exc:
        fast.simulate("disc", 600.0, 2.8e6, params=thesis_model("reed"))
    assert exc.value.field == "params"
    with pytest.raises(InputError) as exc:
        fast.simulate("disc", 600.0, 2.8e6, contact_atol=-1.0)
    assert exc.value.field == "contact_atol"


def test_leakage_and_velocities_follow_the_reference():
    from lumped.params import set_effect

    model = set_effect(thesis_model("disc"), "piston_leakage", True)
    r = ref.simulate("disc", 593.0, 2.76e6, revolutions=2, params=model, trace=True, trace_points=360)
    f = fast.simulate("disc", 593.0, 2.76e6, revolutions=2, params=model, trace=True, trace_points=360)
    assert r.leakage_per_rev > 0
    assert f.leakage_per_rev == pytest.approx(r.leakage_per_rev, rel=1e-3)
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=DELIVERY_RTOL)
    assert np.median(np.abs(f.trace.inlet_velocity - r.trace.inlet_velocity)) < 1e-3


def test_cyclic_steady_state_is_judged_at_the_fast_paths_accuracy():
    """A design the reference finds cyclic (change 5e-8 after five revolutions) is cyclic on
    the fast path too, although its revolution-to-revolution noise at rtol 1e-3 is ~6e-4
    (before this was allowed for, 10 % of random designs were wrongly flagged not cyclic)."""
    args = ("disc", 854.421904517335, 1958595.0694370186)   # a random draw, change 5.9e-4 at rtol 1e-3
    air = 0.021386707876997053
    r = ref.simulate(*args, air_content=air, revolutions=5)
    f = fast.simulate(*args, air_content=air, revolutions=5)
    assert r.cyclic_steady and f.cyclic_steady
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=DELIVERY_RTOL)
    # a design that has not settled is still reported as such: two revolutions from rest
    assert not fast.simulate(*args, air_content=air, revolutions=2).cyclic_steady
