"""The compiled stiff integrator of the fast path: Rodas4P or Rodas5P (:mod:`lumped.solver.rosenbrock`) with
step-size control, located events and a recorded dense output.

Rodas4P (Steinebach 1995) keeps its order on stiff problems driven by a time-dependent forcing (the
Prothero-Robinson test, the shape of a cylinder pressure driven by the crank, where Rodas4 needs several
times the steps); L-stable, so the stiff seat and stop contacts and the compressible cylinder do not limit
the step once their transients have decayed, and stiffly accurate, so a valve resting on its seat is an
exact equilibrium rather than a ringing one. Rodas5P (Steinebach 2023; ``Options.order``) is taken where a
stiff component is slaved to a fast forcing (a valve's velocity under a transient flow force): Rodas4P's
embedded estimate over-reads its own error there (docs/discrepancy.md, "Cost").

:func:`solve` is the loop; each of its parts is a helper numba compiles with it: :func:`_prepare` (f, the
events and the Jacobian where stale), :func:`_attempt` (one step and its error test), :func:`_event_in_step`
(the first crossing on the step's interpolant, the step redone to end there), :func:`_next_step` (Gustafsson's
predictive controller, as in RODAS), :func:`_record_step` (the dense output kept), :func:`_switch` and
:func:`_restart` (a mode change and the step after it), :func:`_pass_stops`.

The model's functions are module-level names: ``rhs(t, y, p, dydt)`` (fills ``dydt`` in place; ``p`` a flat
float64 parameter array), and the hooks ``event_values``, ``apply_event``, ``step_tag``, ``event_retry``,
``update_tolerances``, ``jacobian``. :func:`specialize` returns a copy of :func:`solve` with them bound to a
model's ``numba.njit`` functions, compiled once and cached on disk under a name of its own, so every model gets
a solver with its right-hand side inlined and no Python in the loop. The Jacobian is the model's own or forward
differences over the first ``n_dyn`` states (:func:`fd_jacobian`): the remaining states are quadratures (e.g.
integrated mass flows) that never feed back.

Everything is compiled with numba's ``error_model="numpy"``: a float division by zero gives inf or nan (a
non-finite stage, so a rejected step) instead of raising, and the divisions need no zero test (a large share
of a pump right-hand side call, docs/performance.md).
"""

from __future__ import annotations

import types
from typing import NamedTuple

import numba
import numpy as np

from lumped.solver.dense_output import interpolate, sample_modes  # noqa: F401 - re-exported
from lumped.solver.rosenbrock import (  # noqa: F401 - re-exported: the method's pieces
    _cut_interpolant, _dense_into, dense, dense_coefficients, lu_factor, lu_solve, rhs, rosenbrock5_step,
    rosenbrock_step, work,
)

SAFE, FAC_MIN, FAC_MAX = 0.9, 0.2, 6.0  # step ratio limits of RODAS
MAX_EVENT_RETRIES = 3  # times a step is redone to end at a crossing located on its interpolant
EVENT_RETRY_WINDOW = 1e-3  # ... unless the crossing lies this close (step fraction) to either end

#: solver status codes
OK, MAX_STEPS, STEP_TOO_SMALL, TOO_MANY_EVENTS = 0, 1, 2, 3
#: each status code in words
STATUS_TEXT = {OK: "ok", MAX_STEPS: "too many steps", STEP_TOO_SMALL: "step size underflow",
               TOO_MANY_EVENTS: "too many events (chatter)"}


@numba.njit(cache=True, error_model="numpy")
def event_values(t, y, p, g):  # default hook of specialize(): no events
    g[:] = 1.0


@numba.njit(cache=True, error_model="numpy")
def apply_event(k, t, y, p):  # default hook of specialize(): nothing to switch
    return 0


@numba.njit(cache=True, error_model="numpy")
def step_tag(p):  # default hook of specialize(): one tag for every step
    return 0


@numba.njit(cache=True, error_model="numpy")
def event_retry(k, p):  # default hook of specialize(): every event may need its step redone
    return True


@numba.njit(cache=True, error_model="numpy")
def update_tolerances(p, atol):  # default hook of specialize(): fixed tolerances
    return


@numba.njit(cache=True, error_model="numpy")
def jacobian(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h):  # default hook: -1, forward differences
    return -1


