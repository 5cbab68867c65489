"""The compiled Rodas4P and Rodas5P integrators against closed forms and scipy's Radau."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from lumped.solver import rodas


@numba.njit(cache=True)
def _vdp(t, y, p, dy):
    dy[0] = y[1]
    dy[1] = ((1.0 - y[0] ** 2) * y[1] - y[0]) / p[0]


@numba.njit(cache=True)
def _forced(t, y, p, dy):
    # Prothero-Robinson: y' = lam (y - sin t) + cos t, y = sin t + y0 e^(lam t); stiff for lam << 0
    dy[0] = p[0] * (y[0] - math.sin(t)) + math.cos(t)
    dy[1] = y[0]  # quadrature of y: never feeds back (n_dyn = 1)


@numba.njit(cache=True)
def _impact(t, y, p, dy):
    # a mass moving onto a linear spring-dashpot wall at x < 0 (the seat model of eq 2.20)
    k, c, m = p[0], p[1], p[2]
    f = 0.0
    if y[0] < 0.0:
        f = -k * y[0] - c * y[1]
    dy[0] = y[1]
    dy[1] = f / m


@numba.njit(cache=True)
def _ball(t, y, p, dy):
    # a ball in flight under gravity (y = height, velocity); the floor is an event
    dy[0] = y[1]
    dy[1] = -p[0]


@numba.njit(cache=True)
def _ball_events(t, y, p, g):
    g[0] = y[0] if y[1] < 0.0 else 1.0   # hits the floor on the way down


@numba.njit(cache=True)
def _ball_bounce(k, t, y, p):
    y[0] = 0.0
    y[1] = -p[1] * y[1]                    # restitution
    p[2] += 1.0                            # bounce counter, changes the model state
    return int(p[2])


@numba.njit(cache=True)
def _ball_tag(p):
    return int(p[2])


@numba.njit(cache=True)
def _floor(t, y, p, dy):
    # a ball under gravity on a stiff spring-dashpot floor (the seat model of eq 2.20) while p[3] = 1
    dy[0] = y[1]
    dy[1] = -p[0]
    if p[3] > 0.5:
        dy[1] += (-p[1] * y[0] - p[2] * y[1])


@numba.njit(cache=True)
def _floor_events(t, y, p, g):
    g[0] = y[0] if p[3] < 0.5 else 1.0     # lands: contact starts
    g[1] = -y[0] if p[3] > 0.5 else 1.0    # lifts off


@numba.njit(cache=True)
def _floor_switch(k, t, y, p):
    p[3] = 1.0 if k == 0 else 0.0
    return 1 + k


vdp = rodas.specialize(_vdp, "test_vdp")
floor = rodas.specialize(_floor, "test_floor", events=_floor_events, apply=_floor_switch)
ball = rodas.specialize(_ball, "test_ball", events=_ball_events, apply=_ball_bounce, tagger=_ball_tag)
forced = rodas.specialize(_forced, "test_forced")
impact = rodas.specialize(_impact, "test_impact")


ORDERS = pytest.mark.parametrize("order", [4, 5], ids=["rodas4p", "rodas5p"])


@numba.njit(cache=True)
def _oscillator(t, y, p, dy):
    dy[0] = y[1]
    dy[1] = -y[0]


@numba.njit(cache=True)
def _riccati(t, y, p, dy):
    # y' = -y^2 from 1: y = 1/(1 + t); its quadrature ln(1 + t)
    dy[0] = -y[0] * y[0]
    dy[1] = y[0]


oscillator = rodas.specialize(_oscillator, "test_oscillator")
riccati = rodas.specialize(_riccati, "test_riccati")


def _fixed_steps(solver, y0, h, order, T=2.0):
    """A run whose steps are all hmax = h: the error test never binds (rtol 1e3)."""
    r = solver(0.0, y0, np.array([T]), np.zeros(1),
               rodas.Options(1e3, np.full(2, 1e3), h, h, 10**6, 2, 0.0, 0, 0, 1, np.zeros(0), order))
    assert r.status == rodas.OK and r.n_steps == round(T / h)
    return r


@ORDERS
def test_order_of_steps_and_dense_output_against_closed_forms(order):
    """Halving a fixed step divides the end error of y' = -y^2 by about 2^order, and the dense output's
    largest error between steps on a harmonic oscillator by 2^order too (Rodas4P's 3rd-order interpolant
    has a local error of h^4, Rodas5P's 4th-order one of h^5), against 1/(1 + t) and cos t."""
    end = [abs(_fixed_steps(riccati, np.array([1.0, 0.0]), h, order).y_stops[-1, 0] - 1.0 / 3.0)
           for h in (0.05, 0.025)]
    assert math.log2(end[0] / end[1]) > order - 0.45
    tt = np.linspace(0.0, 2.0, 1001)
    dense_err = []
    for h in (0.1, 0.05):
        r = _fixed_steps(oscillator, np.array([1.0, 0.0]), h, order)
        yy = rodas.interpolate(tt, r.rec_t, r.rec_y, r.rec_q2, r.rec_q3, r.rec_q4)
        dense_err.append(np.max(np.abs(yy[:, 0] - np.cos(tt))))
    assert math.log2(dense_err[0] / dense_err[1]) == pytest.approx(order, abs=0.15)


@ORDERS
def test_stiff_van_der_pol_matches_radau(order):
    eps, y0, T = 1e-6, np.array([2.0, -0.66]), 2.0
    ref = solve_ivp(
        lambda t, y: [y[1], ((1 - y[0] ** 2) * y[1] - y[0]) / eps], (0, T), y0, method="Radau",
        rtol=1e-12, atol=1e-12,
        jac=lambda t, y: [[0, 1], [(-2 * y[0] * y[1] - 1) / eps, (1 - y[0] ** 2) / eps]],
    )
    steps = []
    for rtol, tol in [(1e-6, 2e-6), (1e-9, 5e-9)]:
        r = vdp(0.0, y0, np.array([T]), np.array([eps]),
                rodas.Options(rtol, np.full(2, rtol), 1e-6, np.inf, 10**6, 2, np.inf, 0, 0, 1, np.zeros(0), order))
        assert r.status == rodas.OK
        assert np.allclose(r.y_stops[-1], ref.y[:, -1], rtol=0, atol=tol)
        steps.append(r.n_steps)
    assert steps[0] < 2000  # a stiff solver: the step follows the slow manifold


@ORDERS
def test_stops_dense_output_and_quadrature_against_closed_form(order):
    lam = -1e4
    stops = np.array([0.5, 1.0, 2.0, 3.0])
    r = forced(0.0, np.array([1.0, 0.0]), stops, np.array([lam]),
               rodas.Options(1e-8, np.array([1e-12, 1e-12]), 1e-8, np.inf, 10**6, 1, 1.0, 0, 0, 1, np.zeros(0), order))
    st, ys, rt, ry, q2, q3, ns = r.status, r.y_stops, r.rec_t, r.rec_y, r.rec_q2, r.rec_q3, r.n_steps
    assert st == rodas.OK
    exact = np.sin(stops) + np.exp(lam * stops)
    assert np.allclose(ys[:, 0], exact, rtol=0, atol=1e-9)
    # the quadrature state: integral of y = 1 - cos t + (e^(lam t) - 1)/lam
    assert np.allclose(ys[:, 1], 1 - np.cos(stops) + (np.exp(lam * stops) - 1) / lam, rtol=0, atol=1e-8)
    assert rt[0] == 1.0 and rt[-1] == 3.0  # recording starts on the stop at t_record
    # the dense output between steps is as accurate as the steps themselves
    tt = np.linspace(1.0, 3.0, 997)
    yy = rodas.interpolate(tt, rt, ry, q2, q3, r.rec_q4)
    assert np.max(np.abs(yy[:, 0] - np.sin(tt))) < 5e-7
    assert ns < 600  # no order reduction on this stiff forced problem (Rodas4 took ~2000)
    if order == 5:
        assert ns < 300  # Rodas5P: 5th order, fewer steps still


@ORDERS
@pytest.mark.parametrize("zeta", [0.05, 0.3, 0.7])
def test_impact_restitution_matches_the_damped_oscillator(zeta, order):
    """Linear spring-dashpot impact: rebound speed e v0 with e = exp(-zeta pi / sqrt(1 - zeta^2))."""
    k, m = 3.02e9, 2.7e-3  # the disc valve's rigid seat and moving mass (Tables 2.1-2.3)
    c = 2 * zeta * math.sqrt(k * m)
    v0, x0 = -0.5, 1e-5
    wd = math.sqrt(k / m) * math.sqrt(1 - zeta**2)
    t_contact = x0 / -v0 + math.pi / wd
    T = t_contact + 2e-5
    r = impact(0.0, np.array([x0, v0]), np.array([T]), np.array([k, c, m]),
               rodas.Options(1e-9, np.array([1e-15, 1e-9]), 1e-7, np.inf, 10**6, 2, np.inf, 0, 0, 1, np.zeros(0), order))
    st, ys = r.status, r.y_stops
    assert st == rodas.OK
    e = math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))
    assert ys[-1, 1] == pytest.approx(-e * v0, rel=1e-6)
    assert ys[-1, 0] == pytest.approx(-e * v0 * (T - t_contact), rel=1e-5)


