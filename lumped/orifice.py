"""Orifice flow with a Reynolds-dependent discharge coefficient, solved consistently with the flow.

Both valves use the Wu et al. (2002) form (eqs 2.47 and 3.88) in s = sqrt(Re)::

    Cd(s) = Cd_inf + A exp(-B s) - (Cd_inf + A) exp(-C s)

with Re = k |Q_o|, k = 4 rho / (mu p) (eqs 2.46, 3.87) and the orifice equation
Q_o = Cd A_o sqrt(2 |dP| / rho) sign(dP) (eqs 2.38, 3.22). Writing s^2 = k |Q_o| the pair
becomes one scalar equation s^2 = G Cd(s) with G = k A_o sqrt(2 |dP| / rho). Because
Cd ~ alpha s for small s, Q_o -> 2 alpha^2 k A_o^2 dP / rho: the flow is linear (laminar)
in the pressure drop near zero, so the right-hand side stays smooth through dP = 0 with
no hand-made regularisation.

Plain float functions (``math`` only) so that ``numba.njit`` can compile the same source.
"""

from __future__ import annotations

import math


def discharge_coefficient(s: float, cd_inf: float, a: float, b: float, c: float) -> float:
    """Cd at s = sqrt(Re) (eqs 2.47/2.48, 3.88/3.89), with Cd(0) = 0 exactly.

    The last coefficient is -(Cd_inf + A), written with expm1 so that small s loses no
    digits to cancellation (Cd ~ alpha s for tiny flows).
    """
    return a * math.expm1(-b * s) - (cd_inf + a) * math.expm1(-c * s)


def discharge_slope(s: float, cd_inf: float, a: float, b: float, c: float) -> float:
    """dCd/ds at s = sqrt(Re) (dimensionless)."""
    return -a * b * math.exp(-b * s) + (cd_inf + a) * c * math.exp(-c * s)


def laminar_slope(cd_inf: float, a: float, b: float, c: float) -> float:
    """alpha = dCd/ds at s = 0: Cd ~ alpha sqrt(Re) for vanishing flow (must be > 0)."""
    return -a * b + (cd_inf + a) * c


def orifice_flow(area: float, dp: float, rho: float, mu: float, perimeter: float,
                 cd_inf: float, a: float, b: float, c: float) -> tuple[float, float, float, float]:
    """Orifice volume flow with Cd(Re) solved consistently (eqs 2.38 + 2.46-2.48; 3.22 + 3.87-3.89).

    area A_o [m^2] (>= 0), dp = P_up - P_down [Pa], rho [kg/m^3], mu [Pa s], perimeter
    p [m] of the Reynolds number Re = 4 rho |Q| / (mu p). Returns
    (Q [m^3/s], Cd, dQ/d(dp) [m^3/s/Pa], dQ/dA_o [m/s]).

    Solves w(sigma) = 2 sigma - ln Cd(e^sigma) - ln G = 0 for sigma = ln s by Newton's
    method with a bisection safeguard; w is increasing (s^2 / Cd(s) is monotone for the
    correlations of eqs 2.48 and 3.89, checked where the parameters are loaded).
    """
    if area <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    k = 4.0 * rho / (mu * perimeter)
    alpha = laminar_slope(cd_inf, a, b, c)
    adp = abs(dp)
    if adp == 0.0:
        return 0.0, 0.0, 2.0 * alpha * alpha * k * area * area / rho, 0.0
    g = k * area * math.sqrt(2.0 * adp / rho)
    # start from the smaller of the laminar (s = alpha G) and turbulent (s^2 = G Cd_inf) limits
    s_lam = alpha * g
    s_tur = math.sqrt(g * cd_inf)
    sigma = math.log(s_lam if s_lam < s_tur else s_tur)
    lg = math.log(g)
    lo = -1.0e300
    hi = 1.0e300
    s = math.exp(sigma)
    cd = discharge_coefficient(s, cd_inf, a, b, c)
    dw = 1.0
    for _ in range(100):
        w = 2.0 * sigma - math.log(cd) - lg
        if w == 0.0:                     # exact root: it would fail the strict bracket test below
            break
        dw = 2.0 - s * discharge_slope(s, cd_inf, a, b, c) / cd
        if w < 0.0:
            lo = sigma
        else:
            hi = sigma
        step = -w / dw
        if step > 2.0:
            step = 2.0
        elif step < -2.0:
            step = -2.0
        new = sigma + step
        if not (lo < new < hi):          # Newton left the bracket: bisect instead
            if lo > -1.0e299 and hi < 1.0e299:
                new = 0.5 * (lo + hi)
        done = abs(new - sigma) < 1.0e-13
        sigma = new
        s = math.exp(sigma)
        cd = discharge_coefficient(s, cd_inf, a, b, c)
        if done:
            break
    dw = 2.0 - s * discharge_slope(s, cd_inf, a, b, c) / cd
    q_abs = s * s / k
    q = q_abs if dp > 0.0 else -q_abs
    dq_ddp = q_abs / (adp * dw)                 # even in dp: d|Q|/d|dp|
    dq_darea = 2.0 * q / (area * dw)
    return q, cd, dq_ddp, dq_darea