@numba.njit(cache=True, error_model="numpy")
def fd_jacobian(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h):
    """Forward-difference df/dy (first n_dyn columns; the rest are zero) and df/dt into jac, ft.

    f0 = f(t, y); yp, fp are scratch vectors. Increments: sqrt(eps) times max(|y_j|, atol_j/rtol)
    (the state's own scale), and sqrt(eps) max(|t|, h) in time. Returns the rhs calls made.
    """
    n = y.shape[0]
    sq = 1.4901161193847656e-08
    for j in range(n):
        for i in range(n):
            jac[i, j] = 0.0
    for j in range(n_dyn):
        scale = max(abs(y[j]), atol[j] / rtol)
        yp[:] = y
        yp[j] = y[j] + sq * scale
        dy = yp[j] - y[j]
        rhs(t, yp, p, fp)
        for i in range(n):
            jac[i, j] = (fp[i] - f0[i]) / dy
    dt = sq * max(abs(t), abs(h), 1e-10)
    rhs(t + dt, y, p, fp)
    for i in range(n):
        ft[i] = (fp[i] - f0[i]) / dt
    return n_dyn + 1


@numba.njit(cache=True, error_model="numpy")
def _grow(a, m):
    b = np.empty((2 * a.shape[0] + 16,) + a.shape[1:], dtype=a.dtype)
    b[:m] = a[:m]
    return b


# Points per step where the event functions are checked: the step end only, as scipy's
# solve_ivp does. Scanning the interpolant inside the step would also catch a crossing and
# return within one step, but the interpolant of a stiff transient (a valve settling on
# its stop) can dip across a surface the solution never crosses: spurious switches.
N_SCAN = 1


@numba.njit(cache=True, error_model="numpy")
def _locate_event(t, h, y, p, wk, n_events):
    """(k, s): the event that fires first in the step from (t, y) of size h (its result and interpolant in
    :class:`~lumped.solver.rosenbrock.Work` ``wk``) and the step fraction where it does; k = -1 if none fires.

    An event k fires where g_k drops from >= 0 (``wk.g0``, at the step's start) to < 0. The interpolant is
    checked at N_SCAN points to bracket the first crossing (:func:`_scan`), which :func:`_illinois` refines on
    the interpolant; an event can only come first before the best so far.
    """
    lo, hi = _scan(t, h, y, p, wk, n_events)
    if hi < 0.0:
        return -1, 2.0
    g0, g = wk.g0, wk.g1
    for kk in range(n_events):      # any already negative at the start fire at once
        if g0[kk] < 0.0 and g[kk] < 0.0:
            return kk, 0.0
    gs = np.empty(g.shape[0])
    g_lo = g0                     # the event values at the bracket's start (the step's, unless scanned past)
    if lo > 0.0:
        g_lo = np.empty(g.shape[0])
        _dense_into(lo, y, wk.ynew, wk.q2, wk.q3, wk.q4, wk.yp)
        event_values(t + lo * h, wk.yp, p, g_lo)
    best_k = -1
    best_s = 2.0
    for kk in range(n_events):
        if g[kk] >= 0.0:
            continue
        b = min(hi, best_s)
        fb = g[kk]
        if b < hi:
            _dense_into(b, y, wk.ynew, wk.q2, wk.q3, wk.q4, wk.yp)
            event_values(t + b * h, wk.yp, p, gs)
            if gs[kk] >= 0.0:
                continue
            fb = gs[kk]
        b = _illinois(kk, (lo, b, g_lo[kk], fb), t, h, y, p, wk, gs)
        if b < best_s:
            best_s = b
            best_k = kk
    return best_k, best_s


@numba.njit(cache=True, error_model="numpy")
def _scan(t, h, y, p, wk, n_events):
    """(lo, hi): the step fractions bracketing the first crossing among N_SCAN points of the interpolant (hi < 0:
    none); the event values at hi are left in ``wk.g1``."""
    lo = 0.0
    hi = -1.0
    for j in range(1, N_SCAN + 1):
        sj = j / N_SCAN
        _dense_into(sj, y, wk.ynew, wk.q2, wk.q3, wk.q4, wk.yp)
        event_values(t + sj * h, wk.yp, p, wk.g1)
        for kk in range(n_events):
            if wk.g1[kk] < 0.0:
                hi = sj
        if hi > 0.0:
            break
        lo = sj
    return lo, hi


