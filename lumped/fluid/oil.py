"""Hydraulic oil: viscosity vs temperature (Appendix A) and the entrained-air density of Cho et al.

Plain float functions (``math`` only) so that ``numba.njit`` can compile the same source
for the fast path. SI units: pressure Pa (absolute), density kg/m^3, temperature K.

Density with entrained air (eq 4.11, Cho et al. 2002), R the volume fraction of air at P0::

    rho / rho0 = 1 / ( R (P0/P)^(1/gamma) + (1 - R) exp(-(P - P0)/beta) )

This is exact (not the R << 1 approximation the thesis calls it) when the air volume of
eq 4.9 is written per unit *mixture* volume; the exponent sign follows eqs 4.9 and 4.12
(eqs 4.10-4.11 print exp(-(P0 - P)/beta); see docs/errata.md).

Inverting eq 4.11 (:func:`pressure_iterations`): f(P) = A P^B + C e^(DP) - E with A = R P0^(1/gamma),
B = -1/gamma, C = (1 - R) e^(P0/beta), D = -1/beta, E = rho0/rho (eqs 4.12-4.14). Both terms are
convex and decreasing in P, so a Newton step from any P > 0 lands left of the root
(f >= 0) and from there Newton's method increases monotonically to it without
overshoot: convergence is guaranteed whatever the start, and a close start only saves
iterations. The start solves a two-term model, the liquid term linear in P:
R (P0/P)^(1/gamma) = k (P - P_lin), k = (1 - R)/beta, whose liquid-only root P_lin is a
lower bound of the true root. Where P_lin > 0 it is P_lin u with (u - 1) u^(1/gamma) = c
= R P0^(1/gamma) / (k P_lin^(1 + 1/gamma)) (the air volume at P_lin against the liquid's
compression), solved as u = 1 + c (1 + c)^(-1/(1 + gamma)), exact for c -> 0 and
c -> infinity and within 9 % between; otherwise (expansion) the air takes up the whole
density change with the liquid frozen at its P0 volume.
With R = 0 the liquid root is exact (and may be negative: no vapour model).

``p_start`` > 0 replaces that start (the root of a nearby call: an integrator evaluates the
cylinder at neighbouring states, so one or two Newton steps remain; the result does not
depend on the start beyond the tolerance, since Newton converges from any P > 0, though
from far left of the root it gains only a factor 1 + gamma per step: 10 Pa to 100 MPa in
about 20 of the 60 allowed).

It stops when the last step, or the error it leaves (quadratic convergence from the
left: below f''(P) step^2 / (2 |f'|), f'' decreasing), is below rtol P + 4e-16 beta:
the liquid term fixes P only to ~ beta * eps in absolute terms (conditioning).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from geometry.declare import param


def viscosity_parameters(nu1: float, t1: float, nu2: float, t2: float, density: float) -> tuple[float, float]:
    """The two constants of the Reynolds viscosity law mu = mu_0 exp(-b T) through two measured points
    (eqs A.1-A.2).

    Parameters
    ----------
    nu1, nu2 : float
        Kinematic viscosities [m^2/s] at the temperatures ``t1``, ``t2`` [K].
    t1, t2 : float
        Their temperatures [K].
    density : float
        Oil density [kg/m^3] turning nu into mu = rho nu.

    Returns
    -------
    tuple of float
        (mu_0 [Pa s], b [1/K]) with b = ln(nu1 / nu2) / (t2 - t1) > 0, as used in eq A.3 (the thesis prints
        b = -0.03157 1/K for the same number with the sign convention of eq A.1).

    References
    ----------
    Knutson (2016), Appendix A, eqs A.1-A.3 and Table A.1.

    Examples
    --------
    Table A.1 (44.2 cSt at 40 C, 6.65 cSt at 100 C, 876 kg/m^3) gives eq A.3's mu = 761.1 exp(-0.03157 T):

    >>> mu0, b = viscosity_parameters(44.2e-6, 313.15, 6.65e-6, 373.15, 876.0)
    >>> round(mu0), round(b, 5)
    (761, 0.03157)
    """
    b = math.log(nu1 / nu2) / (t2 - t1)
    mu0 = density * nu1 * math.exp(b * t1)
    return mu0, b


def viscosity(temperature: float, mu0: float, b: float) -> float:
    """Dynamic viscosity of the oil at a temperature by the Reynolds law mu(T) = mu_0 exp(-b T) (eq A.3).

    Parameters
    ----------
    temperature : float
        T [K].
    mu0, b : float
        The law's constants [Pa s], [1/K] (:func:`viscosity_parameters`).

    Returns
    -------
    float
        mu [Pa s].

    References
    ----------
    Knutson (2016), eq A.3.

    Examples
    --------
    >>> round(viscosity(295.15, 761.1, 0.03157), 4)    # eq A.3 at 22 C; Table 5.1: 0.0683 Pa s
    0.0683
    """
    return mu0 * math.exp(-b * temperature)


def thesis_oil_viscosity(temperature: float | None = None) -> tuple[float, float]:
    """Density and viscosity of the thesis's oil (Mobil DTE 25) at a temperature, from the two Table A.1 points
    (lumped/data/oil.toml) by eqs A.1-A.3: the one place the viscosity law is evaluated for the thesis oil.

    Parameters
    ----------
    temperature : float, optional
        T [K]; None: the room temperature of Appendix A (22 C).

    Returns
    -------
    tuple of float
        (density [kg/m^3], dynamic viscosity [Pa s]).

    References
    ----------
    Knutson (2016), Appendix A; Table 5.1 (0.0683 Pa s).

    Examples
    --------
    >>> rho, mu = thesis_oil_viscosity()
    >>> rho, round(mu, 4)                   # Table 5.1: 876 kg/m^3, 0.0683 Pa s at 22 C
    (876.0, 0.0683)
    """
    from geometry.data_files import package_toml

    v = package_toml("lumped", "oil.toml")["viscosity"]
    mu0, b = viscosity_parameters(v["kinematic_low"], v["temperature_low"], v["kinematic_high"],
                                  v["temperature_high"], v["density"])
    t = v["room_temperature"] if temperature is None else temperature
    return float(v["density"]), viscosity(t, mu0, b)


def density(p: float, rho0: float, p0: float, beta: float, gamma: float, air: float) -> float:
    """Density of oil with entrained air at an absolute pressure (eq 4.11, Cho et al. 2002):
    rho = rho0 / (R (P0/P)^(1/gamma) + (1 - R) exp(-(P - P0)/beta)).

    Parameters
    ----------
    p : float
        Absolute pressure P [Pa]; positive when ``air`` > 0 (the air term diverges at P -> 0).
    rho0 : float
        Density of the mixture at ``p0`` [kg/m^3].
    p0 : float
        Reference pressure P0 where R and rho0 are given [Pa, absolute].
    beta : float
        Bulk modulus of the air-free oil [Pa].
    gamma : float
        Polytropic exponent of the air [-].
    air : float
        R, volume fraction of air at P0 [-].

    Returns
    -------
    float
        rho [kg/m^3].

    References
    ----------
    Knutson (2016), eqs 4.9-4.11 (the exponent's sign as in eqs 4.9, 4.12: docs/errata.md); Cho, Kim & Kim
    (2002).

    Examples
    --------
    Air-free oil follows the bulk modulus; 1.3 % air (Table 5.4) more than doubles the
    compression at 2.76 MPa:

    >>> rho = lambda p, air: density(p, 870.0, 101325.0, 1.5e9, 1.4, air)
    >>> round((rho(2.76e6, 0.0) / rho(101325.0, 0.0) - 1.0) * 1.5e9 / (2.76e6 - 101325.0), 4)   # = 1 to O(dp/beta)
    1.0009
    >>> rho(2.76e6, 0.013) / rho(101325.0, 0.013) - 1.0 > 2 * (rho(2.76e6, 0.0) / rho(101325.0, 0.0) - 1.0)
    True
    """
    liquid = (1.0 - air) * math.exp(-(p - p0) / beta)
    if air > 0.0:
        return rho0 / (air * (p0 / p) ** (1.0 / gamma) + liquid)
    return rho0 / liquid


def density_slope(p: float, rho0: float, p0: float, beta: float, gamma: float, air: float) -> float:
    """The slope d rho/dP of eq 4.11: the mixture's density over its effective bulk modulus.

    Parameters
    ----------
    p, rho0, p0, beta, gamma, air : float
        As :func:`density` (SI).

    Returns
    -------
    float
        d rho/dP [kg/m^3/Pa].

    References
    ----------
    Knutson (2016), eq 4.11 differentiated (the dP/dm of eq 4.16).

    Examples
    --------
    Air-free oil: rho / beta at P0 (Table 5.1: 876 kg/m^3, 1.84 GPa):

    >>> density_slope(101325.0, 876.0, 101325.0, 1.84e9, 1.4, 0.0) == 876.0 / 1.84e9
    True
    """
    liquid = (1.0 - air) * math.exp(-(p - p0) / beta)
    d = liquid
    dd = -liquid / beta
    if air > 0.0:
        a = air * (p0 / p) ** (1.0 / gamma)
        d += a
        dd -= a / (gamma * p)
    return -rho0 * dd / (d * d)


def pressure_iterations(rho: float, rho0: float, p0: float, beta: float, gamma: float, air: float,
                        rtol: float = 1e-13, maxiter: int = 60, p_start: float = 0.0) -> tuple[float, int]:
    """The absolute pressure at which oil with entrained air has density ``rho``: eq 4.11 inverted by Newton's
    method (eqs 4.12-4.16).

    Parameters
    ----------
    rho : float
        Mixture density [kg/m^3].
    rho0, p0, beta, gamma, air : float
        As :func:`density` (SI).
    rtol : float
        Relative tolerance of the root [-].
    maxiter : int
        Newton steps allowed.
    p_start : float
        > 0: the start [Pa] (see below); else the two-term model's root.

    Returns
    -------
    tuple
        (P [Pa], Newton iterations taken); the start and the stopping rule: the module docstring.

    References
    ----------
    Knutson (2016), eqs 4.12-4.16.

    Examples
    --------
    The inverse of :func:`density` (1.3 % air, Table 5.4):

    >>> rho = density(2.76e6, 876.0, 101325.0, 1.84e9, 1.4, 0.013)
    >>> p, n = pressure_iterations(rho, 876.0, 101325.0, 1.84e9, 1.4, 0.013)
    >>> round(p), n <= 5
    (2760000, True)
    """
    e = rho0 / rho
    if air <= 1e-200:
        # air-free (or so little air that the pure-air root underflows): the liquid root, explicit
        return p0 - beta * math.log(e / (1.0 - air)), 0
    inv_g = 1.0 / gamma
    if p_start > 0.0:
        return _newton(p_start, e, p0, beta, inv_g, air, rtol, maxiter)
    # start: the root of the two-term model with the liquid term linear in P,
    # R (P0/P)^(1/gamma) = k (P - P_lin), k = (1 - R)/beta, P_lin its liquid-only root (a
    # lower bound of the true root), i.e. P^(1/gamma) (P - P_lin) = A
    k = (1.0 - air) / beta
    p_lin = p0 - (e - (1.0 - air)) / k
    if p_lin > 0.0:
        # P = P_lin u, (u - 1) u^(1/gamma) = c: u = 1 + c (1 + c)^(-1/(1 + gamma))
        c = air * (p0 / p_lin) ** inv_g / (k * p_lin)
        p = p_lin * (1.0 + c * (1.0 + c) ** (-1.0 / (1.0 + gamma)))
    else:
        # the air takes up the density change, the liquid frozen at its P0 volume
        p = p0 * (air / (e - (1.0 - air))) ** gamma
    if not p > p_lin:       # underflow or rounding: fall back on the lower bound
        p = p_lin if p_lin > 0.0 else p0 * (air / e) ** gamma
    return _newton(p, e, p0, beta, inv_g, air, rtol, maxiter)


def _newton(p: float, e: float, p0: float, beta: float, inv_g: float, air: float, rtol: float,
            maxiter: int) -> tuple[float, int]:
    """(P [Pa], iterations): Newton on f(P) = R (P0/P)^(1/gamma) + (1 - R) e^(-(P - P0)/beta) - e from P
    (see :func:`pressure_iterations`)."""
    ta = air * (p0 / p) ** inv_g
    tl = (1.0 - air) * math.exp(-(p - p0) / beta)
    for it in range(1, maxiter + 1):
        f = ta + tl - e
        df = -ta * inv_g / p - tl / beta
        step = f / df
        p_new = p - step
        if p_new <= 0.0:          # a step from far right of the root: stay positive
            p_new = 0.5 * p
        tol = rtol * p_new + 4.0e-16 * beta
        if abs(p_new - p) <= tol:
            return p_new, it
        if f > 0.0:
            # from the left the error left by this step is at most f''(P) step^2 / (2 |f'(P_new)|)
            d2 = (ta * inv_g * (inv_g + 1.0) / p + tl / (beta * beta) * p) / p
            if d2 * step * step <= tol * (-df + d2 * step):     # step < 0 here: |f'(P_new)| >= -df + d2 step
                return p_new, it
        # both terms at P_new: a short step updates them by their series (error < 1e-19,
        # no pow or exp), a long one evaluates them afresh
        dlt = (p_new - p) / p
        x = (p_new - p) / beta
        if -1e-4 < dlt < 1e-4 and -1e-4 < x < 1e-4:
            n1 = inv_g
            ta *= 1.0 - n1 * dlt * (1.0 - (n1 + 1.0) / 2.0 * dlt * (1.0 - (n1 + 2.0) / 3.0 * dlt
                                                                   * (1.0 - (n1 + 3.0) / 4.0 * dlt)))
            tl *= 1.0 - x * (1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0)))
        else:
            ta = air * (p0 / p_new) ** inv_g
            tl = (1.0 - air) * math.exp(-(p_new - p0) / beta)
        p = p_new
    return p, maxiter


def pressure(rho: float, rho0: float, p0: float, beta: float, gamma: float, air: float,
             p_start: float = 0.0) -> float:
    """Absolute pressure of oil with entrained air at a density: eq 4.11 inverted (eqs 4.12-4.16,
    :func:`pressure_iterations`).

    Parameters
    ----------
    rho : float
        Mixture density [kg/m^3].
    rho0, p0, beta, gamma, air : float
        As :func:`density` (SI).
    p_start : float
        > 0: Newton starts there [Pa].

    Returns
    -------
    float
        P [Pa, absolute].

    References
    ----------
    Knutson (2016), eqs 4.11-4.16.
    """
    return pressure_iterations(rho, rho0, p0, beta, gamma, air, p_start=p_start)[0]


@dataclass(frozen=True)
class Oil:
    """The working fluid: density, compressibility with entrained air (eq 4.11), viscosity.

    Values of the thesis's Mobil DTE 25 are in the shipped model files (Table 5.1,
    Appendix A); ``air_content`` is the parameter of the ``entrained_air`` effect (the
    discrepancy workflow's baseline sets it to 0 unless a run states it).
    """

    density: float = param("density", "kg/m^3", "rho_0 at P_0 (Table 5.1)", bounds=(100.0, 3000.0), positive=True, packed=True,
                           typical=(600.0, 1300.0))
    bulk_modulus: float = param("bulk_modulus", "Pa", "beta of air-free oil at P_0 (Table 5.1)",
                                bounds=(1e6, 1e11), positive=True, packed=True)
    polytropic_exponent: float = param("polytropic_exponent", "-", "gamma of the air in eq 4.9 (Table 5.1: 1.4)",
                                       bounds=(1.0, 1.7), packed=True)
    atmospheric_pressure: float = param("atmospheric_pressure", "Pa", "P_0, where R and rho_0 are given (Table 5.1)",
                                        bounds=(1e4, 2e5), positive=True, packed=True)
    viscosity: float = param("viscosity", "Pa s", "mu at the working temperature (eq A.3)", bounds=(1e-6, 100.0),
                             positive=True, packed=True)
    vapour_pressure: float = param("vapour_pressure", "Pa", "absolute pressure where the oil cavitates (cylinder "
                                   "floor, film limit of eq 2.16)", bounds=(0.0, 1e5), packed=True)
    air_content: float = param("air_content", "-", "R, volume fraction of air at P_0 (eq 4.11)", bounds=(0.0, 0.49),
                               effect="entrained_air", packed=True)

    def density_at(self, p: float) -> float:
        """Mixture density at absolute pressure p [kg/m^3] (eq 4.11)."""
        return density(p, self.density, self.atmospheric_pressure, self.bulk_modulus, self.polytropic_exponent,
                       self.air_content)

    def pressure_at(self, rho: float) -> float:
        """Absolute pressure [Pa] at mixture density rho (eqs 4.12-4.16)."""
        return pressure(rho, self.density, self.atmospheric_pressure, self.bulk_modulus, self.polytropic_exponent,
                        self.air_content)

    def bulk_modulus_at(self, p: float) -> float:
        """Effective bulk modulus of the mixture rho / (d rho/dp) [Pa] at absolute pressure p."""
        return self.density_at(p) / density_slope(p, self.density, self.atmospheric_pressure, self.bulk_modulus,
                                                  self.polytropic_exponent, self.air_content)
