"""The compiled stiff integrator of the fast path: Rodas4P or Rodas5P (:mod:`lumped.solver.rosenbrock`) with
step-size control, located events and a recorded dense output.

Rodas4P (Steinebach 1995) keeps its order on stiff problems driven by a time-dependent forcing (the
Prothero-Robinson test, the shape of a cylinder pressure driven by the crank, where Rodas4 needs several
times the steps); L-stable, so the stiff seat and stop contacts and the compressible cylinder do not limit
the step once their transients have decayed, and stiffly accurate, so a valve resting on its seat is an
exact equilibrium rather than a ringing one. Rodas5P (Steinebach 2023; ``Options.order``) is taken where a
stiff component is slaved to a fast forcing (a valve's velocity under a transient flow force): Rodas4P's
embedded estimate over-reads its own error there (docs/discrepancy.md, "Cost").

:func:`solve` is the loop, one compiled kernel: numba increfs and decrefs every array it binds to a function's
argument, so the loop's arrays cross no function boundary per step (docs/extending.md, "Long kernels"). Its
scalar decisions are helpers: ``_clip`` (the step landing on a stop), ``_error_test`` and
``_predicted`` (Gustafsson's predictive controller, as in RODAS), ``_redo`` (a step redone to end at an
event), ``_restart`` (the step after an event); ``_locate_event`` finds the first crossing on the
step's interpolant, ``_illinois`` refines it.

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
def _locate_event(t, h, y0, y1, q2, q3, q4, p, g0, g, ybuf, n_events):
    """(k, s): the event that fires first in the step from (t, y0) of size h and the step fraction where it
    does; k = -1 if none fires.

    An event k fires where g_k drops from >= 0 (``g0``, at the step's start) to < 0. The interpolant (y1 the
    step's result, q2..q4 its coefficients) is checked at N_SCAN points to bracket the first crossing (the
    values at the bracket's end are left in ``g``), which ``_illinois`` refines on the interpolant; an event
    can only come first before the best so far. ``ybuf``: scratch of the state's length.
    """
    lo = 0.0
    hi = -1.0
    for j in range(1, N_SCAN + 1):
        sj = j / N_SCAN
        _dense_into(sj, y0, y1, q2, q3, q4, ybuf)
        event_values(t + sj * h, ybuf, p, g)
        for kk in range(n_events):
            if g[kk] < 0.0:
                hi = sj
        if hi > 0.0:
            break
        lo = sj
    if hi < 0.0:
        return -1, 2.0
    for kk in range(n_events):      # any already negative at the start fire at once
        if g0[kk] < 0.0 and g[kk] < 0.0:
            return kk, 0.0
    gs = np.empty(g.shape[0])
    g_lo = g0                     # the event values at the bracket's start (the step's, unless scanned past)
    if lo > 0.0:
        g_lo = np.empty(g.shape[0])
        _dense_into(lo, y0, y1, q2, q3, q4, ybuf)
        event_values(t + lo * h, ybuf, p, g_lo)
    best_k = -1
    best_s = 2.0
    for kk in range(n_events):
        if g[kk] >= 0.0:
            continue
        b = min(hi, best_s)
        fb = g[kk]
        if b < hi:
            _dense_into(b, y0, y1, q2, q3, q4, ybuf)
            event_values(t + b * h, ybuf, p, gs)
            if gs[kk] >= 0.0:
                continue
            fb = gs[kk]
        b = _illinois(kk, (lo, b, g_lo[kk], fb), (t, h), (y0, y1, q2, q3, q4), p, ybuf, gs)
        if b < best_s:
            best_s = b
            best_k = kk
    return best_k, best_s


@numba.njit(cache=True, error_model="numpy")
def _illinois(kk, bracket, step, interpolant, p, ybuf, gs):
    """The step fraction where event kk crosses, refined inside ``bracket`` = (a, b, g_kk(a), g_kk(b)) on the
    ``interpolant`` = (y0, y1, q2, q3, q4) of the ``step`` = (t, h) to 1e-13 of the step by the Illinois method
    (regula falsi that halves the stale end's value; Dowell & Jarratt 1971), with a bisection whenever the
    bracket fails to halve twice running: about 6-10 evaluations instead of bisection's 43. Returns the
    bracket's end past the crossing."""
    a, b, fa, fb = bracket
    t, h = step
    y0, y1, q2, q3, q4 = interpolant
    side = 0
    slow = 0
    while b - a > 1e-13:
        width = b - a
        m = (a * fb - b * fa) / (fb - fa) if slow < 2 else 0.5 * (a + b)
        if not (a < m < b):
            m = 0.5 * (a + b)
        _dense_into(m, y0, y1, q2, q3, q4, ybuf)
        event_values(t + m * h, ybuf, p, gs)
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


@numba.njit(cache=True, error_model="numpy")
def solve(t0, y0, tstops, p, opts):
    """Integrate y' = rhs(t, y, p) from t0 through every time in ``tstops`` (ascending), steps landing exactly
    on each; a :class:`Result`.

    Error control: RMS over components of err_i / (atol_i + rtol max(|y_i|, |y_new_i|)), atol as the model's
    ``update_tolerances`` sets it at the start and after every event; Gustafsson's predictive controller, as in
    RODAS (``_error_test``, ``_predicted``). Events (``opts.n_events`` > 0): event k fires where
    ``event_values``'s g_k drops from >= 0 to < 0, located on the dense output (``_locate_event``), the step
    redone to end there (``_redo``); there ``apply_event`` switches the model and integration restarts
    (``_restart``), so the right-hand side is smooth inside every step. A long kernel (docs/extending.md,
    "Long kernels"): its arrays cross no function boundary inside the loop.
    """
    n, n_dyn, n_events, rtol, atol, order = y0.shape[0], opts.n_dyn, opts.n_events, opts.rtol, opts.atol, opts.order
    y, t, h_event, expo = y0.copy(), t0, opts.h_event, _exponent(opts.order)
    update_tolerances(p, atol)
    f0, ft, fp, yp, jac, w, piv, k, u, ynew, q2, q3, q4, g0, g1 = work(n, n_dyn, n_events)
    rec_t, rec_y, rec_q2, rec_q3, rec_q4, rec_tag = _record_arrays(1024, n)
    ev_t, ev_k, ev_code, ev_y = _event_arrays(64, n)
    m = _keep_start(rec_t, rec_y, rec_q2, rec_q3, rec_q4, rec_tag, t, y, step_tag(p)) if opts.t_record <= t0 else 0
    y_stops = np.full((tstops.shape[0], n), np.nan)
    i_stop = _pass_stops(tstops, 0, t, y, y_stops)
    h, h_acc, err_acc = min(opts.h0, opts.hmax, tstops[-1] - t0), 0.0, 1.0
    n_steps, n_rej, n_rhs, n_ev, status = 0, 0, 0, 0, OK
    first, reject, f_fresh, g_fresh = True, False, False, False
    jac_age, retries, after_event = opts.jac_reuse, 0, -1      # a Jacobian due; no event pending
    while i_stop < tstops.shape[0]:
        if n_steps >= opts.max_steps:
            status = MAX_STEPS
            break
        h_try, hit = _clip(t, h, opts.hmax, tstops[i_stop])
        if h_try <= 1e-14 * max(abs(t), 1e-300) or h_try <= 0.0:
            status = STEP_TOO_SMALL
            break
        if not f_fresh:                # f(t, y) and the events there, unless the last step's scan gave them
            rhs(t, y, p, f0)
            n_rhs += 1
            if n_events > 0 and not g_fresh:
                event_values(t, y, p, g0)
            f_fresh = True
        if jac_age >= opts.jac_reuse or (reject and jac_age > 0):   # kept jac_reuse steps; fresh after a reject
            nj = jacobian(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h_try)
            if nj < 0:
                nj = fd_jacobian(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h_try)
            n_rhs += nj
            jac_age = 0
        if order == 5:
            ok, err = rosenbrock5_step(t, h_try, y, p, f0, ft, jac, w, piv, k, u, ynew, n_dyn, rtol, atol)
        else:
            ok, err = rosenbrock_step(t, h_try, y, p, f0, ft, jac, w, piv, k, u, ynew, n_dyn, rtol, atol)
        n_rhs += 7 if order == 5 else 5
        n_steps += 1 if ok else 0
        accepted, fac_h, h_new = _error_test(ok, err, h_try, expo, first)
        if not accepted:
            h, reject, n_rej = h_new, True, n_rej + 1
            continue
        dense_coefficients(k, q2, q3, q4, order)
        k_ev, s_ev = -1, 2.0
        if n_events > 0:
            k_ev, s_ev = _locate_event(t, h_try, y, ynew, q2, q3, q4, p, g0, g1, yp, n_events)
            if k_ev >= 0 and _redo(s_ev, retries) and event_retry(k_ev, p):
                retries += 1
                h = s_ev * h_try
                event_values(t, y, p, g0)      # g0 served as scratch; y, f0 and J still hold
                continue
        if after_event >= 0:               # the first step after an event of this code: remembered
            h_event[after_event] = h_new
            after_event = -1
        h_new = _predicted(h_try, err, fac_h, h_new, (h_acc, err_acc, expo), first, reject)
        h_acc, err_acc, first, reject = h_try, max(1e-2, err), False, False
        t_old = t
        t = tstops[i_stop] if hit else t + h_try
        tag = step_tag(p)
        if k_ev >= 0:
            _cut_interpolant(s_ev, y, ynew, q2, q3, q4, order)
            t = t_old + s_ev * h_try
            hit = False
        if t >= opts.t_record and (t > t_old or m == 0):
            if m == 0 and t > opts.t_record:     # the step that crosses t_record: keep its start too
                m = _keep_start(rec_t, rec_y, rec_q2, rec_q3, rec_q4, rec_tag, t_old, y, tag)
            if m >= rec_t.shape[0]:
                rec_t, rec_y, rec_q2, rec_q3, rec_q4, rec_tag = _grown(rec_t, rec_y, rec_q2, rec_q3, rec_q4, rec_tag, m)
            rec_t[m] = t
            rec_y[m] = ynew
            rec_q2[m] = q2
            rec_q3[m] = q3
            rec_q4[m] = q4
            rec_tag[m] = tag
            m += 1
        y[:] = ynew
        f_fresh = False
        g_fresh = k_ev < 0 and n_events > 0      # the scan evaluated the events at the step's end (s = 1 is y_new)
        if g_fresh:
            g0[:n_events] = g1[:n_events]
        jac_age += 1
        if k_ev >= 0:
            jac_age, retries = opts.jac_reuse, 0
            if n_ev >= ev_t.shape[0]:
                ev_t, ev_k, ev_code, ev_y = _grown_events(ev_t, ev_k, ev_code, ev_y, n_ev)
            ev_y[n_ev] = y
            code = apply_event(k_ev, t, y, p)
            update_tolerances(p, atol)
            ev_t[n_ev] = t
            ev_k[n_ev] = k_ev
            ev_code[n_ev] = code
            n_ev += 1
            if n_ev >= opts.max_events:
                status = TOO_MANY_EVENTS
                break
            first = True
            h, after_event = _restart(h_new, h_try, code, h_event)
            continue
        if hit:
            i_stop = _pass_stops(tstops, i_stop, t, y, y_stops)
            h = max(h_new, h)          # a step clipped to land on a stop does not shrink the next one
        else:
            h = h_new
    return Result(status, y_stops, rec_t[:m], rec_y[:m], rec_q2[:m], rec_q3[:m], rec_q4[:m], rec_tag[:m],
                  ev_t[:n_ev], ev_k[:n_ev], ev_code[:n_ev], ev_y[:n_ev], n_steps, n_rej, n_rhs, h)


@numba.njit(cache=True, error_model="numpy")
def _exponent(order):
    """The exponent 1/q of the step-ratio law err^(-1/q): q the method's order (the embedded estimate's + 1),
    4 for Rodas4P, 5 for Rodas5P."""
    return 0.2 if order == 5 else 0.25


@numba.njit(cache=True, error_model="numpy")
def _clip(t, h, hmax, t_stop):
    """(step to try, whether it lands on the stop t_stop): h at most hmax, ending exactly on a stop it would
    reach (to 1e-12 of it)."""
    h_try = min(h, hmax)
    if t + h_try >= t_stop - 1e-12 * abs(t_stop):
        return t_stop - t, True
    return h_try, False


@numba.njit(cache=True, error_model="numpy")
def _error_test(ok, err, h_try, expo, first):
    """(accepted, fac, h_new) of a step of h_try that gave (ok, err): fac the step ratio the error asks for
    (RODAS's limits), h_new the step to take next. A failed step (singular W, a non-finite stage) is retried at
    a quarter, a step failing the test at h_try / fac (a tenth as the first step)."""
    if not ok:
        return False, 0.0, 0.25 * h_try
    fac_h = max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, err ** expo / SAFE))
    if err > 1.0:
        return False, fac_h, (0.1 * h_try if first else h_try / fac_h)
    return True, fac_h, h_try / fac_h