@numba.njit(cache=True, error_model="numpy")
def _illinois(kk, bracket, t, h, y, p, wk, gs):
    """The step fraction where event kk crosses, refined inside ``bracket`` = (a, b, g_kk(a), g_kk(b)) on the
    interpolant to 1e-13 of the step by the Illinois method (regula falsi that halves the stale end's value;
    Dowell & Jarratt 1971), with a bisection whenever the bracket fails to halve twice running: about 6-10
    evaluations instead of bisection's 43. Returns the bracket's end past the crossing."""
    a, b, fa, fb = bracket
    side = 0
    slow = 0
    while b - a > 1e-13:
        width = b - a
        m = (a * fb - b * fa) / (fb - fa) if slow < 2 else 0.5 * (a + b)
        if not (a < m < b):
            m = 0.5 * (a + b)
        _dense_into(m, y, wk.ynew, wk.q2, wk.q3, wk.q4, wk.yp)
        event_values(t + m * h, wk.yp, p, gs)
        fm = gs[kk]
        if fm < 0.0:
            b = m
            fb = fm
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            a = m
            fa = fm
            if side == 1:
                fb *= 0.5
            side = 1
        slow = slow + 1 if b - a > 0.5 * width else 0      # two slow ones: the next is a bisection
    return b


class Options(NamedTuple):
    """Settings of :func:`solve` (SI time units).

    ``rtol``; ``atol``: array, one per state (the model's ``update_tolerances`` may rewrite
    it); ``h0``: first step; ``hmax``: largest step; ``max_steps``; ``n_dyn``: the first
    n_dyn states feed back, the rest are quadratures; ``t_record``: keep every accepted
    step from this time on; ``n_events``: switching functions of the model;
    ``max_events``: events before giving up (chatter); ``jac_reuse``: accepted steps per
    Jacobian; ``h_event``: read and written, a memory the caller keeps between calls: the first
    step after an event whose ``apply_event`` code is c (0 <= c < len) starts no larger than
    ``h_event[c]``, the size the error estimate of the last first step after such an event
    asked for (empty: no memory); ``order``: 4 for Rodas4P, 5 for Rodas5P.
    """

    rtol: float
    atol: np.ndarray
    h0: float
    hmax: float
    max_steps: int
    n_dyn: int
    t_record: float
    n_events: int
    max_events: int
    jac_reuse: int
    h_event: np.ndarray = np.zeros(0)
    order: int = 4


class Result(NamedTuple):
    """What :func:`solve` returns.

    ``status`` (:data:`STATUS_TEXT`); ``y_stops[i]``: the state at ``tstops[i]``; the recorded
    steps: step i runs from rec_t[i-1] to rec_t[i], its dense-output coefficients at
    i (``rec_q2``, ``rec_q3``, ``rec_q4``) and ``rec_tag[i] = step_tag(p)`` during it; the events: time,
    index, the model's code, and the state just before the switch (``ev_y``); counts;
    ``h_next``, the step to continue with.
    """

    status: int
    y_stops: np.ndarray
    rec_t: np.ndarray
    rec_y: np.ndarray
    rec_q2: np.ndarray
    rec_q3: np.ndarray
    rec_q4: np.ndarray
    rec_tag: np.ndarray
    ev_t: np.ndarray
    ev_k: np.ndarray
    ev_code: np.ndarray
    ev_y: np.ndarray
    n_steps: int
    n_rejected: int
    n_rhs: int
    h_next: float


#: the step controller's integer state, slots of an int64 array: the counts, the Jacobian's age in accepted steps,
#: the redone steps of the pending event, the event code whose first step is being taken (-1: none), and flags:
#: the first step since the start or an event, the last step rejected, f(t, y) and the events at (t, y) known
N_STEPS, N_REJECTED, N_RHS, JAC_AGE, RETRIES, AFTER_EVENT, FIRST, REJECT, F_FRESH, G_FRESH = range(10)
#: its float state: the step to try next, the last accepted step and its error (Gustafsson's controller)
H, H_ACC, ERR_ACC = range(3)


class Record(NamedTuple):
    """The recorded steps (:class:`Result`'s ``rec_*``), grown as they fill (:func:`_keep`)."""

    t: np.ndarray
    y: np.ndarray
    q2: np.ndarray
    q3: np.ndarray
    q4: np.ndarray
    tag: np.ndarray


class EventLog(NamedTuple):
    """The events made (:class:`Result`'s ``ev_*``), grown as they fill (:func:`_switch`)."""

    t: np.ndarray
    k: np.ndarray
    code: np.ndarray
    y: np.ndarray