def test_step_budget_is_reported():
    r = vdp(0.0, np.array([2.0, -0.66]), np.array([2.0]), np.array([1e-6]),
            rodas.Options(1e-8, np.full(2, 1e-8), 1e-6, np.inf, 50, 2, np.inf, 0, 0, 1))
    assert r.status == rodas.MAX_STEPS


def test_lu_solves_a_pivoting_system():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(6, 6))
    a[0, 0] = 0.0  # forces a row exchange
    b = rng.normal(size=6)
    lu, piv, x = a.copy(), np.empty(6, dtype=np.int64), b.copy()
    assert rodas.lu_factor(lu, piv)
    rodas.lu_solve(lu, piv, x)
    assert np.allclose(a @ x, b, rtol=0, atol=1e-12)


@ORDERS
def test_events_are_located_on_the_dense_output(order):
    """A bouncing ball: bounce times 2 v0/g e^k sums in closed form; the step is cut at each."""
    g, e, v0 = 9.81, 0.8, 3.0
    p = np.array([g, e, 0.0])
    T = 1.5
    r = ball(0.0, np.array([0.0, v0]), np.array([T]), p,
             rodas.Options(1e-6, np.array([1e-9, 1e-9]), 1e-3, np.inf, 10**5, 2, 0.0, 1, 100, 1, np.zeros(0), order))
    st, ys, rt, tags, ev_t, ev_code = r.status, r.y_stops, r.rec_t, r.rec_tag, r.ev_t, r.ev_code
    assert st == rodas.OK
    # the state just before each bounce is logged: falling onto the floor at the bounce speed
    assert np.allclose(r.ev_y[:, 0], 0.0, atol=1e-9) and np.all(r.ev_y[:, 1] < 0)
    flights = 2 * v0 / g * e ** np.arange(20)
    exact = np.cumsum(flights)
    exact = exact[exact < T]
    assert len(ev_t) == len(exact) and list(ev_code) == list(range(1, len(exact) + 1))
    assert np.allclose(ev_t, exact, rtol=0, atol=1e-9)
    # the steps end on the events and carry the model state (tag) that held during them
    assert set(exact.round(9)) <= set(np.round(rt, 9))
    assert tags[-1] == len(exact) and p[2] == len(exact)
    # after the last bounce: free flight from 0 with speed v0 e^n
    tau = T - exact[-1]
    vn = v0 * e ** len(exact)
    assert ys[-1, 0] == pytest.approx(vn * tau - g * tau**2 / 2, abs=1e-9)