@numba.njit(cache=True, error_model="numpy")
def _redo(s_ev, retries):
    """Whether a step with an event crossing at step fraction s_ev is redone to end there: the interpolant
    locates a crossing only as well as it follows the solution, so the crossing is located again on the shorter
    step (at most MAX_EVENT_RETRIES times; near either end the interpolant is pinned to the states)."""
    return retries < MAX_EVENT_RETRIES and EVENT_RETRY_WINDOW < s_ev < 1.0 - EVENT_RETRY_WINDOW


@numba.njit(cache=True, error_model="numpy")
def _predicted(h_try, err, fac_h, h_new, history, first, reject):
    """The step after an accepted one: Gustafsson's predictive controller (as in RODAS) from ``history`` =
    (the last accepted step, its error, the exponent 1/q), no larger than a step just rejected."""
    h_acc, err_acc, expo = history
    if not first:
        fg = (h_acc / h_try) * (err * err / err_acc) ** expo / SAFE
        fg = max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, fg))
        fac_h = max(fac_h, fg)
        h_new = h_try / fac_h
    if reject:
        h_new = min(h_new, h_try)
    return h_new


@numba.njit(cache=True, error_model="numpy")
def _restart(h_new, h_try, code, h_event):
    """(step, pending code) after an event of ``code``: the dynamics change, so the step-size history restarts,
    from the step the error asked for, at most the one just taken, and at most the first step after the last
    event of the same code (``h_event``): an impact starts a stiff contact transient that a step sized on the
    flight before cannot follow. The pending code is -1 where the caller keeps no memory of it."""
    h = max(min(h_new, h_try), 1e-6 * h_try)
    if 0 <= code < h_event.shape[0]:
        if h_event[code] > 0.0:
            h = min(h, h_event[code])
        return h, code
    return h, -1