@numba.njit(cache=True, error_model="numpy")
def solve(t0, y0, tstops, p, opts):
    """Integrate y' = rhs(t, y, p) from t0 through every time in ``tstops`` (ascending), steps landing exactly
    on each; a :class:`Result`. Error control: RMS over components of err_i / (atol_i + rtol max(|y_i|,
    |y_new_i|)), atol as the model's ``update_tolerances`` sets it at the start and after every event. Events
    (``opts.n_events`` > 0): event k fires where ``event_values``'s g_k drops from >= 0 to < 0, located on the
    dense output, the step redone to end there (:func:`_event_in_step`); there ``apply_event`` switches the
    model and integration restarts, so the right-hand side is smooth inside every step.
    """
    n, y, t = y0.shape[0], y0.copy(), t0
    update_tolerances(p, opts.atol)
    wk = work(n, opts.n_dyn, opts.n_events)
    expo = _exponent(opts.order)
    ci, cf = _controller(opts, t0, tstops[-1])
    rec, m = _record_start(n, t, y, step_tag(p), opts.t_record <= t0)
    ev, n_ev = _event_log(n), 0
    y_stops = np.full((tstops.shape[0], n), np.nan)
    i_stop = _pass_stops(tstops, 0, t, y, y_stops)
    status = OK
    while i_stop < tstops.shape[0]:
        if ci[N_STEPS] >= opts.max_steps:
            status = MAX_STEPS
            break
        h_try, hit = _clip(t, cf[H], opts.hmax, tstops[i_stop])
        if h_try <= 1e-14 * max(abs(t), 1e-300) or h_try <= 0.0:
            status = STEP_TOO_SMALL
            break
        _prepare(t, y, p, wk, opts, ci, h_try)
        ok, err, fac_h, h_new = _attempt(t, h_try, y, p, wk, opts, ci, cf)
        if not ok:
            continue
        dense_coefficients(wk.k, wk.q2, wk.q3, wk.q4, opts.order)
        k_ev, s_ev, redo = _event_in_step(t, h_try, y, p, wk, opts, ci, cf)
        if redo:
            continue
        h_new = _next_step(h_try, err, fac_h, h_new, expo, ci, cf, opts.h_event)
        t_old = t
        t = tstops[i_stop] if hit else t + h_try
        tag = step_tag(p)
        if k_ev >= 0:
            _cut_interpolant(s_ev, y, wk.ynew, wk.q2, wk.q3, wk.q4, opts.order)
            t = t_old + s_ev * h_try
            hit = False
        rec, m = _record_step(rec, m, (t_old, t), y, wk, tag, opts.t_record)
        y[:] = wk.ynew
        _after_step(ci, wk, k_ev, opts)
        if k_ev >= 0:
            ev, n_ev, code = _switch(ev, n_ev, k_ev, t, y, p, opts.atol)
            if n_ev >= opts.max_events:
                status = TOO_MANY_EVENTS
                break
            _restart(h_new, h_try, code, ci, cf, opts.h_event)
            continue
        if hit:
            i_stop = _pass_stops(tstops, i_stop, t, y, y_stops)
            cf[H] = max(h_new, cf[H])          # a step clipped to land on a stop does not shrink the next one
        else:
            cf[H] = h_new
    return Result(status, y_stops, rec.t[:m], rec.y[:m], rec.q2[:m], rec.q3[:m], rec.q4[:m], rec.tag[:m],
                  ev.t[:n_ev], ev.k[:n_ev], ev.code[:n_ev], ev.y[:n_ev], ci[N_STEPS], ci[N_REJECTED], ci[N_RHS],
                  cf[H])


@numba.njit(cache=True, error_model="numpy")
def _exponent(order):
    """The exponent 1/q of the step-ratio law err^(-1/q): q the method's order (the embedded estimate's + 1),
    4 for Rodas4P, 5 for Rodas5P."""
    return 0.2 if order == 5 else 0.25


@numba.njit(cache=True, error_model="numpy")
def _event_log(n):
    """An empty :class:`EventLog` for states of length n."""
    return EventLog(np.empty(64), np.empty(64, dtype=np.int64), np.empty(64, dtype=np.int64), np.empty((64, n)))


