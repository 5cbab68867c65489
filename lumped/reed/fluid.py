"""Fluid quantities of the reed model (thesis sections 3.3, 3.7, 3.8.2.2-3.8.5).

Added mass (hydrodynamic function, eqs 3.11-3.17), viscous fluid damping (kinetic
Reynolds number and c_f, eqs 3.79-3.80), the Poiseuille-regime pressure fractions and
pressure load multiplier (eqs 3.50-3.60, Table 3.12) and the orifice-regime
correlation X(x) (eq 3.83). SI units throughout. Inputs that are not in Table 3.13
(the damping reading of Naik et al., the sealing layout) are in
``lumped/data/reed_fluid.toml``; the oil's viscosity law is :mod:`lumped.fluid.oil`'s.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

from geometry.data_files import package_toml
from geometry.reed import Reed
from lumped.fluid.oil import thesis_oil_viscosity

# -- data files ---------------------------------------------------------------------


@cache
def _data(name: str) -> dict:
    return package_toml("lumped", f"{name}.toml")


def fluid_data() -> dict:
    """The reed's fluid data: the parsed ``lumped/data/reed_fluid.toml``.

    Returns
    -------
    dict
    """
    return _data("reed_fluid")


def oil_properties(temperature: float | None = None) -> tuple[float, float]:
    """Density and viscosity of the thesis oil at a temperature (eqs A.1-A.3,
    :func:`lumped.fluid.oil.thesis_oil_viscosity`: the one viscosity law).

    Parameters
    ----------
    temperature : float, optional
        T [K]; None: 22 C.

    Returns
    -------
    tuple of float
        (rho [kg/m^3], mu [Pa s]).
    """
    return thesis_oil_viscosity(temperature)


# -- added mass (section 3.3) -------------------------------------------------------

#: Pade coefficients of the flexural hydrodynamic function, eq 3.13 (Van Eysden & Sader 2006)
_PADE_NUM = (1.0, 0.74273, 0.14862)
_PADE_DEN = (1.0, 0.74273, 0.35004, 0.058364)


def hydrodynamic_function(kappa_n):
    """The flexural hydrodynamic function Gamma_f of a reed vibrating in a fluid: the Pade approximant of Van Eysden
    & Sader (eq 3.13).

    Parameters
    ----------
    kappa_n : float or array_like
        Normalised mode number [-] (eqs 3.12, 3.14).

    Returns
    -------
    float or numpy.ndarray
        Gamma_f [-].

    References
    ----------
    Knutson (2016), eq 3.13; Van Eysden & Sader (2006).

    Examples
    --------
    >>> round(hydrodynamic_function(0.9677), 4)       # Table 3.13: 0.8850
    0.885
    """
    k = np.asarray(kappa_n, dtype=float)
    num = sum(c * k**i for i, c in enumerate(_PADE_NUM))
    den = sum(c * k**i for i, c in enumerate(_PADE_DEN))
    out = num / den
    return float(out) if out.ndim == 0 else out


def normalised_mode_number(alpha: float, width: float, length: float) -> float:
    """Normalised mode number of a uniform reed, kappa_n = alpha W / L (eq 3.12).

    Parameters
    ----------
    alpha : float
        Frequency parameter [-].
    width : float
        W [m]
    length : float
        L [m].

    Returns
    -------
    float
        kappa_n [-].

    References
    ----------
    Knutson (2016), eq 3.12.
    """
    return alpha * width / length


def normalised_mode_number_area(alpha: float, face_area: float, length: float) -> float:
    """Normalised mode number of a non-uniform reed, kappa_n = alpha A / L^2 with its face area A (eq 3.14).

    Parameters
    ----------
    alpha : float
        Frequency parameter [-].
    face_area : float
        A [m^2].
    length : float
        L [m].

    Returns
    -------
    float
        kappa_n [-].

    References
    ----------
    Knutson (2016), eq 3.14, Table 3.13.
    """
    return alpha * face_area / length**2


def added_mass_per_length(rho: float, width, gamma_f: float):
    """Added fluid mass per unit length of a vibrating strip, m_f = (pi/4) rho W^2 Gamma_f (eq 3.17).

    Parameters
    ----------
    rho : float
        Fluid density [kg/m^3].
    width : float or array_like
        W [m]
    gamma_f : float
        Hydrodynamic function [-].

    Returns
    -------
    float or numpy.ndarray
        m_f [kg/m].

    References
    ----------
    Knutson (2016), eq 3.17.
    """
    return np.pi / 4.0 * rho * np.asarray(width, dtype=float) ** 2 * gamma_f


def added_mass_coefficient(gamma3: float, rho: float, width_tip: float, gamma_f: float) -> float:
    """The added-mass term of the lumped reed equation, gamma3 rho W2 (pi/4) Gamma_f (eq 3.21).

    Parameters
    ----------
    gamma3 : float
        [-].
    rho : float
        Fluid density [kg/m^3].
    width_tip : float
        W2 [m].
    gamma_f : float
        [-].

    Returns
    -------
    float
        [kg/m^2].

    References
    ----------
    Knutson (2016), eq 3.21.
    """
    return gamma3 * rho * width_tip * np.pi / 4.0 * gamma_f


def frequency_in_fluid(omega_vac: float, rho: float, width: float, density_reed: float,
                       thickness: float, gamma_f: float) -> float:
    """Natural frequency of a reed in a fluid, omega_f = omega_vac (1 + pi rho W Gamma_f / (4 rho_c h))^(-1/2) (eq
    3.11).

    Parameters
    ----------
    omega_vac : float
        In vacuum [rad/s].
    rho : float
        Fluid density [kg/m^3].
    width : float
        W [m]
    density_reed : float
        rho_c [kg/m^3].
    thickness : float
        h [m].
    gamma_f : float
        [-].

    Returns
    -------
    float
        omega_f [rad/s].

    References
    ----------
    Knutson (2016), eq 3.11.
    """
    return omega_vac / np.sqrt(1.0 + np.pi * rho * width * gamma_f / (4.0 * density_reed * thickness))


def added_to_reed_mass_ratio(gamma3: float, rho: float, width_tip: float, gamma_f: float,
                             density_reed: float, thickness: float) -> float:
    """The added fluid mass over the reed's mass, gamma3 rho W2 (pi/4) Gamma_f / (rho_c h) (eq 3.76).

    Parameters
    ----------
    gamma3 : float
        [-].
    rho : float
        Fluid density [kg/m^3].
    width_tip : float
        W2 [m].
    gamma_f : float
        [-].
    density_reed : float
        rho_c [kg/m^3].
    thickness : float
        h [m].

    Returns
    -------
    float
        [-].

    References
    ----------
    Knutson (2016), eq 3.76, Table 3.13 (air: 0.0062).
    """
    return added_mass_coefficient(gamma3, rho, width_tip, gamma_f) / (density_reed * thickness)


# -- viscous fluid damping (section 3.8.3) ------------------------------------------


def kinetic_reynolds(rho: float, omega: float, width: float, mu: float) -> float:
    """Kinetic Reynolds number of a strip vibrating in a fluid, R_k = rho omega W^2 / (4 mu) (eq 3.79).

    Parameters
    ----------
    rho : float
        [kg/m^3].
    omega : float
        [rad/s].
    width : float
        W [m]
    mu : float
        [Pa s].

    Returns
    -------
    float
        R_k [-].

    References
    ----------
    Knutson (2016), eq 3.79.

    Examples
    --------
    >>> round(kinetic_reynolds(876.0, 2786.0, 15.875e-3, 0.0683), -1)     # Table 3.13: 2250
    2250.0
    """
    return rho * omega * width**2 / (4.0 * mu)


def damping_per_length(mu: float, cv_over_mu: float | None = None) -> float:
    """Viscous damping per unit length of a strip, R_f = (c_v / mu) mu (section 3.8.3, Naik et al. 2003).

    Parameters
    ----------
    mu : float
        [Pa s].
    cv_over_mu : float, optional
        The non-dimensional damping read from Naik et al.'s curve (Figure 3.22) at the reed's kinetic Reynolds
        number; not in the thesis, so an explicit input (None: the thesis's reading, 500 at R_k = 2250,
        lumped/data/reed_fluid.toml).

    Returns
    -------
    float
        R_f [Pa s].

    References
    ----------
    Knutson (2016), section 3.8.3, Figure 3.22; Naik, Longmire & Mantell (2003).

    Examples
    --------
    >>> damping_per_length(0.0683, 500.0)       # Table 3.13: 34.15 Pa s
    34.15
    """
    c = fluid_data()["damping"]["cv_over_mu"] if cv_over_mu is None else cv_over_mu
    if not c >= 0.0:
        raise ValueError(f"cv_over_mu must be >= 0, got {c}")
    return c * mu


def fluid_damping(s, psi, width, mu: float, cv_over_mu: float | None = None, weights=None) -> float:
    """Viscous fluid damping of the one-mode reed, c_f = (int psi^2 ds / int psi W ds) R_f (eq 3.80).

    Parameters
    ----------
    s : array_like
        Positions [m].
    psi : array_like
        The mode function there [-].
    width : array_like
        W [m]
    mu : float
        [Pa s].
    cv_over_mu : float, optional
        As :func:`damping_per_length`.
    weights : array_like, optional
        Quadrature weights for the samples (None: Simpson's rule).

    Returns
    -------
    float
        c_f [Pa s/m].

    References
    ----------
    Knutson (2016), eq 3.80, Table 3.13 (1650 Pa s/m).
    """
    psi = np.asarray(psi, dtype=float)
    W = np.asarray(width, dtype=float)
    num, den = _integrate(s, psi**2, weights), _integrate(s, psi * W, weights)
    return num / den * damping_per_length(mu, cv_over_mu)


def fluid_displacement_area(s, psi, width, weights=None) -> float:
    """Fluid displacement area of a reed with an unobstructed seat, A_2 = int W psi ds (eq 3.29).

    Parameters
    ----------
    s : array_like
        Positions [m].
    psi : array_like
        [-].
    width : array_like
        W [m]
    weights : array_like, optional
        Quadrature weights (None: Simpson's rule).

    Returns
    -------
    float
        A_2 [m^2].

    References
    ----------
    Knutson (2016), eq 3.29.
    """
    return _integrate(s, np.asarray(psi, float) * np.asarray(width, float), weights)


def _integrate(s, f, weights) -> float:
    if weights is not None:
        return float(np.asarray(weights) @ f)
    from scipy.integrate import simpson

    return float(simpson(f, x=np.asarray(s, dtype=float)))


# -- Poiseuille regime pressure (section 3.7.1) --------------------------------------


def plate_pressure(y, width: float, dp: float, mu: float = 0.0, u: float = 0.0, gap: float = np.inf):
    """Pressure across a sealing strip between parallel plates, d2P/dy2 = 12 mu u / x^3 with P(0) = P_up, P(W) =
    P_down (eq 3.51; u = 0: eq 3.52, mean dp/2, eq 3.53).

    Parameters
    ----------
    y : array_like
        Position across the strip [m].
    width : float
        W [m]
    dp : float
        P_up - P_down [Pa].
    mu : float
        [Pa s].
    u : float
        Normal velocity [m/s].
    gap : float
        x [m].

    Returns
    -------
    numpy.ndarray
        P(y) - P_down [Pa].

    References
    ----------
    Knutson (2016), eqs 3.51-3.53.
    """
    y = np.asarray(y, dtype=float)
    squeeze = 0.0 if u == 0.0 else 6.0 * mu * u / gap**3
    return (dp - squeeze * width * y) * (1.0 - y / width)


def side_pressure_fraction() -> float:
    """F2, the mean pressure over a straight sealing land as a fraction of the pressure difference: 1/2 (eqs
    3.52-3.53, 3.58).

    Returns
    -------
    float
        F2 = 0.5 [-].

    References
    ----------
    Knutson (2016), eq 3.58.
    """
    return 0.5  # the mean of the linear profile (1 - y / W) over 0 <= y <= W


def annulus_pressure(r, r_inner: float, r_outer: float, dp: float, mu: float = 0.0,
                     u: float = 0.0, gap: float = np.inf):
    """Pressure across an annular sealing land R_i <= r <= R_o, d/dr(r x^3 dP/dr) = 12 mu r u with P(R_i) = P_up,
    P(R_o) = P_down (eqs 3.54-3.56).

    Parameters
    ----------
    r : array_like
        Radius [m].
    r_inner, r_outer : float
        R_i, R_o [m].
    dp : float
        [Pa].
    mu : float
        [Pa s].
    u : float
        [m/s].
    gap : float
        [m].

    Returns
    -------
    numpy.ndarray
        P(r) - P_down [Pa].

    Notes
    -----
    The printed eq 3.55 has R_i and R_o where R_i^2 and R_o^2 belong (docs/errata.md); with u = 0 it is eq 3.56.

    References
    ----------
    Knutson (2016), eqs 3.54-3.56.
    """
    r = np.asarray(r, dtype=float)
    k = 0.0 if u == 0.0 else 3.0 * mu * u / gap**3
    lnio = np.log(r_outer / r_inner)
    squeeze = k * (r**2 * np.log(r_inner / r_outer) + r_inner**2 * np.log(r_outer / r)
                   + r_outer**2 * np.log(r / r_inner))
    return (dp * np.log(r_outer / r) - squeeze) / lnio


def annulus_pressure_fraction(r_inner: float, r_outer: float) -> float:
    """F3, the mean pressure over an annular land as a fraction of the pressure difference, 1 / (2 ln(R_o/R_i)) - 1
    / ((R_o/R_i)^2 - 1) (eqs 3.57, 3.59).

    Parameters
    ----------
    r_inner, r_outer : float
        R_i, R_o [m].

    Returns
    -------
    float
        F3 [-].

    References
    ----------
    Knutson (2016), eqs 3.57, 3.59, Table 3.12.

    Examples
    --------
    >>> round(float(annulus_pressure_fraction(6.35e-3, 7.94e-3)), 3)      # Table 3.12: 0.463
    0.463
    """
    q = r_outer / r_inner
    return 1.0 / (2.0 * np.log(q)) - 1.0 / (q**2 - 1.0)


@dataclass(frozen=True)
class SealingLayout:
    """The four pressure sections of Figure 3.14 (reconstruction, lumped/data/reed_fluid.toml).

    Section 1: the face inside the sealing land, open to upstream pressure (F1 = 1);
    section 2: the land of width ``land_width`` [m] along the straight sides (F2 = 1/2);
    section 3: the land around the rounded tip, an annulus R_o = tip radius,
    R_i = R_o - land (F3 of eq 3.59); section 4: the base, full width from the clamp
    to ``base_length`` [m], with an unknown F4.
    """

    land_width: float
    base_length: float

    def __post_init__(self):
        if not (self.land_width >= 0.0 and self.base_length >= 0.0):
            raise ValueError(f"land_width and base_length must be >= 0, got {self.land_width}, {self.base_length}")

    @classmethod
    def thesis(cls) -> "SealingLayout":
        d = fluid_data()["sealing"]
        return cls(land_width=d["land_width"], base_length=d["base_length"])

    def breaks(self, reed: Reed) -> np.ndarray:
        """s [m] where the F-weighted width changes form."""
        L, R, lw = reed.length, reed.tip_radius, self.land_width
        pts = [0.0, L, self.base_length, reed.step_location, reed.tip_start, L - lw]
        if R > lw:
            pts.append(reed.tip_start + R - lw)
        return np.clip(np.array(pts), 0.0, L)

    def weighted_width(self, reed: Reed, s, F4: float) -> np.ndarray:
        """int F(s, y) dy across the face at s [m]: the width weighted by the pressure fraction."""
        s = np.asarray(s, dtype=float)
        lw, L, R = self.land_width, reed.length, reed.tip_radius
        W = np.asarray(reed.width(s), dtype=float)
        F2 = side_pressure_fraction()
        # straight part: open centre, a land on each side; the end land of a square tip
        centre = np.maximum(W - 2 * lw, 0.0)
        fw = np.where(s > L - lw, W * F2, centre + (W - centre) * F2)
        if R > 0.0:
            d = np.clip(s - reed.tip_start, 0.0, R)
            flat = reed.width_tip - 2 * R  # straight middle part of the tip
            a_out = np.sqrt(np.maximum(R**2 - d**2, 0.0))
            if lw == 0.0:  # no land: the whole tip is open
                F3, a_in = 1.0, a_out
            elif R > lw:
                F3 = annulus_pressure_fraction(R - lw, R)
                a_in = np.sqrt(np.maximum((R - lw) ** 2 - d**2, 0.0))
            else:  # a land wider than the rounding: treat it as straight
                F3, a_in = F2, 0.0 * d
            tip = 2 * a_in + 2 * (a_out - a_in) * F3 + flat * np.where(s > L - lw, F2, 1.0)
            fw = np.where(s > reed.tip_start, tip, fw)
        return np.where(s < self.base_length, F4 * W, fw)


def poiseuille_multiplier(reed: Reed, psi, F4: float, layout: SealingLayout | None = None,
                          nodes: int = 48) -> float:
    """The pressure load multiplier X of the Poiseuille regime, X = iint psi F dA / int psi W ds (eq 3.60).

    Parameters
    ----------
    reed : geometry.Reed
        The reed.
    psi : callable
        psi(s) [-] (s in m), the mode function normalised at the tip.
    F4 : float
        The pressure fraction of the base section [-] (Table 3.12 varies it over 0..1).
    layout : SealingLayout, optional
        The four pressure sections (None: the thesis's).
    nodes : int
        Chebyshev nodes per piece.

    Returns
    -------
    float
        X [-].

    References
    ----------
    Knutson (2016), eqs 3.58-3.60, Table 3.12.
    """
    from .quadrature import ProfileQuadrature

    lay = SealingLayout.thesis() if layout is None else layout
    q = ProfileQuadrature(lay.breaks(reed), nodes)
    p = np.asarray(psi(q.s), dtype=float)
    return q.integral(p * lay.weighted_width(reed, q.s, F4)) / q.integral(p * reed.width(q.s))


def orifice_reynolds(flow, rho: float, perimeter: float, mu: float):
    """Reynolds number of the reed's orifice flow, Re = rho V D_H / mu = 4 rho Q_o / (p_o mu) (eqs 3.85-3.87; A_o
    cancels).

    Parameters
    ----------
    flow : float or array_like
        Q_o [m^3/s].
    rho : float
        [kg/m^3].
    perimeter : float
        p_o [m].
    mu : float
        [Pa s].

    Returns
    -------
    float or numpy.ndarray
        Re [-].

    Notes
    -----
    For the prototype (p_o = 91.2 mm) the coefficient is 5.625e5 s/m^3; eq 3.87 prints its reciprocal 1.778e-6
    (docs/errata.md).

    References
    ----------
    Knutson (2016), eqs 3.85-3.87.

    Examples
    --------
    >>> round(float(orifice_reynolds(1.0, 876.0, 91.2e-3, 0.0683)) / 1e5, 3)     # 1 / 1.778e-6 s/m^3
    5.625
    """
    return 4.0 * rho * np.asarray(flow, dtype=float) / (perimeter * mu)


# -- orifice regime (section 3.8.5) --------------------------------------------------


@dataclass(frozen=True)
class PressureMultiplierFit:
    """Coefficients of eq 3.83, X = (n1 x + n0) / (x^3 + d2 x^2 + d1 x + d0), x in m; Poiseuille plateau."""

    poiseuille: float
    n1: float
    n0: float
    d2: float
    d1: float
    d0: float

    @classmethod
    def thesis(cls) -> "PressureMultiplierFit":
        """The prototype's fit, as the shipped model file gives it (``[valves] pressure_multiplier.*`` of
        lumped/data/models/thesis-reed.toml; read as data: the reed's physics sits below the model layer)."""
        m = _data("models/thesis-reed")["valves"]["pressure_multiplier"]
        return cls(m["poiseuille"], m["n1"], m["n0"], m["d2"], m["d1"], m["d0"])

    def rational(self, x):
        x = np.asarray(x, dtype=float)
        return (self.n1 * x + self.n0) / (x**3 + self.d2 * x**2 + self.d1 * x + self.d0)

    @property
    def closing_opening(self) -> float:
        """x [m] where the rational fit first reaches 0 (numerator root, before the pole): X = 0 beyond."""
        roots = [-self.n0 / self.n1] if self.n1 != 0.0 else []
        roots += [r.real for r in np.roots([1.0, self.d2, self.d1, self.d0]) if abs(r.imag) < 1e-12]
        pos = [r for r in roots if r > 0.0]
        return min(pos) if pos else np.inf


def orifice_multiplier(x, fit: PressureMultiplierFit | None = None):
    """The pressure load multiplier X of the orifice regime at a tip opening: eq 3.83 capped where it first reaches
    0.

    Parameters
    ----------
    x : float or array_like
        Tip opening [m].
    fit : PressureMultiplierFit, optional
        The fit (None: the prototype's).

    Returns
    -------
    float or numpy.ndarray
        X [-].

    Notes
    -----
    X = max(0, min(X_Poiseuille, rational(x))) for x below the fit's first zero (1.369 mm for the prototype) and
    0 above it: the printed correlation has a pole at 1.651 mm and climbs back to 0.835 beyond it (docs/errata.md).

    References
    ----------
    Knutson (2016), eq 3.83, Figure 3.24.
    """
    f = PressureMultiplierFit.thesis() if fit is None else fit
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        X = np.clip(f.rational(x), 0.0, f.poiseuille)
    X = np.where(x >= f.closing_opening, 0.0, X)
    return float(X) if X.ndim == 0 else X
