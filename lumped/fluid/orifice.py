"""Orifice flow with a Reynolds-dependent discharge coefficient, solved consistently with the flow.

Both valves use the Wu et al. (2002) form (eqs 2.47 and 3.88) in s = sqrt(Re)::

    Cd(s) = Cd_inf + A exp(-B s) - (Cd_inf + A) exp(-C s)

with Re = k |Q_o|, k = 4 rho / (mu p) (eqs 2.46, 3.87) and the orifice equation
Q_o = Cd A_o sqrt(2 |dP| / rho) sign(dP) (eqs 2.38, 3.22). Writing s^2 = k |Q_o| the pair
becomes one scalar equation s^2 = G Cd(s) with G = k A_o sqrt(2 |dP| / rho). Because
Cd ~ alpha s for small s, Q_o -> 2 alpha^2 k A_o^2 dP / rho: the flow is linear (laminar)
in the pressure drop near zero, so the right-hand side stays smooth through dP = 0 with
no hand-made regularisation.

Plain float functions (``math``, and numpy ufuncs numba knows) so that ``numba.njit`` can
compile the same source.
"""

from __future__ import annotations

import math

import numpy as np

#: Halley steps below this (in ln s) leave an error ~ step^3 << 1e-13: the solve stops there
FINAL_STEP = 1.0e-5


def discharge_coefficient(s, cd_inf: float, a: float, b: float, c: float):
    """Discharge coefficient of the Wu et al. (2002) correlation at s = sqrt(Re):
    Cd(s) = Cd_inf + A exp(-B s) - (Cd_inf + A) exp(-C s), with Cd(0) = 0 exactly (eqs 2.47-2.48, 3.88-3.89).

    The last coefficient is -(Cd_inf + A), written with expm1 so that small s loses no digits to cancellation
    (Cd ~ alpha s for tiny flows).

    Parameters
    ----------
    s : float or numpy.ndarray
        sqrt(Re) [-] (an array: the parameter check evaluates a whole curve at once).
    cd_inf, a, b, c : float
        The correlation's Cd_inf, A, B, C [-].

    Returns
    -------
    float or numpy.ndarray
        Cd [-].

    References
    ----------
    Knutson (2016), eqs 2.47-2.48 (disc), 3.88-3.89 (reed); Wu, Burton, Schoenau & Bitner (2002).

    Examples
    --------
    Eq 2.48's fit reaches its asymptote 0.972 at high Re and is 0 at rest:

    >>> cd = lambda s: discharge_coefficient(s, 0.9720, -1.0801, 0.1058, 0.9505)
    >>> round(float(cd(1e3)), 4), float(cd(0.0))
    (0.972, 0.0)
    """
    return a * np.expm1(-b * s) - (cd_inf + a) * np.expm1(-c * s)


def discharge_slope(s: float, cd_inf: float, a: float, b: float, c: float) -> float:
    """Slope dCd/ds of :func:`discharge_coefficient` at s = sqrt(Re) (eq 2.47 differentiated).

    Parameters
    ----------
    s : float
        sqrt(Re) [-].
    cd_inf, a, b, c : float
        The correlation's constants [-].

    Returns
    -------
    float
        dCd/ds [-].
    """
    return -a * b * math.exp(-b * s) + (cd_inf + a) * c * math.exp(-c * s)


def laminar_slope(cd_inf: float, a: float, b: float, c: float) -> float:
    """The laminar slope alpha = dCd/ds at s = 0 of eq 2.47: Cd ~ alpha sqrt(Re) for a vanishing flow, so that
    the flow is linear in the pressure drop there (must be > 0).

    Parameters
    ----------
    cd_inf, a, b, c : float
        The correlation's constants [-].

    Returns
    -------
    float
        alpha = -A B + (Cd_inf + A) C [-].

    Examples
    --------
    >>> round(laminar_slope(0.9720, -1.0801, 0.1058, 0.9505), 5)      # eq 2.48's fit
    0.01153
    """
    return -a * b + (cd_inf + a) * c