@numba.njit(cache=True, error_model="numpy")
def _controller(opts, t0, t_end):
    """The controller's state at the start (:data:`N_STEPS`..., :data:`H`...): a Jacobian due, no event pending,
    the first step ``opts.h0`` (at most ``opts.hmax`` and the span)."""
    ci = np.zeros(10, dtype=np.int64)
    ci[JAC_AGE] = opts.jac_reuse      # forces a Jacobian at the first step
    ci[AFTER_EVENT] = -1
    ci[FIRST] = 1
    cf = np.empty(3)
    cf[H] = min(opts.h0, opts.hmax, t_end - t0)
    cf[H_ACC] = 0.0
    cf[ERR_ACC] = 1.0
    return ci, cf


@numba.njit(cache=True, error_model="numpy")
def _clip(t, h, hmax, t_stop):
    """(step to try, whether it lands on the stop t_stop): h at most hmax, ending exactly on a stop it would
    reach (to 1e-12 of it)."""
    h_try = min(h, hmax)
    if t + h_try >= t_stop - 1e-12 * abs(t_stop):
        return t_stop - t, True
    return h_try, False


@numba.njit(cache=True, error_model="numpy")
def _prepare(t, y, p, wk, opts, ci, h_try):
    """f(t, y) at the step's start and the events there (unless known), and the Jacobian and f_t when due:
    kept for up to ``opts.jac_reuse`` accepted steps, fresh after an event or a rejection."""
    if not ci[F_FRESH]:
        rhs(t, y, p, wk.f0)
        ci[N_RHS] += 1
        if opts.n_events > 0 and not ci[G_FRESH]:
            event_values(t, y, p, wk.g0)
        ci[F_FRESH] = 1
    if ci[JAC_AGE] >= opts.jac_reuse or (ci[REJECT] and ci[JAC_AGE] > 0):
        nj = jacobian(t, y, p, wk.f0, wk.jac, wk.ft, wk.yp, wk.fp, opts.atol, opts.rtol, opts.n_dyn, h_try)
        if nj < 0:
            nj = fd_jacobian(t, y, p, wk.f0, wk.jac, wk.ft, wk.yp, wk.fp, opts.atol, opts.rtol, opts.n_dyn, h_try)
        ci[N_RHS] += nj
        ci[JAC_AGE] = 0


@numba.njit(cache=True, error_model="numpy")
def _attempt(t, h_try, y, p, wk, opts, ci, cf):
    """One Rosenbrock step of h_try and its error test: (accepted, err, fac, h_new), fac and h_new the step
    ratio and next step the error asks for (RODAS's limits). A failed step (singular W, a non-finite stage)
    is retried at a quarter, a step failing the test at h_new (a tenth as the first step)."""
    if opts.order == 5:
        ok, err = rosenbrock5_step(t, h_try, y, p, wk, opts.n_dyn, opts.rtol, opts.atol)
        ci[N_RHS] += 7
    else:
        ok, err = rosenbrock_step(t, h_try, y, p, wk, opts.n_dyn, opts.rtol, opts.atol)
        ci[N_RHS] += 5
    if not ok:
        cf[H] = 0.25 * h_try
        ci[REJECT] = 1
        ci[N_REJECTED] += 1
        return False, err, 0.0, 0.0
    ci[N_STEPS] += 1
    fac_h = max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, err ** _exponent(opts.order) / SAFE))
    h_new = h_try / fac_h
    if err > 1.0:
        ci[N_REJECTED] += 1
        cf[H] = h_new if not ci[FIRST] else 0.1 * h_try
        ci[REJECT] = 1
        return False, err, fac_h, h_new
    return True, err, fac_h, h_new


@numba.njit(cache=True, error_model="numpy")
def _event_in_step(t, h_try, y, p, wk, opts, ci, cf):
    """(k, s, redo): the first event crossing in the accepted step and its step fraction (-1, 2.0: none), and
    whether the step is to be redone to end at the crossing (the interpolant locates a crossing only as well as
    it follows the solution; near either end it is pinned to the states): then the next step is set there."""
    if opts.n_events <= 0:
        return -1, 2.0, False
    k_ev, s_ev = _locate_event(t, h_try, y, p, wk, opts.n_events)
    if (k_ev >= 0 and ci[RETRIES] < MAX_EVENT_RETRIES and EVENT_RETRY_WINDOW < s_ev < 1.0 - EVENT_RETRY_WINDOW
            and event_retry(k_ev, p)):
        ci[RETRIES] += 1
        cf[H] = s_ev * h_try
        event_values(t, y, p, wk.g0)      # g0 served as scratch; y, f0 and J still hold
        return k_ev, s_ev, True
    return k_ev, s_ev, False


