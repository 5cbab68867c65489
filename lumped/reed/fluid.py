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
    """The parsed ``lumped/data/reed_fluid.toml``."""
    return _data("reed_fluid")


def oil_properties(temperature: float | None = None) -> tuple[float, float]:
    """Oil density [kg/m^3] and dynamic viscosity [Pa s] at ``temperature`` [K] (eqs A.1-A.3):
    :func:`lumped.fluid.oil.thesis_oil_viscosity` (the one viscosity law)."""
    return thesis_oil_viscosity(temperature)


# -- added mass (section 3.3) -------------------------------------------------------

#: Pade coefficients of the flexural hydrodynamic function, eq 3.13 (Van Eysden & Sader 2006)
_PADE_NUM = (1.0, 0.74273, 0.14862)
_PADE_DEN = (1.0, 0.74273, 0.35004, 0.058364)


def hydrodynamic_function(kappa_n):
    """Gamma_f(kappa_n), dimensionless: Pade approximant of the flexural hydrodynamic function (eq 3.13)."""
    k = np.asarray(kappa_n, dtype=float)
    num = sum(c * k**i for i, c in enumerate(_PADE_NUM))
    den = sum(c * k**i for i, c in enumerate(_PADE_DEN))
    out = num / den
    return float(out) if out.ndim == 0 else out


def normalised_mode_number(alpha: float, width: float, length: float) -> float:
    """kappa_n = alpha W / L, dimensionless, of a uniform reed (eq 3.12)."""
    return alpha * width / length


def normalised_mode_number_area(alpha: float, face_area: float, length: float) -> float:
    """kappa_n = alpha A / L^2, dimensionless, with the face area A [m^2] of a non-uniform reed (eq 3.14)."""
    return alpha * face_area / length**2


def added_mass_per_length(rho: float, width, gamma_f: float):
    """m_f = (pi / 4) rho W^2 Gamma_f [kg/m], added fluid mass per unit length (eq 3.17)."""
    return np.pi / 4.0 * rho * np.asarray(width, dtype=float) ** 2 * gamma_f


def added_mass_coefficient(gamma3: float, rho: float, width_tip: float, gamma_f: float) -> float:
    """gamma3 rho W2 (pi / 4) Gamma_f [kg/m^2]: the added-mass term of the lumped equation (eq 3.21)."""
    return gamma3 * rho * width_tip * np.pi / 4.0 * gamma_f


def frequency_in_fluid(omega_vac: float, rho: float, width: float, density_reed: float,
                       thickness: float, gamma_f: float) -> float:
    """omega_f = omega_vac (1 + pi rho W Gamma_f / (4 rho_c h))^(-1/2) [rad/s] (eq 3.11)."""
    return omega_vac / np.sqrt(1.0 + np.pi * rho * width * gamma_f / (4.0 * density_reed * thickness))


def added_to_reed_mass_ratio(gamma3: float, rho: float, width_tip: float, gamma_f: float,
                             density_reed: float, thickness: float) -> float:
    """gamma3 rho W2 (pi/4) Gamma_f / (rho_c h), dimensionless: added over reed mass (eq 3.76)."""
    return added_mass_coefficient(gamma3, rho, width_tip, gamma_f) / (density_reed * thickness)


# -- viscous fluid damping (section 3.8.3) ------------------------------------------


def kinetic_reynolds(rho: float, omega: float, width: float, mu: float) -> float:
    """R_k = rho omega W^2 / (4 mu), dimensionless kinetic Reynolds number (eq 3.79)."""
    return rho * omega * width**2 / (4.0 * mu)


def damping_per_length(mu: float, cv_over_mu: float | None = None) -> float:
    """R_f = (c_v / mu) mu [Pa s]: viscous damping per unit length (section 3.8.3, Naik et al. 2003).

    ``cv_over_mu`` is the non-dimensional damping read from Naik et al.'s curve (Figure
    3.22) at the reed's kinetic Reynolds number; the curve is not in the thesis, so it is
    an explicit input. Default: the thesis's reading, 500 at R_k = 2250
    (``lumped/data/reed_fluid.toml``).
    """
    c = fluid_data()["damping"]["cv_over_mu"] if cv_over_mu is None else cv_over_mu
    if not c >= 0.0:
        raise ValueError(f"cv_over_mu must be >= 0, got {c}")
    return c * mu


def fluid_damping(s, psi, width, mu: float, cv_over_mu: float | None = None, weights=None) -> float:
    """c_f = (int psi^2 ds / int psi W ds) R_f [Pa s/m], viscous fluid damping (eq 3.80).

    ``s`` [m], ``psi`` and ``width`` [m] sampled along the reed; ``weights`` (quadrature
    weights for those samples) replace Simpson's rule when given. R_f from
    :func:`damping_per_length`.
    """
    psi = np.asarray(psi, dtype=float)
    W = np.asarray(width, dtype=float)
    num, den = _integrate(s, psi**2, weights), _integrate(s, psi * W, weights)
    return num / den * damping_per_length(mu, cv_over_mu)


