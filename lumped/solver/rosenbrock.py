"""The Rodas4P and Rodas5P steps: coefficients, one step, the step's dense output, the small dense LU.

Rodas4P (Steinebach 1995; METH = 3 of Hairer & Wanner's code RODAS, *Solving ODEs II*, 2nd ed., section
IV.7) is a 6-stage Rosenbrock method of order 4 with an embedded order-3 error estimate and a 3rd-order
dense output; Rodas5P (Steinebach 2023) has 8 stages, order 5, an embedded order-4 estimate and a 4th-order
dense output. Both are L-stable and stiffly accurate, in the transformed form
W k_i = f(t + c_i h, y + sum a_ij k_j) + sum (C_ij / h) k_j + h d_i f_t with W = I/(h gamma) - J, so each
stage is one solve with one LU factorisation of W and no Newton iteration. Both share one dense-output form,
y0 (1 - s) + s (y1 + (1 - s) (q2 + s (q3 + s q4))), with q4 = 0 for Rodas4P.

The right-hand side is the module-level name ``rhs(t, y, p, dydt)``; :func:`lumped.solver.rodas.specialize`
binds the model's. The linear systems are solved on the first ``n_dyn`` states only: the rest are quadratures
that never feed back (:func:`stage_solve`). Compiled with numba's ``error_model="numpy"`` (a division by zero
gives inf or nan: a non-finite stage, so a rejected step).
"""

from __future__ import annotations

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


class Work(NamedTuple):
    """The scratch of one integration, allocated once (:func:`work`): f(t, y) ``f0``, df/dt ``ft``, the
    Jacobian ``jac`` (n x n), W and its pivots on the first n_dyn block (``w``, ``piv``), the stages ``k``
    (8 x n), the stage input ``u``, the step's result ``ynew`` and dense-output coefficients ``q2``, ``q3``,
    ``q4``, vectors ``yp``, ``fp`` for differencing and interpolating, and the event functions' values at the
    step's start and end ``g0``, ``g1`` (the events, then the state's length of scratch for the model)."""

    f0: np.ndarray
    ft: np.ndarray
    fp: np.ndarray
    yp: np.ndarray
    jac: np.ndarray
    w: np.ndarray
    piv: np.ndarray
    k: np.ndarray
    u: np.ndarray
    ynew: np.ndarray
    q2: np.ndarray
    q3: np.ndarray
    q4: np.ndarray
    g0: np.ndarray
    g1: np.ndarray


@numba.njit(cache=True, error_model="numpy")
def work(n, n_dyn, n_events):
    """The :class:`Work` of an integration of n states (n_dyn feeding back) with n_events switching functions."""
    return Work(np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty((n, n)), np.empty((n_dyn, n_dyn)),
                np.empty(n_dyn, dtype=np.int64), np.empty((8, n)), np.empty(n), np.empty(n), np.empty(n),
                np.empty(n), np.empty(n), np.empty(max(n_events, 1) + n), np.empty(max(n_events, 1) + n))


@numba.njit(cache=True, error_model="numpy")
def rhs(t, y, p, dydt):  # never used: specialize() always binds the model's rhs
    dydt[:] = 0.0


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
def _dense_into(s, y0, y1, q2, q3, q4, out):
    for i in range(y0.shape[0]):
        out[i] = dense(s, y0[i], y1[i], q2[i], q3[i], q4[i])


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
    """One Rodas4P step of size h from (t, y), with f(t, y) ``f0``, df/dt ``ft`` and J ``jac`` (the arrays of
    :class:`Work`): stages in ``k`` (6 x n), the result in ``ynew``.

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
    """One Rodas5P step of size h from (t, y): stages in ``k`` (8 x n), the result in ``ynew``; arguments and
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
