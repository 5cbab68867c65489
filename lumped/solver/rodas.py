"""A compiled stiff integrator: Rodas4P or Rodas5P, L-stable, stiffly accurate Rosenbrock methods.

Rodas4P (Steinebach 1995; METH = 3 of Hairer & Wanner's code RODAS, *Solving ODEs II*,
2nd ed., section IV.7) is a 6-stage Rosenbrock method of order 4 with an embedded
order-3 error estimate and a 3rd-order dense output. Unlike Rodas4 it keeps its order on
stiff problems driven by a time-dependent forcing (the Prothero-Robinson test, which is
the shape of a cylinder pressure driven by the crank: Rodas4 needed 5x the steps there). Each step solves six linear systems with one LU factorisation of
W = I/(h gamma) - J, so no Newton iteration is needed. It suits valve models well: L-stable,
so the stiff seat and stop contacts and the compressible cylinder do not limit the step
once their transients have decayed, and stiffly accurate, so a valve resting on its
seat is an exact equilibrium rather than a ringing one.

The right-hand side is a module-level name ``rhs(t, y, p, dydt)`` (fills ``dydt`` in
place; ``p`` a flat float64 parameter array). :func:`specialize` returns a copy of
:func:`solve` with ``rhs`` bound to a given ``numba.njit`` function, compiled once and
cached on disk under a name of its own, so every model gets a solver with its
right-hand side inlined and no Python in the loop.

The Jacobian is formed by forward differences over the first ``n_dyn`` states only (or by
the model's own ``jacobian``): the remaining states are quadratures (e.g. integrated mass
flows) that never feed back, so the linear systems of the stages are solved on the
n_dyn x n_dyn block alone.

Rodas5P (Steinebach 2023) is the same kind of method with 8 stages, order 5, an embedded
order-4 estimate and a 4th-order dense output; ``Options.order`` picks it. Where a stiff
component is slaved to a fast forcing (a valve's velocity under a transient flow force,
eigenvalues to -1e6 1/s) Rodas4P's embedded estimate over-reads its own error many times
(benchmarks/pump_step_anatomy.py); Rodas5P's does not, and takes half the steps at tight
tolerances. Both share one dense-output form, y0 (1 - s) + s (y1 + (1 - s) (q2 + s (q3 + s q4))),
with q4 = 0 for Rodas4P.

Everything is compiled with numba's ``error_model="numpy"``: a float division by zero gives
inf or nan (a non-finite stage, so a rejected step) instead of raising, and the divisions
need no zero test (about 30 % of a pump right-hand side call).
"""

from __future__ import annotations

import types
from typing import NamedTuple

import numba
import numpy as np

# Rodas4P coefficients (RODAS, METH = 3), in the transformed form
# W k_i = f(t + c_i h, y + sum a_ij k_j) + sum (C_ij / h) k_j + h d_i f_t.
GAMMA = 0.25
C2, C3, C4 = 0.75, 0.21, 0.63
D1, D2, D3, D4 = 0.25, -0.5, -0.023504, -0.0362
A21 = 3.0
A31, A32 = 1.831036793486759, 0.4955183967433795
A41, A42, A43 = 2.304376582692669, -0.05249275245743001, -1.176798761832782
A51, A52, A53, A54 = -7.170454962423024, -4.741636671481785, -16.31002631330971, -1.062004044111401
C21 = -12.0
C31, C32 = -8.791795173947035, -2.207865586973518
C41, C42, C43 = 10.81793056857153, 6.780270611428266, 19.53485944642410
C51, C52, C53, C54 = 34.19095006749676, 15.49671153725963, 54.74760875964130, 14.16005392148534
C61, C62, C63, C64, C65 = (34.62605830930532, 15.30084976114473, 56.99955578662667,
                           18.40807009793095, -5.714285714285717)
H21, H22, H23, H24, H25 = 25.09876703708589, 11.62013104361867, 28.49148307714626, -5.664021568594133, 0.0
H31, H32, H33, H34, H35 = 1.638054557396973, -0.7373619806678748, 8.477918219238990, 15.99253148779520, -1.882352941176471

# Rodas5P coefficients (S. Steinebach, BIT Numer. Math. 63 (2023) 27; as in OrdinaryDiffEq's
# Rodas5PTableau), same transformed form; stages 6-8 at t + h with d = 0, y1 = stage 8's input + k8.
P_GAMMA = 0.21193756319429014
P_C2, P_C3, P_C4, P_C5 = 0.6358126895828704, 0.4095798393397535, 0.9769306725060716, 0.4288403609558664
P_D1, P_D2, P_D3, P_D4, P_D5 = (0.21193756319429014, -0.42387512638858027, -0.3384627126235924,
                                1.8046452872882734, 2.325825639765069)