@numba.njit(cache=True, error_model="numpy")
def _record_arrays(cap, n):
    """Room for ``cap`` recorded steps of n states: (t, y, q2, q3, q4, tag) (:class:`Result`'s ``rec_*``)."""
    return (np.empty(cap), np.empty((cap, n)), np.empty((cap, n)), np.empty((cap, n)), np.empty((cap, n)),
            np.empty(cap, dtype=np.int64))


@numba.njit(cache=True, error_model="numpy")
def _grown(rec_t, rec_y, rec_q2, rec_q3, rec_q4, rec_tag, m):
    """The record's arrays with their first m entries, twice as long."""
    return (_grow(rec_t, m), _grow(rec_y, m), _grow(rec_q2, m), _grow(rec_q3, m), _grow(rec_q4, m),
            _grow(rec_tag, m))


@numba.njit(cache=True, error_model="numpy")
def _keep_start(rec_t, rec_y, rec_q2, rec_q3, rec_q4, rec_tag, t, y, tag):
    """The record's first entry: the state a recorded span starts from (no step ends there: q = 0); returns the
    entries kept (1)."""
    rec_t[0] = t
    rec_y[0] = y
    rec_q2[0] = 0.0
    rec_q3[0] = 0.0
    rec_q4[0] = 0.0
    rec_tag[0] = tag
    return 1