def orifice_flow(area: float, dp: float, rho: float, mu: float, perimeter: float,
                 cd_inf: float, a: float, b: float, c: float, s_start: float = 0.0) -> tuple[float, float, float, float]:
    """Orifice volume flow Q_o = Cd A_o sqrt(2 |dP| / rho) sign(dP) with Cd(Re) of the same flow, solved
    consistently (eqs 2.38 + 2.46-2.48; 3.22 + 3.87-3.89).

    Parameters
    ----------
    area : float
        Orifice area A_o [m^2] (>= 0).
    dp : float
        P_up - P_down [Pa].
    rho, mu : float
        Density [kg/m^3] and viscosity [Pa s].
    perimeter : float
        p [m] of the Reynolds number Re = 4 rho |Q| / (mu p) (eqs 2.46, 3.87).
    cd_inf, a, b, c : float
        The Cd(Re) correlation (:func:`discharge_coefficient`).
    s_start : float
        > 0: sqrt(Re) to start the iteration from (see below).

    Returns
    -------
    tuple of float
        (Q [m^3/s], Cd [-], dQ/d(dp) [m^3/s/Pa], dQ/dA_o [m/s]).

    Notes
    -----
    Solves w(sigma) = 2 sigma - ln Cd(e^sigma) - ln G = 0 for sigma = ln s, w increasing
    (s^2 / Cd(s) is monotone for the correlations of eqs 2.48 and 3.89, checked where the
    parameters are loaded), by Halley's method (cubic; w'' costs no extra exponential: Cd,
    Cd' and Cd'' share exp(-B s) and exp(-C s)) inside a shrinking bracket (bisection in
    sigma when a step leaves it). It stops after a step below FINAL_STEP, whose error is
    ~ step^3 < 1e-14; Cd and w' at that last point come from the Taylor series of the
    evaluated ones (error ~ step^3 as well), so the last step costs no exponential.
    ``s_start`` > 0: start the iteration there (the root of a nearby call: the pump's
    integrator evaluates the same valve at neighbouring states; the result does not depend
    on the start beyond round-off).

    References
    ----------
    Knutson (2016), eqs 2.38, 2.46-2.48, 3.22, 3.86-3.89; Wu et al. (2002).

    Examples
    --------
    The thesis disc 0.5 mm open under 0.1 MPa (eq 2.40 area, twice the port's perimeter): the solved Cd
    satisfies the orifice equation with the flow's own Reynolds number:

    >>> import math
    >>> area, per = math.pi * 10.48e-3 * math.sin(math.radians(54.0)) * 0.5e-3, 2 * math.pi * 10.48e-3
    >>> q, cd, _, _ = orifice_flow(area, 1e5, 876.0, 0.0683, per, 0.9720, -1.0801, 0.1058, 0.9505)
    >>> re = 4 * 876.0 * q / (0.0683 * per)
    >>> bool(abs(cd - discharge_coefficient(math.sqrt(re), 0.9720, -1.0801, 0.1058, 0.9505)) < 1e-12)
    True
    >>> abs(q - cd * area * math.sqrt(2 * 1e5 / 876.0)) < 1e-15
    True
    """
    if area <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    k = 4.0 * rho / (mu * perimeter)
    ca = cd_inf + a
    alpha = -a * b + ca * c                # laminar_slope, inlined (one compiled function)
    adp = abs(dp)
    if adp == 0.0:
        return 0.0, 0.0, 2.0 * alpha * alpha * k * area * area / rho, 0.0
    g = k * area * math.sqrt(2.0 * adp / rho)
    # start from the smaller of the laminar (s = alpha G) and turbulent (s^2 = G Cd_inf) limits
    s_lam = alpha * g
    s_tur = math.sqrt(g * cd_inf)
    s = s_lam if s_lam < s_tur else s_tur
    if s_start > 0.0 and 0.5 * s < s_start < 2.0 * s_tur:
        s = s_start
    lo = 0.0                                # bracket of the root in s (0, inf: not yet known)
    hi = math.inf
    cd = 0.0
    w1 = 1.0
    for _ in range(100):
        # the only two exponentials; expm1 where Cd would lose digits to cancellation (small s,
        # Cd ~ alpha s), exp (cheaper) where it loses at most about a factor 100 of 1e-16
        if s < 1.0:
            mb = math.expm1(-b * s)
            mc = math.expm1(-c * s)
            cd = a * mb - ca * mc                             # discharge_coefficient
            eb = 1.0 + mb
            ec = 1.0 + mc
        else:
            eb = math.exp(-b * s)
            ec = math.exp(-c * s)
            cd = cd_inf + a * eb - ca * ec
        d1 = -a * b * eb + ca * c * ec                        # Cd' (discharge_slope)
        d2 = a * b * b * eb - ca * c * c * ec                 # Cd''
        s_cd = s / cd
        q = (s / g) * s_cd
        x = q - 1.0
        if -1e-3 < x < 1e-3:      # near the root: ln(1 + x) by its series (error < x^6/6)
            w = x * (1.0 - x * (0.5 - x * (1.0 / 3.0 - x * (0.25 - x * 0.2))))
        else:
            w = math.log(q)                                   # 2 sigma - ln Cd - ln G
        r1 = s_cd * d1
        w1 = 2.0 - r1                                         # dw/dsigma
        if w == 0.0:                                          # exact root
            break
        if w < 0.0:
            lo = s
        else:
            hi = s
        w2 = -(r1 + s * s_cd * d2 - r1 * r1)                  # d2w/dsigma2
        newton = -w / w1
        den = w1 + 0.5 * w2 * newton
        step = -w / den if den > 0.5 * w1 else newton         # Halley, Newton if it would blow up
        if step > 2.0:
            step = 2.0
        elif step < -2.0:
            step = -2.0
        if abs(step) < FINAL_STEP:
            # last step: Cd, Cd' at s e^step by Taylor (no exponential), error ~ step^3
            x = step
            ex = x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0))))   # e^x - 1
            ds = s * ex
            d3 = -a * b * b * b * eb + ca * c * c * c * ec    # Cd'''
            s = s + ds
            cd = cd + ds * (d1 + ds * (0.5 * d2 + ds * d3 / 6.0))
            d1 = d1 + ds * (d2 + 0.5 * ds * d3)
            w1 = 2.0 - s * d1 / cd
            break
        if abs(step) < 0.25:       # an iterate, not the result: a short series for e^step will do
            new = s * (1.0 + step * (1.0 + step * (0.5 + step * (1.0 / 6.0 + step * (1.0 / 24.0 + step / 120.0)))))
        else:
            new = s * math.exp(step)
        if not (lo < new < hi) and lo > 0.0 and hi < math.inf:
            new = math.sqrt(lo * hi)                          # bisection in sigma = ln s
        s = new
    q_abs = s * s / k
    q = q_abs if dp > 0.0 else -q_abs
    dq_ddp = q_abs / (adp * w1)                 # even in dp: d|Q|/d|dp|
    dq_darea = 2.0 * q / (area * w1)
    return q, cd, dq_ddp, dq_darea
