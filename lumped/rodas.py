"""A compiled stiff integrator: Rodas4P, an L-stable, stiffly accurate Rosenbrock method.

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

The Jacobian is formed by forward differences over the first ``n_dyn`` states only: the
remaining states are quadratures (e.g. integrated mass flows) that never feed back.
"""

from __future__ import annotations

import types

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

SAFE, FAC_MIN, FAC_MAX = 0.9, 0.2, 6.0  # step ratio limits of RODAS

#: solver status codes
OK, MAX_STEPS, STEP_TOO_SMALL = 0, 1, 2
STATUS_TEXT = {OK: "ok", MAX_STEPS: "too many steps", STEP_TOO_SMALL: "step size underflow"}


@numba.njit(cache=True)
def rhs(t, y, p, dydt):  # pragma: no cover - placeholder, replaced by specialize()
    dydt[:] = 0.0


@numba.njit(cache=True)
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


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def dense(s, y0, y1, q2, q3):
    """Rodas4P's 3rd-order interpolant at fraction s of a step from y0 to y1."""
    return y0 * (1.0 - s) + s * (y1 + (1.0 - s) * (q2 + s * q3))


@numba.njit(cache=True)
def _grow(a, m):
    b = np.empty((2 * a.shape[0] + 16,) + a.shape[1:])
    b[:m] = a[:m]
    return b