@numba.njit(cache=True, error_model="numpy")
def _next_step(h_try, err, fac_h, h_new, expo, ci, cf, h_event):
    """The step after an accepted one: Gustafsson's predictive controller (as in RODAS) from the last two
    accepted steps and errors, no larger than a step just rejected; the first step after an event of code c
    is remembered in ``h_event[c]`` (the same kind of event recurs every revolution)."""
    if ci[AFTER_EVENT] >= 0:
        h_event[ci[AFTER_EVENT]] = h_new
        ci[AFTER_EVENT] = -1
    if not ci[FIRST]:
        fg = (cf[H_ACC] / h_try) * (err * err / cf[ERR_ACC]) ** expo / SAFE
        fg = max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, fg))
        fac_h = max(fac_h, fg)
        h_new = h_try / fac_h
    cf[H_ACC] = h_try
    cf[ERR_ACC] = max(1e-2, err)
    ci[FIRST] = 0
    if ci[REJECT]:
        h_new = min(h_new, h_try)
    ci[REJECT] = 0
    return h_new


@numba.njit(cache=True, error_model="numpy")
def _after_step(ci, wk, k_ev, opts):
    """Bookkeeping of an accepted step: f at the new start unknown; the events there known from the scan of
    the step's end (s = 1 is y_new exactly) unless an event was cut; the Jacobian a step older (due after an
    event, whose step is no longer redone)."""
    ci[F_FRESH] = 0
    g_fresh = k_ev < 0 and opts.n_events > 0
    ci[G_FRESH] = 1 if g_fresh else 0
    if g_fresh:
        wk.g0[:opts.n_events] = wk.g1[:opts.n_events]
    ci[JAC_AGE] += 1
    if k_ev >= 0:
        ci[JAC_AGE] = opts.jac_reuse
        ci[RETRIES] = 0


@numba.njit(cache=True, error_model="numpy")
def _record_start(n, t, y, tag, keep):
    """(record, count): an empty :class:`Record` of n states, with (t, y) as its start when ``keep``."""
    cap = 1024
    rec = Record(np.empty(cap), np.empty((cap, n)), np.empty((cap, n)), np.empty((cap, n)), np.empty((cap, n)),
                 np.empty(cap, dtype=np.int64))
    if not keep:
        return rec, 0
    _keep_start(rec, t, y, tag)
    return rec, 1


@numba.njit(cache=True, error_model="numpy")
def _keep_start(rec, t, y, tag):
    """The record's first entry: the state a recorded span starts from (no step ends there: q = 0)."""
    rec.t[0] = t
    rec.y[0] = y
    rec.q2[0] = 0.0
    rec.q3[0] = 0.0
    rec.q4[0] = 0.0
    rec.tag[0] = tag


@numba.njit(cache=True, error_model="numpy")
def _record_step(rec, m, span, y, wk, tag, t_record):
    """(record, count) with the accepted step over ``span`` = (t_old, t) kept when it ends at or after
    t_record (a step crossing t_record keeps its start too)."""
    t_old, t = span
    if t >= t_record and (t > t_old or m == 0):
        if m == 0 and t > t_record:
            _keep_start(rec, t_old, y, tag)
            m = 1
        if m >= rec.t.shape[0]:
            rec = Record(_grow(rec.t, m), _grow(rec.y, m), _grow(rec.q2, m), _grow(rec.q3, m), _grow(rec.q4, m),
                         _grow(rec.tag, m))
        rec.t[m] = t
        rec.y[m] = wk.ynew
        rec.q2[m] = wk.q2
        rec.q3[m] = wk.q3
        rec.q4[m] = wk.q4
        rec.tag[m] = tag
        m += 1
    return rec, m


@numba.njit(cache=True, error_model="numpy")
def _switch(ev, n_ev, k_ev, t, y, p, atol):
    """Event k_ev at (t, y): the state before it logged, the model switched (``apply_event``, which may change
    y and p), the tolerances refreshed; (log, count, the model's code)."""
    if n_ev >= ev.t.shape[0]:
        ev = EventLog(_grow(ev.t, n_ev), _grow(ev.k, n_ev), _grow(ev.code, n_ev), _grow(ev.y, n_ev))
    ev.y[n_ev] = y
    code = apply_event(k_ev, t, y, p)
    update_tolerances(p, atol)
    ev.t[n_ev] = t
    ev.k[n_ev] = k_ev
    ev.code[n_ev] = code
    return ev, n_ev + 1, code