P_A21 = 3.0
P_A31, P_A32 = 2.849394379747939, 0.45842242204463923
P_A41, P_A42, P_A43 = -6.954028509809101, 2.489845061869568, -10.358996098473584
P_A51, P_A52, P_A53, P_A54 = 2.8029986275628964, 0.5072464736228206, -0.3988312541770524, -0.04721187230404641
P_A61, P_A62, P_A63, P_A64, P_A65 = (-7.502846399306121, 2.561846144803919, -11.627539656261098,
                                     -0.18268767659942256, 0.030198172008377946)
P_C21 = -14.155112264123755
P_C31, P_C32 = -17.97296035885952, -2.859693295451294
P_C41, P_C42, P_C43 = 147.12150275711716, -1.41221402718213, 71.68940251302358
P_C51, P_C52, P_C53, P_C54 = 165.43517024871676, -0.4592823456491126, 42.90938336958603, -5.961986721573306
P_C61, P_C62, P_C63, P_C64, P_C65 = (24.854864614690072, -3.0009227002832186, 47.4931110020768,
                                     5.5814197821558125, -0.6610691825249471)
P_C71, P_C72, P_C73, P_C74, P_C75, P_C76 = (30.91273214028599, -3.1208243349937974, 77.79954646070892,
                                            34.28646028294783, -19.097331116725623, -28.087943162872662)
P_C81, P_C82, P_C83, P_C84, P_C85, P_C86, P_C87 = (37.80277123390563, -3.2571969029072276, 112.26918849496327,
                                                   66.9347231244047, -40.06618937091002, -54.66780262877968,
                                                   -9.48861652309627)
P_H = np.array([[25.948786856663858, -2.5579724845846235, 10.433815404888879, -2.3679251022685204,
                 0.524948541321073, 1.1241088310450404, 0.4272876194431874, -0.17202221070155493],
                [-9.91568850695171, -0.9689944594115154, 3.0438037242978453, -24.495224566215796,
                 20.176138334709044, 15.98066361424651, -6.789040303419874, -6.710236069923372],
                [11.419903575922262, 2.8879645146136994, 72.92137995996029, 80.12511834622643,
                 -52.072871366152654, -59.78993625266729, -0.15582684282751913, 4.883087185713722]])

SAFE, FAC_MIN, FAC_MAX = 0.9, 0.2, 6.0  # step ratio limits of RODAS
MAX_EVENT_RETRIES = 3  # times a step is redone to end at a crossing located on its interpolant
EVENT_RETRY_WINDOW = 1e-3  # ... unless the crossing lies this close (step fraction) to either end

#: solver status codes
OK, MAX_STEPS, STEP_TOO_SMALL, TOO_MANY_EVENTS = 0, 1, 2, 3
#: each status code in words
STATUS_TEXT = {OK: "ok", MAX_STEPS: "too many steps", STEP_TOO_SMALL: "step size underflow",
               TOO_MANY_EVENTS: "too many events (chatter)"}


@numba.njit(cache=True, error_model="numpy")
def rhs(t, y, p, dydt):  # never used: specialize() always binds the model's rhs
    dydt[:] = 0.0


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
def lu_factor(a, piv):
    """In-place LU factorisation with partial pivoting of a small dense matrix; False if singular."""
    n = a.shape[0]
    for k in range(n):
        m = k
        big = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                big = abs(a[i, k])
                m = i
        piv[k] = m
        if big == 0.0 or not np.isfinite(big):
            return False
        if m != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[m, j]
                a[m, j] = tmp
        inv = 1.0 / a[k, k]
        for i in range(k + 1, n):
            a[i, k] *= inv
            f = a[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]
    return True


@numba.njit(cache=True, error_model="numpy")
def stage_solve(w, piv, jac, hg, b, n_dyn):
    """Solve (I/(h gamma) - J) k = b in place in b, for a J whose columns n_dyn.. are zero.

    The quadrature states (the last n - n_dyn) never feed back, so only the n_dyn x n_dyn
    block, factorised in ``w`` (:func:`lu_factor`), needs a solve; their own rows then give
    k_q = h gamma (b_q + J_qd k_d) directly. hg = h gamma.
    """
    lu_solve(w, piv, b[:n_dyn])
    for i in range(n_dyn, b.shape[0]):
        s = b[i]
        for j in range(n_dyn):
            s += jac[i, j] * b[j]
        b[i] = hg * s


@numba.njit(cache=True, error_model="numpy")
def lu_solve(a, piv, b):
    """Solve (LU) x = b in place in b, with the factors and pivots of :func:`lu_factor`."""
    n = a.shape[0]
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp
    for i in range(1, n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]