def fluid_displacement_area(s, psi, width, weights=None) -> float:
    """A_2 = int W psi ds [m^2], fluid displacement area with an unobstructed seat (eq 3.29)."""
    return _integrate(s, np.asarray(psi, float) * np.asarray(width, float), weights)


def _integrate(s, f, weights) -> float:
    if weights is not None:
        return float(np.asarray(weights) @ f)
    from scipy.integrate import simpson

    return float(simpson(f, x=np.asarray(s, dtype=float)))


# -- Poiseuille regime pressure (section 3.7.1) --------------------------------------


def plate_pressure(y, width: float, dp: float, mu: float = 0.0, u: float = 0.0, gap: float = np.inf):
    """Delta P(y) [Pa] across a sealing strip of width W between parallel plates (eq 3.51).

    Solves d2P/dy2 = 12 mu u / x^3 with P(0) = P_up, P(W) = P_down; ``u`` [m/s] the normal
    velocity, ``gap`` x [m]. With u = 0 it is eq 3.52, whose mean is dp / 2 (eq 3.53).
    """
    y = np.asarray(y, dtype=float)
    squeeze = 0.0 if u == 0.0 else 6.0 * mu * u / gap**3
    return (dp - squeeze * width * y) * (1.0 - y / width)


def side_pressure_fraction() -> float:
    """F2 = mean Delta P / Delta P_u-d = 1/2 over a straight sealing land (eqs 3.52-3.53, 3.58)."""
    return 0.5  # the mean of the linear profile (1 - y / W) over 0 <= y <= W


def annulus_pressure(r, r_inner: float, r_outer: float, dp: float, mu: float = 0.0,
                     u: float = 0.0, gap: float = np.inf):
    """Delta P(r) [Pa] across an annular land R_i <= r <= R_o (eq 3.55, with R_i^2 and R_o^2).

    Solves d/dr(r x^3 dP/dr) = 12 mu r u (eq 3.54) with P(R_i) = P_up, P(R_o) = P_down.
    The printed eq 3.55 has R_i and R_o where R_i^2 and R_o^2 belong (docs/errata.md);
    with u = 0 it is eq 3.56.
    """
    r = np.asarray(r, dtype=float)
    k = 0.0 if u == 0.0 else 3.0 * mu * u / gap**3
    lnio = np.log(r_outer / r_inner)
    squeeze = k * (r**2 * np.log(r_inner / r_outer) + r_inner**2 * np.log(r_outer / r)
                   + r_outer**2 * np.log(r / r_inner))
    return (dp * np.log(r_outer / r) - squeeze) / lnio


def annulus_pressure_fraction(r_inner: float, r_outer: float) -> float:
    """F3 = 1 / (2 ln(R_o/R_i)) - 1 / ((R_o/R_i)^2 - 1), dimensionless (eqs 3.57, 3.59)."""
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
    """X = iint psi F dA / int psi W ds, dimensionless, in the Poiseuille regime (eq 3.60).

    ``psi``: a callable psi(s) (s in m), the mode function normalised at the tip;
    ``F4`` the pressure fraction of the base section (Table 3.12 varies it over 0..1).
    """
    from .quadrature import ProfileQuadrature

    lay = SealingLayout.thesis() if layout is None else layout
    q = ProfileQuadrature(lay.breaks(reed), nodes)
    p = np.asarray(psi(q.s), dtype=float)
    return q.integral(p * lay.weighted_width(reed, q.s, F4)) / q.integral(p * reed.width(q.s))


def orifice_reynolds(flow, rho: float, perimeter: float, mu: float):
    """Re = rho V D_H / mu = 4 rho Q_o / (p_o mu), dimensionless, for orifice flow Q_o [m^3/s] (eqs 3.85-3.87).

    D_H = 4 A_o / p_o and V = Q_o / A_o, so A_o cancels. For the prototype (p_o = 91.2 mm,
    rho = 876 kg/m^3, mu = 0.0683 Pa s) the coefficient is 5.625e5 s/m^3; eq 3.87 prints
    its reciprocal 1.778e-6 (docs/errata.md).
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
    """X(x), dimensionless, for tip opening x [m]: eq 3.83 capped where it first reaches 0.

    X = max(0, min(X_Poiseuille, rational(x))) for x below the fit's first zero
    (1.369 mm for the prototype) and 0 above it: the printed correlation has a pole at
    1.651 mm and climbs back to 0.835 beyond it (docs/errata.md).
    """
    f = PressureMultiplierFit.thesis() if fit is None else fit
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        X = np.clip(f.rational(x), 0.0, f.poiseuille)
    X = np.where(x >= f.closing_opening, 0.0, X)
    return float(X) if X.ndim == 0 else X