@numba.njit(cache=True, error_model="numpy")
def _event_arrays(cap, n):
    """Room for ``cap`` events of n states: (t, k, code, y) (:class:`Result`'s ``ev_*``)."""
    return np.empty(cap), np.empty(cap, dtype=np.int64), np.empty(cap, dtype=np.int64), np.empty((cap, n))


@numba.njit(cache=True, error_model="numpy")
def _grown_events(ev_t, ev_k, ev_code, ev_y, n_ev):
    """The event log's arrays with their first n_ev entries, twice as long."""
    return _grow(ev_t, n_ev), _grow(ev_k, n_ev), _grow(ev_code, n_ev), _grow(ev_y, n_ev)


@numba.njit(cache=True, error_model="numpy")
def _pass_stops(tstops, i_stop, t, y, y_stops):
    """The state at every stop t has reached (into ``y_stops``); the index of the next stop."""
    while i_stop < tstops.shape[0] and tstops[i_stop] <= t:
        y_stops[i_stop] = y
        i_stop += 1
    return i_stop


#: the integrator's functions that call the model's (directly or through another), innermost first:
#: :func:`specialize` rebinds each to the model's functions
HOOKED = ("fd_jacobian", "rosenbrock_step", "rosenbrock5_step", "_illinois", "_locate_event")
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