@numba.njit(cache=True, error_model="numpy")
def dense(s, y0, y1, q2, q3, q4):
    """The step's interpolant at fraction s of a step from y0 to y1 (Rodas4P's 3rd order: q4 = 0;
    Rodas5P's 4th)."""
    return y0 * (1.0 - s) + s * (y1 + (1.0 - s) * (q2 + s * (q3 + s * q4)))


@numba.njit(cache=True, error_model="numpy")
def _grow(a, m):
    b = np.empty((2 * a.shape[0] + 16,) + a.shape[1:], dtype=a.dtype)
    b[:m] = a[:m]
    return b


@numba.njit(cache=True, error_model="numpy")
def _dense_into(s, y0, y1, q2, q3, q4, out):
    for i in range(y0.shape[0]):
        out[i] = dense(s, y0[i], y1[i], q2[i], q3[i], q4[i])


# Points per step where the event functions are checked: the step end only, as scipy's
# solve_ivp does. Scanning the interpolant inside the step would also catch a crossing and
# return within one step, but the interpolant of a stiff transient (a valve settling on
# its stop) can dip across a surface the solution never crosses: spurious switches.
N_SCAN = 1


@numba.njit(cache=True, error_model="numpy")
def _locate_event(t, h, y0, y1, q2, q3, q4, p, g0, g, ybuf, n_events):
    """(k, s): the event that fires first in this step and the step fraction where it does.

    An event k fires where g_k drops from >= 0 to < 0. The interpolant is checked at
    N_SCAN points to bracket the first crossing, which the Illinois method (regula falsi
    that halves the stale end's value; Dowell & Jarratt 1971) on the interpolant then
    refines to 1e-13 of the step, with a bisection whenever the bracket fails to halve
    twice running: about 6-10 evaluations instead of bisection's 43. k = -1 if no event fires.
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
    # which events are negative at hi (any already negative at the start fire at once)
    best_k = -1
    best_s = 2.0
    for kk in range(n_events):
        if g0[kk] < 0.0 and g[kk] < 0.0:
            return kk, 0.0
    gs = np.empty(g.shape[0])
    g_lo = g0                     # the event values at the bracket's start (the step's, unless scanned past)
    if lo > 0.0:
        g_lo = np.empty(g.shape[0])
        _dense_into(lo, y0, y1, q2, q3, q4, ybuf)
        event_values(t + lo * h, ybuf, p, g_lo)
    for kk in range(n_events):
        if g[kk] >= 0.0:
            continue
        a = lo
        b = min(hi, best_s)       # an event can only come first before the best so far
        fa = g_lo[kk]
        fb = g[kk]
        if b < hi:
            _dense_into(b, y0, y1, q2, q3, q4, ybuf)
            event_values(t + b * h, ybuf, p, gs)
            if gs[kk] >= 0.0:
                continue
            fb = gs[kk]
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
        if b < best_s:
            best_s = b
            best_k = kk
    return best_k, best_s


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
def _factor_w(w, piv, jac, fac, n_dyn):
    """W = I fac - J on the first n_dyn block (fac = 1/(h gamma)), factorised in ``w``; False if singular."""
    for i in range(n_dyn):
        for j in range(n_dyn):
            w[i, j] = -jac[i, j]
        w[i, i] += fac
    return lu_factor(w, piv)


@numba.njit(cache=True, error_model="numpy")
def _last_stage(y, u, k_last, ynew, rtol, atol):
    """ynew = u + k_last (the step's result); (ok, err), err the RMS of k_last (the embedded estimate) over
    atol_i + rtol max(|y_i|, |ynew_i|)."""
    n = y.shape[0]
    err = 0.0
    for i in range(n):
        ynew[i] = u[i] + k_last[i]
        sk = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
        err += (k_last[i] / sk) ** 2
    err = np.sqrt(err / n)
    return np.isfinite(err), err


@numba.njit(cache=True, error_model="numpy")
def rosenbrock_step(t, h, y, p, f0, ft, jac, w, piv, k, u, ynew, n_dyn, rtol, atol):
    """One Rodas4P step of size h from (t, y): stages in ``k`` (6 x n), the result in ``ynew``.

    Factorises W = I/(h gamma) - J (first n_dyn block) in ``w``; returns (ok, err), err the
    RMS of the embedded error estimate over err_i / (atol_i + rtol max(|y_i|, |ynew_i|));
    ok False for a singular W or a non-finite stage (e.g. a state left the model's domain).
    """
    n = y.shape[0]
    fac = 1.0 / (h * GAMMA)
    hg = h * GAMMA
    if not _factor_w(w, piv, jac, fac, n_dyn):
        return False, 0.0
    k1, k2, k3, k4, k5, k6 = k[0], k[1], k[2], k[3], k[4], k[5]
    hc21, hc31, hc32 = C21 / h, C31 / h, C32 / h
    hc41, hc42, hc43 = C41 / h, C42 / h, C43 / h
    hc51, hc52, hc53, hc54 = C51 / h, C52 / h, C53 / h, C54 / h
    hc61, hc62, hc63, hc64, hc65 = C61 / h, C62 / h, C63 / h, C64 / h, C65 / h
    for i in range(n):
        k1[i] = f0[i] + h * D1 * ft[i]
    stage_solve(w, piv, jac, hg, k1, n_dyn)
    for i in range(n):
        u[i] = y[i] + A21 * k1[i]
    rhs(t + C2 * h, u, p, k2)
    for i in range(n):
        k2[i] += h * D2 * ft[i] + hc21 * k1[i]
    stage_solve(w, piv, jac, hg, k2, n_dyn)
    for i in range(n):
        u[i] = y[i] + A31 * k1[i] + A32 * k2[i]
    rhs(t + C3 * h, u, p, k3)
    for i in range(n):
        k3[i] += h * D3 * ft[i] + hc31 * k1[i] + hc32 * k2[i]
    stage_solve(w, piv, jac, hg, k3, n_dyn)
    for i in range(n):
        u[i] = y[i] + A41 * k1[i] + A42 * k2[i] + A43 * k3[i]
    rhs(t + C4 * h, u, p, k4)
    for i in range(n):
        k4[i] += h * D4 * ft[i] + hc41 * k1[i] + hc42 * k2[i] + hc43 * k3[i]
    stage_solve(w, piv, jac, hg, k4, n_dyn)
    for i in range(n):
        u[i] = y[i] + A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]
    rhs(t + h, u, p, k5)
    for i in range(n):
        k5[i] += hc51 * k1[i] + hc52 * k2[i] + hc53 * k3[i] + hc54 * k4[i]
    stage_solve(w, piv, jac, hg, k5, n_dyn)
    for i in range(n):
        u[i] += k5[i]
    rhs(t + h, u, p, k6)
    for i in range(n):
        k6[i] += hc61 * k1[i] + hc62 * k2[i] + hc63 * k3[i] + hc64 * k4[i] + hc65 * k5[i]
    stage_solve(w, piv, jac, hg, k6, n_dyn)
    return _last_stage(y, u, k6, ynew, rtol, atol)


@numba.njit(cache=True, error_model="numpy")
def rosenbrock5_step(t, h, y, p, f0, ft, jac, w, piv, k, u, ynew, n_dyn, rtol, atol):
    """One Rodas5P step of size h from (t, y): stages in ``k`` (8 x n), the result in ``ynew``;
    (ok, err) as :func:`rosenbrock_step`, err from the embedded order-4 estimate (the last stage)."""
    n = y.shape[0]
    hg = h * P_GAMMA
    if not _factor_w(w, piv, jac, 1.0 / hg, n_dyn):
        return False, 0.0
    k1, k2, k3, k4, k5, k6, k7, k8 = k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7]
    ih = 1.0 / h
    for i in range(n):
        k1[i] = f0[i] + h * P_D1 * ft[i]
    stage_solve(w, piv, jac, hg, k1, n_dyn)
    for i in range(n):
        u[i] = y[i] + P_A21 * k1[i]
    rhs(t + P_C2 * h, u, p, k2)
    for i in range(n):
        k2[i] += h * P_D2 * ft[i] + ih * P_C21 * k1[i]
    stage_solve(w, piv, jac, hg, k2, n_dyn)
    for i in range(n):
        u[i] = y[i] + P_A31 * k1[i] + P_A32 * k2[i]
    rhs(t + P_C3 * h, u, p, k3)
    for i in range(n):
        k3[i] += h * P_D3 * ft[i] + ih * (P_C31 * k1[i] + P_C32 * k2[i])
    stage_solve(w, piv, jac, hg, k3, n_dyn)
    for i in range(n):
        u[i] = y[i] + P_A41 * k1[i] + P_A42 * k2[i] + P_A43 * k3[i]
    rhs(t + P_C4 * h, u, p, k4)
    for i in range(n):
        k4[i] += h * P_D4 * ft[i] + ih * (P_C41 * k1[i] + P_C42 * k2[i] + P_C43 * k3[i])
    stage_solve(w, piv, jac, hg, k4, n_dyn)
    for i in range(n):
        u[i] = y[i] + P_A51 * k1[i] + P_A52 * k2[i] + P_A53 * k3[i] + P_A54 * k4[i]
    rhs(t + P_C5 * h, u, p, k5)
    for i in range(n):
        k5[i] += h * P_D5 * ft[i] + ih * (P_C51 * k1[i] + P_C52 * k2[i] + P_C53 * k3[i] + P_C54 * k4[i])
    stage_solve(w, piv, jac, hg, k5, n_dyn)
    for i in range(n):
        u[i] = y[i] + P_A61 * k1[i] + P_A62 * k2[i] + P_A63 * k3[i] + P_A64 * k4[i] + P_A65 * k5[i]
    rhs(t + h, u, p, k6)
    for i in range(n):
        k6[i] += ih * (P_C61 * k1[i] + P_C62 * k2[i] + P_C63 * k3[i] + P_C64 * k4[i] + P_C65 * k5[i])
    stage_solve(w, piv, jac, hg, k6, n_dyn)
    for i in range(n):
        u[i] += k6[i]
    rhs(t + h, u, p, k7)
    for i in range(n):
        k7[i] += ih * (P_C71 * k1[i] + P_C72 * k2[i] + P_C73 * k3[i] + P_C74 * k4[i] + P_C75 * k5[i]
                       + P_C76 * k6[i])
    stage_solve(w, piv, jac, hg, k7, n_dyn)
    for i in range(n):
        u[i] += k7[i]
    rhs(t + h, u, p, k8)
    for i in range(n):
        k8[i] += ih * (P_C81 * k1[i] + P_C82 * k2[i] + P_C83 * k3[i] + P_C84 * k4[i] + P_C85 * k5[i]
                       + P_C86 * k6[i] + P_C87 * k7[i])
    stage_solve(w, piv, jac, hg, k8, n_dyn)
    return _last_stage(y, u, k8, ynew, rtol, atol)


@numba.njit(cache=True, error_model="numpy")
def dense_coefficients(k, q2, q3, q4, order):
    """q2, q3, q4 of the step's interpolant (:func:`dense`) from its stages: Rodas4P's 3rd-order
    (order 4: q4 = 0) or Rodas5P's 4th-order one (order 5)."""
    if order == 5:
        for i in range(q2.shape[0]):
            a2 = 0.0
            a3 = 0.0
            a4 = 0.0
            for j in range(8):
                a2 += P_H[0, j] * k[j, i]
                a3 += P_H[1, j] * k[j, i]
                a4 += P_H[2, j] * k[j, i]
            q2[i] = a2
            q3[i] = a3
            q4[i] = a4
        return
    for i in range(q2.shape[0]):
        q2[i] = H21 * k[0, i] + H22 * k[1, i] + H23 * k[2, i] + H24 * k[3, i] + H25 * k[4, i]
        q3[i] = H31 * k[0, i] + H32 * k[1, i] + H33 * k[2, i] + H34 * k[3, i] + H35 * k[4, i]
        q4[i] = 0.0


@numba.njit(cache=True, error_model="numpy")
def _cut_interpolant(s_ev, y, ynew, q2, q3, q4, order):
    """Cut a step's interpolant at fraction s_ev: ynew, q2, q3, q4 become the sub-step's own."""
    y_e = dense(s_ev, y, ynew, q2, q3, q4)
    if order != 5:
        y1 = dense(s_ev / 3.0, y, ynew, q2, q3, q4)
        y2 = dense(2.0 * s_ev / 3.0, y, ynew, q2, q3, q4)
        for i in range(y.shape[0]):
            # P(s x) - y0 (1 - x) - x P(s) = x (1 - x) (a + b x), exact for a cubic P: fit a, b at x = 1/3, 2/3
            r1 = y1[i] - y[i] * (2.0 / 3.0) - y_e[i] / 3.0
            r2 = y2[i] - y[i] / 3.0 - y_e[i] * (2.0 / 3.0)
            a1 = r1 / (2.0 / 9.0)
            a2 = r2 / (2.0 / 9.0)
            bb = 3.0 * (a2 - a1)
            q3[i] = bb
            q2[i] = a1 - bb / 3.0
        ynew[:] = y_e
        return
    y1 = dense(0.25 * s_ev, y, ynew, q2, q3, q4)
    y2 = dense(0.5 * s_ev, y, ynew, q2, q3, q4)
    y3 = dense(0.75 * s_ev, y, ynew, q2, q3, q4)
    for i in range(y.shape[0]):
        # the same for Rodas5P's quartic P: a + b x + c x^2 through its values at x = 1/4, 1/2, 3/4
        v1 = (y1[i] - y[i] * 0.75 - y_e[i] * 0.25) / 0.1875
        v2 = (y2[i] - y[i] * 0.5 - y_e[i] * 0.5) / 0.25
        v3 = (y3[i] - y[i] * 0.25 - y_e[i] * 0.75) / 0.1875
        c = 8.0 * (v1 - 2.0 * v2 + v3)
        b = 2.0 * (v3 - v1) - c
        q2[i] = v2 - 0.5 * b - 0.25 * c
        q3[i] = b
        q4[i] = c
    ynew[:] = y_e


@numba.njit(cache=True, error_model="numpy")
def solve(t0, y0, tstops, p, opts):
    """Integrate y' = rhs(t, y, p) from t0 through every time in ``tstops`` (ascending); a :class:`Result`.

    Steps land exactly on each stop. Error control: RMS over components of err_i /
    (atol_i + rtol max(|y_i|, |y_new_i|)), atol as the model's ``update_tolerances(p,
    atol)`` sets it at the start and after every event; Gustafsson's predictive step
    controller, as in RODAS.

    Events (``opts.n_events`` > 0): ``event_values(t, y, p, g)`` gives one value per
    event (g holds the state's length more, scratch the model may use); event k fires where g_k
    drops from >= 0 to < 0. The first crossing is found on
    the dense output; the step is redone (up to MAX_EVENT_RETRIES times, where
    ``event_retry(k, p)``) to end there, since the interpolant of a long step does not
    follow a stiff component, and the crossing located again is where the step is cut.
    There ``apply_event(k, t, y, p)`` switches the model (it may change ``p`` and ``y``;
    its return value is logged) and integration restarts, so the right-hand side is
    smooth inside every step.
    """
    n = y0.shape[0]
    n_dyn = opts.n_dyn
    rtol = opts.rtol
    atol = opts.atol
    y = y0.copy()
    t = t0
    t_end = tstops[-1]
    update_tolerances(p, atol)
    n_stops = tstops.shape[0]
    y_stops = np.full((n_stops, n), np.nan)
    f0 = np.empty(n)
    ft = np.empty(n)
    fp = np.empty(n)
    jac = np.empty((n, n))
    w = np.empty((n_dyn, n_dyn))
    piv = np.empty(n_dyn, dtype=np.int64)
    order = opts.order
    expo = 0.2 if order == 5 else 0.25    # the step ratio goes as err^(-1/order) (embedded estimate order + 1)
    k = np.empty((8, n))
    u = np.empty(n)
    yp = np.empty(n)
    ynew = np.empty(n)
    q2 = np.empty(n)
    q3 = np.empty(n)
    q4 = np.empty(n)
    n_events = opts.n_events
    # the event functions' values, then the state's length of scratch the model's event function may use
    g0 = np.empty(max(n_events, 1) + n)
    g1 = np.empty(max(n_events, 1) + n)
    cap = 1024
    rec_t = np.empty(cap)
    rec_y = np.empty((cap, n))
    rec_q2 = np.empty((cap, n))
    rec_q3 = np.empty((cap, n))
    rec_q4 = np.empty((cap, n))
    rec_tag = np.empty(cap, dtype=np.int64)
    ecap = 64
    ev_t = np.empty(ecap)
    ev_k = np.empty(ecap, dtype=np.int64)
    ev_code = np.empty(ecap, dtype=np.int64)
    ev_y = np.empty((ecap, n))
    n_ev = 0
    m = 0
    if opts.t_record <= t0:
        rec_t[0] = t
        rec_y[0] = y
        rec_q2[0] = 0.0
        rec_q3[0] = 0.0
        rec_q4[0] = 0.0
        rec_tag[0] = step_tag(p)
        m = 1

    h = min(opts.h0, opts.hmax, t_end - t0)
    n_steps = 0
    n_rej = 0
    n_rhs = 0
    status = OK
    i_stop = 0
    while i_stop < n_stops and tstops[i_stop] <= t:
        y_stops[i_stop] = y
        i_stop += 1
    h_acc = 0.0
    err_acc = 1.0
    first = True
    reject = False
    f_fresh = False
    jac_age = opts.jac_reuse  # forces a Jacobian at the first step
    retries = 0               # steps redone to end at the located crossing of the pending event
    g_fresh = False           # g0 holds the event values at (t, y): the last step's end, scanned already
    # the event whose first step is being taken: an impact starts a stiff contact transient that a
    # step sized on the flight before cannot follow (three rejections of 10x each, measured); the
    # same kind of event recurs every revolution, so its last first step is remembered in opts.h_event
    after_event = -1
    h_event = opts.h_event
    while i_stop < n_stops:
        if n_steps >= opts.max_steps:
            status = MAX_STEPS
            break
        t_stop = tstops[i_stop]
        h_try = min(h, opts.hmax)
        hit = False
        if t + h_try >= t_stop - 1e-12 * abs(t_stop):
            h_try = t_stop - t
            hit = True
        if h_try <= 1e-14 * max(abs(t), 1e-300) or h_try <= 0.0:
            status = STEP_TOO_SMALL
            break
        # f(t, y) at the step start; the Jacobian and f_t, kept for up to jac_reuse accepted
        # steps (fresh after an event or a rejection)
        if not f_fresh:
            rhs(t, y, p, f0)
            n_rhs += 1
            if n_events > 0 and not g_fresh:
                event_values(t, y, p, g0)
            f_fresh = True
        if jac_age >= opts.jac_reuse or (reject and jac_age > 0):
            nj = jacobian(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h_try)
            if nj < 0:
                nj = fd_jacobian(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h_try)
            n_rhs += nj
            jac_age = 0
        if order == 5:
            ok, err = rosenbrock5_step(t, h_try, y, p, f0, ft, jac, w, piv, k, u, ynew, n_dyn, rtol, atol)
            n_rhs += 7
        else:
            ok, err = rosenbrock_step(t, h_try, y, p, f0, ft, jac, w, piv, k, u, ynew, n_dyn, rtol, atol)
            n_rhs += 5
        if not ok:
            h = 0.25 * h_try
            reject = True
            n_rej += 1
            continue
        n_steps += 1
        fac_h = max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, err**expo / SAFE))
        h_new = h_try / fac_h
        if err > 1.0:
            n_rej += 1
            h = h_new if not first else 0.1 * h_try
            reject = True
            continue
        # ---- accepted by the error test
        dense_coefficients(k, q2, q3, q4, order)
        # ---- events: the first crossing on the dense output
        k_ev = -1
        s_ev = 2.0
        if n_events > 0:
            k_ev, s_ev = _locate_event(t, h_try, y, ynew, q2, q3, q4, p, g0, g1, yp, n_events)
            if (k_ev >= 0 and retries < MAX_EVENT_RETRIES and EVENT_RETRY_WINDOW < s_ev < 1.0 - EVENT_RETRY_WINDOW
                    and event_retry(k_ev, p)):
                # the interpolant locates a crossing only as well as it follows the solution:
                # redo the step so that it ends at the located crossing, and locate it again
                # on that shorter step (near either end the interpolant is pinned to the states)
                retries += 1
                h = s_ev * h_try
                event_values(t, y, p, g0)      # g0 served as scratch; y, f0 and J still hold
                continue
        if after_event >= 0:
            h_event[after_event] = h_new
            after_event = -1
        if not first:
            fg = (h_acc / h_try) * (err * err / err_acc) ** expo / SAFE
            fg = max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, fg))
            fac_h = max(fac_h, fg)
            h_new = h_try / fac_h
        h_acc = h_try
        err_acc = max(1e-2, err)
        first = False
        if reject:
            h_new = min(h_new, h_try)
        reject = False
        t_old = t
        t = t_stop if hit else t + h_try
        tag = step_tag(p)
        if k_ev >= 0:
            _cut_interpolant(s_ev, y, ynew, q2, q3, q4, order)
            t = t_old + s_ev * h_try
            hit = False
        if t >= opts.t_record and (t > t_old or m == 0):
            if m == 0 and t > opts.t_record:
                # the step that crosses t_record: keep its start too
                rec_t[0] = t_old
                rec_y[0] = y
                rec_q2[0] = 0.0
                rec_q3[0] = 0.0
                rec_q4[0] = 0.0
                rec_tag[0] = tag
                m = 1
            if m >= rec_t.shape[0]:
                rec_t = _grow(rec_t, m)
                rec_y = _grow(rec_y, m)
                rec_q2 = _grow(rec_q2, m)
                rec_q3 = _grow(rec_q3, m)
                rec_q4 = _grow(rec_q4, m)
                rec_tag = _grow(rec_tag, m)
            rec_t[m] = t
            rec_y[m] = ynew
            rec_q2[m] = q2
            rec_q3[m] = q3
            rec_q4[m] = q4
            rec_tag[m] = tag
            m += 1
        y[:] = ynew
        f_fresh = False
        # the scan evaluated the events at the step's end (s = 1 is y_new exactly): the next start's values
        g_fresh = k_ev < 0 and n_events > 0
        if g_fresh:
            g0[:n_events] = g1[:n_events]
        jac_age += 1
        if k_ev >= 0:
            jac_age = opts.jac_reuse
            retries = 0
            if n_ev >= ev_t.shape[0]:
                ev_t = _grow(ev_t, n_ev)
                ev_k = _grow(ev_k, n_ev)
                ev_code = _grow(ev_code, n_ev)
                ev_y = _grow(ev_y, n_ev)
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
            # the dynamics change here: restart the step-size history
            first = True
            h = max(min(h_new, h_try), 1e-6 * h_try)
            if 0 <= code < h_event.shape[0]:
                if h_event[code] > 0.0:
                    h = min(h, h_event[code])
                after_event = code
            continue
        if hit:
            while i_stop < n_stops and tstops[i_stop] <= t:
                y_stops[i_stop] = y
                i_stop += 1
            # a step clipped to land on a stop does not shrink the next one
            h = max(h_new, h)
        else:
            h = h_new
    return Result(status, y_stops, rec_t[:m], rec_y[:m], rec_q2[:m], rec_q3[:m], rec_q4[:m], rec_tag[:m],
                  ev_t[:n_ev], ev_k[:n_ev], ev_code[:n_ev], ev_y[:n_ev], n_steps, n_rej, n_rhs, h)


