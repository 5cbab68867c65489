"""Hydraulic oil: viscosity vs temperature (Appendix A) and the entrained-air density of Cho et al.

Plain float functions (``math`` only) so that ``numba.njit`` can compile the same source
for the fast path. SI units: pressure Pa (absolute), density kg/m^3, temperature K.

Density with entrained air (eq 4.11, Cho et al. 2002), R the volume fraction of air at P0::

    rho / rho0 = 1 / ( R (P0/P)^(1/gamma) + (1 - R) exp(-(P - P0)/beta) )

This is exact (not the R << 1 approximation the thesis calls it) when the air volume of
eq 4.9 is written per unit *mixture* volume; the exponent sign follows eqs 4.9 and 4.12
(eqs 4.10-4.11 print exp(-(P0 - P)/beta); see docs/errata.md).
"""

from __future__ import annotations

import math


def viscosity_parameters(nu1: float, t1: float, nu2: float, t2: float, density: float) -> tuple[float, float]:
    """(mu_0 [Pa s], b [1/K]) of mu = mu_0 exp(-b T) from two kinematic viscosities (eqs A.1-A.2).

    Returns b > 0 as used in eq A.3 (mu = 761.1 exp(-0.03157 T)); the thesis prints
    b = -0.03157 1/K for the same number with the sign convention of eq A.1.
    """
    b = math.log(nu1 / nu2) / (t2 - t1)
    mu0 = density * nu1 * math.exp(b * t1)
    return mu0, b


def viscosity(temperature: float, mu0: float, b: float) -> float:
    """Dynamic viscosity mu(T) = mu_0 exp(-b T) [Pa s], T in K (eq A.3)."""
    return mu0 * math.exp(-b * temperature)


def density(p: float, rho0: float, p0: float, beta: float, gamma: float, air: float) -> float:
    """Density of oil with entrained air at absolute pressure p [kg/m^3] (eq 4.11).

    For air > 0 the pressure must be positive (the air term diverges at p -> 0).
    """
    liquid = (1.0 - air) * math.exp(-(p - p0) / beta)
    if air > 0.0:
        return rho0 / (air * (p0 / p) ** (1.0 / gamma) + liquid)
    return rho0 / liquid


def density_slope(p: float, rho0: float, p0: float, beta: float, gamma: float, air: float) -> float:
    """d rho / d p [kg/m^3/Pa] of eq 4.11 (the mixture's rho / effective bulk modulus)."""
    liquid = (1.0 - air) * math.exp(-(p - p0) / beta)
    d = liquid
    dd = -liquid / beta
    if air > 0.0:
        a = air * (p0 / p) ** (1.0 / gamma)
        d += a
        dd -= a / (gamma * p)
    return -rho0 * dd / (d * d)


def pressure_iterations(rho: float, rho0: float, p0: float, beta: float, gamma: float, air: float,
                        rtol: float = 1e-13, maxiter: int = 60) -> tuple[float, int]:
    """(p [Pa], Newton iterations) solving eq 4.11 for pressure (eqs 4.12-4.16).

    f(P) = A P^B + C e^(DP) - E with A = R P0^(1/gamma), B = -1/gamma,
    C = (1 - R) e^(P0/beta), D = -1/beta, E = rho0/rho (eqs 4.12-4.14). Both terms are
    convex and decreasing in P, so Newton's method started left of the root (f > 0)
    increases monotonically to it without overshoot. Each term alone gives such a
    start: the pure-liquid root P_l and the pure-air root P_a both lie below the root
    (the other term is positive there), so max(P_l, P_a) is a safe, close start.
    With R = 0 the liquid root is exact (and may be negative: no vapour model).
    """
    e = rho0 / rho
    # pure-liquid root: (1 - R) exp(-(P - P0)/beta) = E
    p_liq = p0 - beta * math.log(e / (1.0 - air))
    if air <= 1e-200:
        # air-free (or so little air that the pure-air root underflows): explicit
        return p_liq, 0
    inv_g = 1.0 / gamma
    # pure-air root: R (P0/P)^(1/gamma) = E; both single-term roots are lower bounds
    p_air = p0 * (air / e) ** gamma
    p_lo = p_liq if p_liq > p_air else p_air
    p = p_lo
    if e > 1.0 - air:
        # air root with the liquid term frozen at its P0 value: close to the root while
        # P << beta (a lower bound below P0, an upper bound above it)
        p2 = p0 * (air / (e - (1.0 - air))) ** gamma
        if p2 <= 0.0:
            p2 = p
        ta = air * (p0 / p2) ** inv_g
        tl = (1.0 - air) * math.exp(-(p2 - p0) / beta)
        f = ta + tl - e
        if f < 0.0:   # right of the root: one Newton step lands left of it (convexity)
            p2 = p2 - f / (-ta * inv_g / p2 - tl / beta)
        if p2 > p:
            p = p2
    for it in range(1, maxiter + 1):
        ta = air * (p0 / p) ** inv_g
        tl = (1.0 - air) * math.exp(-(p - p0) / beta)
        f = ta + tl - e
        df = -ta * inv_g / p - tl / beta
        step = f / df
        p_new = p - step
        if p_new <= 0.0:          # round-off right of the root near P -> 0: stay positive
            p_new = 0.5 * p
        # the liquid term fixes P only to ~ beta * eps in absolute terms (conditioning)
        if abs(p_new - p) <= rtol * p_new + 4.0e-16 * beta:
            return p_new, it
        p = p_new
    return p, maxiter


def pressure(rho: float, rho0: float, p0: float, beta: float, gamma: float, air: float) -> float:
    """Absolute pressure [Pa] of oil with entrained air at density rho (inverse of eq 4.11)."""
    return pressure_iterations(rho, rho0, p0, beta, gamma, air)[0]