@numba.njit(cache=True)
def solve(t0, y0, tstops, p, rtol, atol, h0, hmax, max_steps, n_dyn, t_record):
    """Integrate y' = rhs(t, y, p) from t0 through every time in ``tstops`` (ascending).

    Steps land exactly on each stop; ``y_stops[i]`` is the state there. From ``t_record`` on
    every accepted step is kept with its dense-output coefficients (``rec_t``, ``rec_y``,
    ``rec_q2``, ``rec_q3``: step i runs from rec_t[i-1] to rec_t[i], its coefficients stored
    at i). Error control: RMS over components of err_i / (atol_i + rtol max(|y_i|, |y_new_i|)).

    Returns (status, y_stops, rec_t, rec_y, rec_q2, rec_q3, n_steps, n_rejected, n_rhs).
    """
    n = y0.shape[0]
    y = y0.copy()
    t = t0
    t_end = tstops[-1]
    n_stops = tstops.shape[0]
    y_stops = np.full((n_stops, n), np.nan)
    f0 = np.empty(n)
    ft = np.empty(n)
    fp = np.empty(n)
    jac = np.empty((n, n))
    w = np.empty((n, n))
    piv = np.empty(n, dtype=np.int64)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    k5 = np.empty(n)
    k6 = np.empty(n)
    u = np.empty(n)
    yp = np.empty(n)
    ynew = np.empty(n)
    cap = 1024
    rec_t = np.empty(cap)
    rec_y = np.empty((cap, n))
    rec_q2 = np.empty((cap, n))
    rec_q3 = np.empty((cap, n))
    m = 0
    if t_record <= t0:
        rec_t[0] = t
        rec_y[0] = y
        rec_q2[0] = 0.0
        rec_q3[0] = 0.0
        m = 1

    eps = 2.220446049250313e-16
    sq = np.sqrt(eps)
    h = min(h0, hmax, t_end - t0)
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
    jac_fresh = False
    while i_stop < n_stops:
        if n_steps >= max_steps:
            status = MAX_STEPS
            break
        t_stop = tstops[i_stop]
        h_try = min(h, hmax)
        hit = False
        if t + h_try >= t_stop - 1e-12 * abs(t_stop):
            h_try = t_stop - t
            hit = True
        if h_try <= 1e-14 * max(abs(t), 1e-300) or h_try <= 0.0:
            status = STEP_TOO_SMALL
            break
        # Jacobian and time derivative by forward differences (reused after a rejection)
        if not jac_fresh:
            rhs(t, y, p, f0)
            n_rhs += 1
            for j in range(n):
                for i in range(n):
                    jac[i, j] = 0.0
            for j in range(n_dyn):
                scale = max(abs(y[j]), atol[j] / rtol)
                dy = sq * scale
                yp[:] = y
                yp[j] = y[j] + dy
                dy = yp[j] - y[j]
                rhs(t, yp, p, fp)
                n_rhs += 1
                for i in range(n):
                    jac[i, j] = (fp[i] - f0[i]) / dy
            dt = sq * max(abs(t), abs(h_try), 1e-10)
            rhs(t + dt, y, p, fp)
            n_rhs += 1
            for i in range(n):
                ft[i] = (fp[i] - f0[i]) / dt
            jac_fresh = True
        fac = 1.0 / (h_try * GAMMA)
        for i in range(n):
            for j in range(n):
                w[i, j] = -jac[i, j]
            w[i, i] += fac
        ok = lu_factor(w, piv)
        if ok:
            hc21, hc31, hc32 = C21 / h_try, C31 / h_try, C32 / h_try
            hc41, hc42, hc43 = C41 / h_try, C42 / h_try, C43 / h_try
            hc51, hc52, hc53, hc54 = C51 / h_try, C52 / h_try, C53 / h_try, C54 / h_try
            hc61, hc62, hc63, hc64, hc65 = C61 / h_try, C62 / h_try, C63 / h_try, C64 / h_try, C65 / h_try
            for i in range(n):
                k1[i] = f0[i] + h_try * D1 * ft[i]
            lu_solve(w, piv, k1)
            for i in range(n):
                u[i] = y[i] + A21 * k1[i]
            rhs(t + C2 * h_try, u, p, k2)
            for i in range(n):
                k2[i] += h_try * D2 * ft[i] + hc21 * k1[i]
            lu_solve(w, piv, k2)
            for i in range(n):
                u[i] = y[i] + A31 * k1[i] + A32 * k2[i]
            rhs(t + C3 * h_try, u, p, k3)
            for i in range(n):
                k3[i] += h_try * D3 * ft[i] + hc31 * k1[i] + hc32 * k2[i]
            lu_solve(w, piv, k3)
            for i in range(n):
                u[i] = y[i] + A41 * k1[i] + A42 * k2[i] + A43 * k3[i]
            rhs(t + C4 * h_try, u, p, k4)
            for i in range(n):
                k4[i] += h_try * D4 * ft[i] + hc41 * k1[i] + hc42 * k2[i] + hc43 * k3[i]
            lu_solve(w, piv, k4)
            for i in range(n):
                u[i] = y[i] + A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]
            rhs(t + h_try, u, p, k5)
            for i in range(n):
                k5[i] += hc51 * k1[i] + hc52 * k2[i] + hc53 * k3[i] + hc54 * k4[i]
            lu_solve(w, piv, k5)
            for i in range(n):
                u[i] += k5[i]
            rhs(t + h_try, u, p, k6)
            for i in range(n):
                k6[i] += hc61 * k1[i] + hc62 * k2[i] + hc63 * k3[i] + hc64 * k4[i] + hc65 * k5[i]
            lu_solve(w, piv, k6)
            n_rhs += 5
            err = 0.0
            for i in range(n):
                ynew[i] = u[i] + k6[i]
                sk = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
                err += (k6[i] / sk) ** 2
            err = np.sqrt(err / n)
            if not np.isfinite(err):
                ok = False
        if not ok:
            # singular W or a non-finite stage (e.g. a state left the model's domain)
            h = 0.25 * h_try
            reject = True
            n_rej += 1
            continue
        n_steps += 1
        fac_h = max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, err**0.25 / SAFE))
        h_new = h_try / fac_h
        if err <= 1.0:
            if not first:
                # Gustafsson's predictive controller (as in RODAS)
                fg = (h_acc / h_try) * (err * err / err_acc) ** 0.25 / SAFE
                fg = max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, fg))
                fac_h = max(fac_h, fg)
                h_new = h_try / fac_h
            h_acc = h_try
            err_acc = max(1e-2, err)
            first = False
            t_old = t
            t = t_stop if hit else t + h_try
            if t >= t_record:
                if m == 0 and t > t_record:
                    # the step that crosses t_record: keep its start too
                    rec_t[0] = t_old
                    rec_y[0] = y
                    rec_q2[0] = 0.0
                    rec_q3[0] = 0.0
                    m = 1
                if m >= rec_t.shape[0]:
                    rec_t = _grow(rec_t, m)
                    rec_y = _grow(rec_y, m)
                    rec_q2 = _grow(rec_q2, m)
                    rec_q3 = _grow(rec_q3, m)
                rec_t[m] = t
                rec_y[m] = ynew
                for i in range(n):
                    rec_q2[m, i] = H21 * k1[i] + H22 * k2[i] + H23 * k3[i] + H24 * k4[i] + H25 * k5[i]
                    rec_q3[m, i] = H31 * k1[i] + H32 * k2[i] + H33 * k3[i] + H34 * k4[i] + H35 * k5[i]
                m += 1
            y[:] = ynew
            jac_fresh = False
            if reject:
                h_new = min(h_new, h_try)
            reject = False
            if hit:
                while i_stop < n_stops and tstops[i_stop] <= t:
                    y_stops[i_stop] = y
                    i_stop += 1
                # a step clipped to land on a stop does not shrink the next one
                h = max(h_new, h)
            else:
                h = h_new
        else:
            n_rej += 1
            h = h_new if not first else 0.1 * h_try
            reject = True
    return status, y_stops, rec_t[:m], rec_y[:m], rec_q2[:m], rec_q3[:m], n_steps, n_rej, n_rhs


def specialize(rhs_func, tag: str, cache: bool = True):
    """A compiled :func:`solve` whose right-hand side is ``rhs_func`` (a numba.njit function).

    ``tag`` names the compiled copy (its on-disk cache entry), e.g. "pump"; a tag must be
    used for one right-hand side only.
    """
    base = solve.py_func
    g = dict(base.__globals__)
    g["rhs"] = rhs_func
    fn = types.FunctionType(base.__code__, g, base.__name__, base.__defaults__, base.__closure__)
    fn.__qualname__ = f"{base.__qualname__}__{tag}"
    fn.__module__ = base.__module__
    fn.__doc__ = base.__doc__
    return numba.njit(cache=cache)(fn)


def interpolate(t, rec_t, rec_y, rec_q2, rec_q3):
    """States at times ``t`` (array, inside the recorded span) from the dense output (numpy)."""
    t = np.asarray(t, dtype=float)
    i = np.clip(np.searchsorted(rec_t, t, side="left"), 1, len(rec_t) - 1)
    h = rec_t[i] - rec_t[i - 1]
    s = ((t - rec_t[i - 1]) / h)[:, None]
    return rec_y[i - 1] * (1 - s) + s * (rec_y[i] + (1 - s) * (rec_q2[i] + s * rec_q3[i]))