def _rebind(func, scope: dict, tag: str, cache: bool = False):
    """A numba.njit copy of ``func`` (a dispatcher) reading its globals from ``scope``."""
    base = func.py_func
    fn = types.FunctionType(base.__code__, scope, base.__name__, base.__defaults__, base.__closure__)
    fn.__qualname__ = f"{base.__qualname__}__{tag}"
    fn.__module__ = base.__module__
    fn.__doc__ = base.__doc__
    return numba.njit(cache=cache, error_model="numpy")(fn)


def specialize(rhs_func, tag: str, events=None, apply=None, tagger=None, jac=None, tolerances=None,
               retry=None, cache: bool = True):
    """A compiled :func:`solve` bound to a model's functions (numba.njit), inlined, no Python.

    ``rhs_func(t, y, p, dydt)``; optional ``events(t, y, p, g)``, ``apply(k, t, y, p) -> int``,
    ``tagger(p) -> int`` and ``jac(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h) -> int``
    (fills df/dy and df/dt, returns the rhs calls used, or -1 to fall back to forward
    differences; its columns n_dyn.. must stay zero) and ``tolerances(p, atol)`` (may rewrite
    the absolute tolerances in place from the model state; called at the start and after
    every event) and ``retry(k, p) -> bool`` (False:
    event k is located on the interpolant of the step as it is, no step redone; for crossings
    whose variable the interpolant follows to the tolerance). ``tag`` names the compiled copy
    (its on-disk cache entry), e.g. "pump_<hash>"; a tag must stand for one set of functions.
    """
    scope = dict(solve.py_func.__globals__)
    scope["rhs"] = rhs_func
    for name, f in (("event_values", events), ("apply_event", apply), ("step_tag", tagger), ("jacobian", jac),
                    ("update_tolerances", tolerances), ("event_retry", retry)):
        if f is not None:
            scope[name] = f
    # helpers that call the model's functions get the same bindings
    scope["fd_jacobian"] = _rebind(fd_jacobian, scope, tag)
    scope["_locate_event"] = _rebind(_locate_event, scope, tag)
    scope["rosenbrock_step"] = _rebind(rosenbrock_step, scope, tag)
    scope["rosenbrock5_step"] = _rebind(rosenbrock5_step, scope, tag)
    return _rebind(solve, scope, tag, cache=cache)