@numba.njit(cache=True, error_model="numpy")
def _restart(h_new, h_try, code, ci, cf, h_event):
    """After an event the dynamics change: the step-size history restarts, from the step the error asked for,
    at most the one just taken, and at most the first step after the last event of the same code: an impact
    starts a stiff contact transient that a step sized on the flight before cannot follow."""
    ci[FIRST] = 1
    h = max(min(h_new, h_try), 1e-6 * h_try)
    if 0 <= code < h_event.shape[0]:
        if h_event[code] > 0.0:
            h = min(h, h_event[code])
        ci[AFTER_EVENT] = code
    cf[H] = h


@numba.njit(cache=True, error_model="numpy")
def _pass_stops(tstops, i_stop, t, y, y_stops):
    """The state at every stop t has reached (into ``y_stops``); the index of the next stop."""
    while i_stop < tstops.shape[0] and tstops[i_stop] <= t:
        y_stops[i_stop] = y
        i_stop += 1
    return i_stop


#: the integrator's functions that call the model's (directly or through another), innermost first:
#: :func:`specialize` rebinds each to the model's functions
HOOKED = ("fd_jacobian", "rosenbrock_step", "rosenbrock5_step", "_scan", "_illinois", "_locate_event", "_prepare",
          "_attempt", "_event_in_step", "_switch")
#: the model's functions the integrator calls, by their names here
HOOKS = ("rhs", "event_values", "apply_event", "step_tag", "jacobian", "update_tolerances", "event_retry")


def _rebind(func, scope: dict, tag: str, cache: bool = False):
    """A numba.njit copy of ``func`` (a dispatcher) reading its globals from ``scope``."""
    base = func.py_func
    fn = types.FunctionType(base.__code__, scope, base.__name__, base.__defaults__, base.__closure__)
    fn.__qualname__ = f"{base.__qualname__}__{tag}"
    fn.__module__ = base.__module__
    fn.__doc__ = base.__doc__
    return numba.njit(cache=cache, error_model="numpy")(fn)


#: specialize's keyword -> the hook it binds
HOOK_KEYWORDS = {"events": "event_values", "apply": "apply_event", "tagger": "step_tag", "jac": "jacobian",
                 "tolerances": "update_tolerances", "retry": "event_retry"}


def specialize(rhs_func, tag: str, *, cache: bool = True, **model):
    """A compiled :func:`solve` bound to a model's functions (numba.njit), inlined, no Python.

    Parameters
    ----------
    rhs_func
        ``rhs(t, y, p, dydt)``.
    tag : str
        Names the compiled copy (its on-disk cache entry), e.g. "pump_<hash>"; a tag must stand for one set of
        functions.
    cache : bool
        Cache the compiled solver on disk.
    **model
        Optional hooks: ``events(t, y, p, g)``, ``apply(k, t, y, p) -> int``, ``tagger(p) -> int``,
        ``jac(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h) -> int`` (fills df/dy and df/dt, returns the
        rhs calls used, or -1 to fall back to forward differences; its columns n_dyn.. must stay zero),
        ``tolerances(p, atol)`` (may rewrite the absolute tolerances in place from the model state; called at
        the start and after every event) and ``retry(k, p) -> bool`` (False: event k is located on the
        interpolant of the step as it is, no step redone; for crossings whose variable the interpolant follows
        to the tolerance).

    Returns
    -------
    numba dispatcher
        ``solve(t0, y0, tstops, p, opts) -> Result`` with the model's functions.
    """
    unknown = set(model) - set(HOOK_KEYWORDS)
    if unknown:
        raise TypeError(f"specialize() got an unexpected keyword argument {sorted(unknown)[0]!r}")
    hooks = {"rhs": rhs_func, **{HOOK_KEYWORDS[k]: f for k, f in model.items() if f is not None}}
    # the functions that call the model's get the same bindings, innermost first (each sees those before it)
    here = globals()
    for name in HOOKED:
        fn = here[name]
        hooks[name] = _rebind(fn, {**fn.py_func.__globals__, **hooks}, tag)
    return _rebind(solve, {**solve.py_func.__globals__, **hooks}, tag, cache=cache)