def test_first_step_after_an_event_is_remembered_between_calls():
    """An impact on a stiff floor (k/m = 1e8 1/s^2): the step sized on the flight before cannot follow the
    contact transient, so each landing rejects steps there; the size the error estimate asked for is
    kept in opts.h_event (between calls too) and later landings start their contact with it: fewer
    rejections, the same solution (to the tolerance) as without memory."""
    y0, T = np.array([0.2, 0.0]), 0.6
    p = np.array([9.81, 1e8, 2e3, 0.0])

    def run(memory):
        q = p.copy()
        opts = rodas.Options(1e-6, np.array([1e-9, 1e-8]), 1e-3, np.inf, 10**6, 2, np.inf, 2, 100, 1, memory)
        return floor(0.0, y0, np.array([T]), q, opts)

    plain = run(np.zeros(0))
    memory = np.zeros(4)
    first, second = run(memory), run(memory)
    assert plain.status == first.status == second.status == rodas.OK
    assert len(plain.ev_t) == len(second.ev_t) >= 2                   # landed and lifted off
    assert memory[1] > 0.0                                           # contact (code 1) remembered
    # the ball lands several times in a call: memory helps from the second landing on
    assert second.n_rejected <= first.n_rejected < plain.n_rejected
    assert np.allclose(second.ev_t, plain.ev_t, rtol=0, atol=1e-6)
    assert np.allclose(second.y_stops, plain.y_stops, rtol=1e-4, atol=1e-6)


def test_sampled_modes_decode_the_step_tags_of_the_layout():
    """Each sample's mode is the mode the stepper tagged its step with (lumped.solver.layout.mode_tag, the encoder),
    a sample at a step's end belonging to that step."""
    from lumped.solver.layout import N_MODE, mode_tag

    rng = np.random.default_rng(3)
    modes = rng.integers(0, 3, size=(6, N_MODE)).astype(float)
    rec_t = np.arange(6, dtype=float)
    rec_tag = np.array([mode_tag(m) for m in modes], dtype=np.int64)
    t = np.array([0.0, 0.5, 1.0, 2.25, 4.999, 5.0])
    got = rodas.sample_modes(t, rec_t, rec_tag, N_MODE)
    assert np.array_equal(got, modes[[1, 1, 1, 3, 5, 5]])