def interpolate(t, rec_t, rec_y, rec_q2, rec_q3, rec_q4):
    """States at times ``t`` (array, inside the recorded span) from the dense output."""
    return _interpolate(np.asarray(t, dtype=float), rec_t, rec_y, rec_q2, rec_q3, rec_q4)


@numba.njit(cache=True, error_model="numpy")
def sample_modes(t, rec_t, rec_tag, n_mode):
    """The modes (rows, floats) of the recorded steps the times ``t`` fall in, decoded from their tags
    (lumped.solver.layout.mode_tag: base 3, the first mode slot the lowest digit)."""
    # compiled: numpy's integer division over 1440 x N_MODE took 0.09 ms a revolution, a thirtieth of a design
    last = len(rec_t) - 1
    out = np.empty((len(t), n_mode))
    for k in range(len(t)):
        tag = rec_tag[min(max(np.searchsorted(rec_t, t[k]), 1), last)]
        for i in range(n_mode):
            out[k, i] = tag % 3
            tag //= 3
    return out


@numba.njit(cache=True, error_model="numpy")
def _interpolate(t, rec_t, rec_y, rec_q2, rec_q3, rec_q4):
    # compiled: the post-processors sample 1440 points of a revolution, a sixth of a sweep design's time in numpy
    n, m, last = len(t), rec_y.shape[1], len(rec_t) - 1
    out = np.empty((n, m))
    for k in range(n):
        i = min(max(np.searchsorted(rec_t, t[k]), 1), last)
        s = (t[k] - rec_t[i - 1]) / (rec_t[i] - rec_t[i - 1])
        for j in range(m):
            out[k, j] = dense(s, rec_y[i - 1, j], rec_y[i, j], rec_q2[i, j], rec_q3[i, j], rec_q4[i, j])
    return out
