"""The thesis's closed-form reed models and the exact stepped beam (thesis 3.2, 3.6).

1. Closed forms of the thesis: the uniform cantilever (eqs 3.1-3.4), the stepped cantilever (eqs 3.5-3.7) from the
   exact characteristic determinant of piecewise-uniform beams (Naguleswaran 2002, written as a product of exact
   segment transfer matrices), and the uniform-load stiffness of eq 3.40.
2. The thesis's approximate static method for a stepped reed with a rounded tip (Tables 3.5, 3.6, eqs 3.37-3.39
   for kappa, eqs 3.42-3.45 for the shape); it takes the tip section as rigid.

Exact Euler-Bernoulli theory on any profile is :mod:`lumped.reed.euler_bernoulli`, which re-exports these. SI
units throughout; s runs from the clamp (0) to the tip (L).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from geometry.errors import InputError
from geometry.reed import Reed

# --------------------------------------------------------------------------------
# 1. Closed forms
# --------------------------------------------------------------------------------


def uniform_frequency_parameter(mode: int = 1) -> float:
    """The n-th root alpha_n of the uniform cantilever's frequency equation cosh(a) cos(a) + 1 = 0 (eq 3.2).

    Parameters
    ----------
    mode : int
        n >= 1.

    Returns
    -------
    float
        alpha_n [-].

    References
    ----------
    Knutson (2016), eq 3.2; e.g. Rao, *Vibration of Continuous Systems* (2007), section 11.5.

    Examples
    --------
    >>> round(uniform_frequency_parameter(1), 4), round(uniform_frequency_parameter(2), 4)
    (1.8751, 4.6941)
    """
    if mode < 1:
        raise ValueError("mode must be >= 1")
    # roots lie within 0.2 of (2n - 1) pi / 2 for every n
    c = (2 * mode - 1) * np.pi / 2
    f = lambda a: np.cos(a) + 1.0 / np.cosh(a)  # eq 3.2 divided by cosh, well scaled
    return brentq(f, c - 0.35, c + 0.35, xtol=1e-15, rtol=4 * np.finfo(float).eps)


def uniform_natural_frequency(youngs_modulus: float, density: float, thickness: float,
                              length: float, alpha: float | None = None) -> float:
    """First natural frequency of a uniform (or stepped-width) reed, omega_n = alpha^2 (h / L^2) sqrt(E / (12 rho))
    (eqs 3.4, 3.7).

    Parameters
    ----------
    youngs_modulus, density : float
        E [Pa], rho [kg/m^3].
    thickness, length : float
        h, L [m].
    alpha : float, optional
        The frequency parameter [-] (None: the uniform reed's 1.8751; a stepped width's of eq 3.7).

    Returns
    -------
    float
        omega_n [rad/s].

    References
    ----------
    Knutson (2016), eqs 3.2-3.7.

    Examples
    --------
    >>> print(f"{uniform_natural_frequency(2.9e9, 1410.0, 1.35e-3, 25.4e-3):.0f} rad/s")   # Table 3.3: 3046
    3046 rad/s
    """
    a = uniform_frequency_parameter() if alpha is None else alpha
    return a**2 * thickness / length**2 * np.sqrt(youngs_modulus / (12.0 * density))


def frequency_parameter_from_omega(omega: float, thickness: float, length: float,
                                   youngs_modulus: float, density: float) -> float:
    """The frequency parameter of a measured or computed frequency, alpha = L (omega / h)^(1/2) (12 rho / E)^(1/4)
    (eq 3.75; h may be h_eff).

    Parameters
    ----------
    omega : float
        omega [rad/s].
    thickness, length : float
        h, L [m].
    youngs_modulus, density : float
        E [Pa], rho [kg/m^3].

    Returns
    -------
    float
        alpha [-].

    References
    ----------
    Knutson (2016), eq 3.75.

    Examples
    --------
    The inverse of :func:`uniform_natural_frequency`:

    >>> round(float(frequency_parameter_from_omega(3045.90, 1.35e-3, 25.4e-3, 2.9e9, 1410.0)), 4)
    1.8751
    """
    return length * np.sqrt(omega / thickness) * (12.0 * density / youngs_modulus) ** 0.25


def uniform_stiffness(youngs_modulus: float, thickness: float, length: float) -> float:
    """Stiffness of a uniform reed under a uniform pressure, kappa = dP / x_tip = 2 E h^3 / (3 L^4) (eq 3.40 with
    W1 = W2; the cantilever's q L^4 / (8 E I)).

    Parameters
    ----------
    youngs_modulus : float
        E [Pa].
    thickness, length : float
        h, L [m].

    Returns
    -------
    float
        kappa [Pa/m].

    Examples
    --------
    The thesis's uniform reed (Delrin, 1.35 mm, 1 in):

    >>> round(uniform_stiffness(2.9e9, 1.35e-3, 25.4e-3) / 1e6, 3)
    11.428
    """
    return 2.0 * youngs_modulus * thickness**3 / (3.0 * length**4)


def stiffness_eq_3_40(youngs_modulus: float, thickness: float, width_root: float,
                      width_tip: float, length_root: float, length_tip: float) -> float:
    """Stiffness of a square-tipped stepped-width reed under a uniform pressure (eq 3.40).

    Parameters
    ----------
    youngs_modulus : float
        E [Pa].
    thickness : float
        h [m].
    width_root, width_tip : float
        W1, W2 [m].
    length_root, length_tip : float
        L1, L2 [m].

    Returns
    -------
    float
        kappa [Pa/m].

    References
    ----------
    Knutson (2016), eq 3.40 (its last term corrected, docs/errata.md).

    Examples
    --------
    Stepped reed #1 (Table 3.1's inch dimensions):

    >>> round(stiffness_eq_3_40(2.9e9, 1.35e-3, 7.9375e-3, 15.875e-3, 4.7625e-3, 20.6375e-3) / 1e6, 3)
    7.345

    Notes
    -----
    kappa = 24 E I1 / (3 W1 L1^4 + (4 W1 + 8 W2) L1^3 L2 + 18 W2 L1^2 L2^2 + 12 W2 L1 L2^3 + 3 W1 L2^4),
    I1 = W1 h^3 / 12.

    The thesis prints the last term as (3/2) W2 L2^4, which equals 3 W1 L2^4 only for
    W2 = 2 W1 (its reeds); the general term is 3 W2 L2^4 I1 / I2 = 3 W1 L2^4
    (docs/errata.md). Exact Euler-Bernoulli for a square tip.
    """
    W1, W2, L1, L2 = width_root, width_tip, length_root, length_tip
    I1 = W1 * thickness**3 / 12.0
    den = (3 * W1 * L1**4 + (4 * W1 + 8 * W2) * L1**3 * L2 + 18 * W2 * L1**2 * L2**2
           + 12 * W2 * L1 * L2**3 + 3 * W1 * L2**4)
    return 24.0 * youngs_modulus * I1 / den


# -- exact piecewise-uniform beams (transfer matrices) ----------------------------


@dataclass(frozen=True)
class Segment:
    """A uniform piece of beam: length [m], flexural rigidity EI [N m^2], mass per length m [kg/m]."""

    length: float
    EI: float
    m: float


def segment_transfer_matrix(seg: Segment, omega: float) -> np.ndarray:
    """Exact transfer matrix of a uniform Euler-Bernoulli segment: maps the state (w, dw/ds, M = EI d2w/ds2,
    V = EI d3w/ds3) at its start to its end for EI d4w/ds4 = m omega^2 w (Krylov-Duncan functions; omega = 0
    gives the static matrix).

    Parameters
    ----------
    seg : Segment
        Length [m], EI [N m^2], m [kg/m].
    omega : float
        Circular frequency [rad/s].

    Returns
    -------
    numpy.ndarray
        4 x 4 matrix (SI units of the state).

    References
    ----------
    Naguleswaran (2002); Rao, *Vibration of Continuous Systems* (2007), section 11.
    """
    L, EI = seg.length, seg.EI
    beta = (seg.m * omega**2 / EI) ** 0.25
    x = beta * L
    if x < 1e-3:  # series of the Krylov functions (avoids 0/0 at low frequency)
        x4 = x**4
        S = 1 + x4 / 24
        T = L * (1 + x4 / 120)            # T / beta
        U = L**2 / 2 * (1 + x4 / 360)     # U / beta^2
        Vb = L**3 / 6 * (1 + x4 / 840)    # V / beta^3
        bV = beta**4 * L**3 / 6           # beta V
        b2U = beta**4 * L**2 / 2          # beta^2 U
        b3T = beta**4 * L                 # beta^3 T
    else:
        ch, sh, c, s = np.cosh(x), np.sinh(x), np.cos(x), np.sin(x)
        S, Tf, Uf, Vf = (ch + c) / 2, (sh + s) / 2, (ch - c) / 2, (sh - s) / 2
        T, U, Vb = Tf / beta, Uf / beta**2, Vf / beta**3
        bV, b2U, b3T = beta * Vf, beta**2 * Uf, beta**3 * Tf
    return np.array([
        [S, T, U / EI, Vb / EI],
        [bV, S, T / EI, U / EI],
        [EI * b2U, EI * bV, S, T],
        [EI * b3T, EI * b2U, bV, S],
    ])


def cantilever_characteristic(omega: float, segments: list[Segment]) -> float:
    """Frequency determinant of a clamped-free chain of uniform segments (zero at natural frequencies).

    Parameters
    ----------
    omega : float
        [rad/s].
    segments : list of Segment
        From the clamp to the tip.

    Returns
    -------
    float
        det P[2:, 2:] [-] (1 at omega = 0).

    Notes
    -----
    Clamp: w = w' = 0 at s = 0; free tip: M = V = 0. With P the product of segment
    transfer matrices, nontrivial (M0, V0) need det P[2:, 2:] = 0: the exact
    characteristic equation of Naguleswaran (2002) for a stepped beam and
    (1 + cosh a cos a) / 2 (eq 3.2) for a uniform one; it equals 1 at omega = 0.
    """
    P = np.eye(4)
    for seg in segments:
        P = segment_transfer_matrix(seg, omega) @ P
    return float(np.linalg.det(P[2:, 2:]))


def cantilever_frequencies(segments: list[Segment], n_modes: int = 1) -> np.ndarray:
    """First natural frequencies of a clamped-free chain of uniform segments (exact Euler-Bernoulli): the roots
    of :func:`cantilever_characteristic`.

    Parameters
    ----------
    segments : list of Segment
        From the clamp to the tip.
    n_modes : int
        How many.

    Returns
    -------
    numpy.ndarray
        omega [rad/s], ascending.

    References
    ----------
    Naguleswaran (2002); Knutson (2016), eq 3.7.
    """
    if not segments:
        raise ValueError("need at least one segment")
    Ltot = sum(sg.length for sg in segments)
    ref = segments[-1]
    scale = np.sqrt(ref.EI / (ref.m * Ltot**4))  # omega = alpha^2 scale
    f = lambda a: cantilever_characteristic(a * a * scale, segments)
    roots: list[float] = []
    a0, f0 = 1e-3, f(1e-3)
    step = 0.01
    while len(roots) < n_modes:
        a1 = a0 + step
        f1 = f(a1)
        if np.sign(f1) != np.sign(f0):
            roots.append(brentq(f, a0, a1, xtol=1e-15, rtol=4 * np.finfo(float).eps))
        a0, f0 = a1, f1
        if a0 > 200.0:
            raise RuntimeError("no natural frequency found below alpha = 200")
    return np.array(roots) ** 2 * scale


def cantilever_mode_shape(segments: list[Segment], omega: float, s) -> np.ndarray:
    """Exact mode shape of a chain of uniform segments at one of its natural frequencies, w(L) = 1.

    Parameters
    ----------
    segments : list of Segment
        From the clamp to the tip.
    omega : float
        A natural frequency [rad/s] (:func:`cantilever_frequencies`).
    s : array_like
        Positions from the clamp [m].

    Returns
    -------
    numpy.ndarray
        w(s) [-].
    """
    P = np.eye(4)
    starts, mats = [], []
    pos = 0.0
    for seg in segments:
        starts.append(pos)
        mats.append(P.copy())
        P = segment_transfer_matrix(seg, omega) @ P
        pos += seg.length
    # null vector of P[2:, 2:] gives (M0, V0) with the tip free
    B = P[2:, 2:]
    mv = np.array([-B[0, 1], B[0, 0]]) if abs(B[0, 0]) + abs(B[0, 1]) > 0 else np.array([-B[1, 1], B[1, 0]])
    z0 = np.array([0.0, 0.0, *mv])
    s = np.asarray(s, dtype=float)
    out = np.empty_like(s)
    bounds = np.array(starts + [pos])
    for i, si in np.ndenumerate(s):
        k = min(max(int(np.searchsorted(bounds, si, side="right")) - 1, 0), len(segments) - 1)
        zk = mats[k] @ z0
        local = Segment(si - starts[k], segments[k].EI, segments[k].m)
        out[i] = (segment_transfer_matrix(local, omega) @ zk)[0]
    tip = (P @ z0)[0]
    return out / tip


def stepped_segments(reed: Reed) -> list[Segment]:
    """The reed as uniform Euler-Bernoulli segments (width and thickness steps).

    Parameters
    ----------
    reed : geometry.Reed
        A piecewise-uniform reed (square tip, no grooves, no taper; InputError otherwise).

    Returns
    -------
    list of Segment
        Length [m], EI [N m^2], m [kg/m] of each piece between breakpoints.
    """
    if not reed.is_piecewise_uniform:
        raise InputError("reed", "the exact stepped-beam determinant needs a square tip, no grooves and no taper")
    out = []
    for a, b in zip(reed.breakpoints()[:-1], reed.breakpoints()[1:]):
        mid = 0.5 * (a + b)
        A, I = reed.section(mid)
        out.append(Segment(b - a, reed.material.youngs_modulus * float(I), reed.material.density * float(A)))
    return out


def stepped_frequency_parameter(step_fraction: float, width_ratio: float) -> float:
    """Frequency parameter alpha of a stepped-width cantilever of uniform thickness (eq 3.7): the root of the exact
    Naguleswaran (2002) determinant. I/m is equal in both sections (eq 3.6), so alpha depends on R_l and W21 only.

    Parameters
    ----------
    step_fraction : float
        R_l = L1 / L [-].
    width_ratio : float
        W21 = W2 / W1 [-].

    Returns
    -------
    float
        alpha [-] (R_l = 0 or W21 = 1: the uniform 1.8751).

    References
    ----------
    Knutson (2016), eqs 3.5-3.7, Table 3.11; Naguleswaran (2002).

    Examples
    --------
    >>> round(stepped_frequency_parameter(0.1875, 2.0), 3)     # stepped reed #1; Table 3.11: 1.674
    1.674
    """
    if not 0.0 <= step_fraction < 1.0 or not width_ratio > 0.0:
        raise ValueError("need 0 <= step_fraction < 1 and width_ratio > 0")
    segs = []
    if step_fraction > 0.0:
        segs.append(Segment(step_fraction, 1.0, 1.0))  # W1 = 1, both EI and m scale with W
    segs.append(Segment(1.0 - step_fraction, width_ratio, width_ratio))
    omega = cantilever_frequencies(segs, 1)[0]
    return float(np.sqrt(omega))  # L = 1 and EI/m = 1 make omega = alpha^2


# --------------------------------------------------------------------------------
# 2. The thesis's approximate three-section method (rigid tip section)
# --------------------------------------------------------------------------------


@dataclass(frozen=True)
class ThreeSection:
    """Sections of Table 3.5 and the loads of Table 3.6 per unit pressure (SI units)."""

    L1: float
    L2: float
    L3: float
    W1: float
    W2: float
    R: float
    A2: float
    A3: float
    EI1: float
    EI2: float

    @classmethod
    def from_reed(cls, reed: Reed) -> "ThreeSection":
        """Table 3.5 quantities of a stepped reed with a rounded tip (grooves ignored: nominal h).

        Needs the thesis's outline: at most one width step, uniform thickness, no taper
        (InputError naming reed.sections otherwise).
        """
        if reed.is_sectioned and (len(reed.pieces()) > 2 or reed.is_tapered or reed.has_thickness_steps):
            raise InputError("reed.sections", "the thesis's three-section method (Tables 3.5, 3.6) needs one "
                             "width step at uniform thickness and no taper; use the exact E-B model")
        L, R, h, E = reed.length, reed.tip_radius, reed.thickness, reed.material.youngs_modulus
        L1 = reed.step_location
        W1 = reed.width_root if reed.step_fraction > 0.0 else reed.width_tip
        W2 = reed.width_tip
        L3 = R
        L2 = L - L1 - L3
        if L1 + L2 <= 0.0:
            raise ValueError("the three-section method needs a flexible part: the rounded tip fills the "
                             "whole reed (L1 + L2 = 0), so it would be rigid")
        return cls(L1=L1, L2=L2, L3=L3, W1=W1, W2=W2, R=R, A2=L2 * W2,
                   A3=R * (W2 - (2.0 - np.pi / 2.0) * R),
                   EI1=E * W1 * h**3 / 12.0, EI2=E * W2 * h**3 / 12.0)

    def loads(self):
        """q1, q2 [N/m], F1, F2 [N], M1, M2 [N m] per unit pressure (Table 3.6, eq 3.37)."""
        q1, q2 = self.W1, self.W2
        F2 = self.A3
        F1 = self.A2 + self.A3
        M2 = self.R**2 * (self.W2 / 2.0 - self.R / 3.0)
        M1 = self.A2 * self.L2 / 2.0 + F2 * self.L2 + M2
        return q1, q2, F1, F2, M1, M2

    def ends(self):
        """x1, theta1, x2, theta2: end deflection [m] and slope of sections 1 and 2 per unit pressure (Table 3.6)."""
        q1, q2, F1, F2, M1, M2 = self.loads()
        L1, L2, EI1, EI2 = self.L1, self.L2, self.EI1, self.EI2
        x1 = q1 * L1**4 / (8 * EI1) + F1 * L1**3 / (3 * EI1) + M1 * L1**2 / (2 * EI1)
        t1 = q1 * L1**3 / (6 * EI1) + F1 * L1**2 / (2 * EI1) + M1 * L1 / EI1
        x2 = q2 * L2**4 / (8 * EI2) + F2 * L2**3 / (3 * EI2) + M2 * L2**2 / (2 * EI2)
        t2 = q2 * L2**3 / (6 * EI2) + F2 * L2**2 / (2 * EI2) + M2 * L2 / EI2
        return x1, t1, x2, t2

    def tip_deflection(self) -> float:
        """x = x1 + L2 theta1 + x2 + L3 (theta1 + theta2) [m] per unit pressure (eq 3.39)."""
        x1, t1, x2, t2 = self.ends()
        return x1 + self.L2 * t1 + x2 + self.L3 * (t1 + t2)

    def deflection(self, s) -> np.ndarray:
        """v(s) [m] per unit pressure, eqs 3.42-3.44 (eq 3.44 with L2 theta1; docs/errata.md)."""
        s = np.asarray(s, dtype=float)
        q1, q2, F1, F2, M1, M2 = self.loads()
        x1, t1, x2, t2 = self.ends()
        L1, L2, EI1, EI2 = self.L1, self.L2, self.EI1, self.EI2
        u = np.clip(s, 0.0, L1)
        v1 = (q1 * u**2 / (24 * EI1) * (u**2 + 6 * L1**2 - 4 * L1 * u)
              + F1 * u**2 / (6 * EI1) * (3 * L1 - u) + M1 * u**2 / (2 * EI1))
        r = np.clip(s - L1, 0.0, L2)
        v2 = (x1 + r * t1 + q2 * r**2 / (24 * EI2) * (r**2 + 6 * L2**2 - 4 * L2 * r)
              + F2 * r**2 / (6 * EI2) * (3 * L2 - r) + M2 * r**2 / (2 * EI2))
        v3 = x1 + L2 * t1 + x2 + (s - L1 - L2) * (t1 + t2)
        return np.where(s < L1, v1, np.where(s <= L1 + L2, v2, v3))


def three_section_stiffness(reed: Reed) -> float:
    """Stiffness of a reed by the thesis's three-section method, kappa = 1 / x_tip per unit pressure (Table 3.6,
    eqs 3.37-3.39). It takes the rounded tip section as rigid, so it overestimates kappa of rounded reeds; for
    a square tip it equals eq 3.40 (exact).

    Parameters
    ----------
    reed : geometry.Reed
        A one-step reed (Table 3.5's sections).

    Returns
    -------
    float
        kappa [Pa/m].

    References
    ----------
    Knutson (2016), eqs 3.37-3.39, Tables 3.5-3.6, Table 3.13.

    Examples
    --------
    >>> from geometry import load_reed
    >>> round(three_section_stiffness(load_reed("stepped2")) / 1e6, 3)       # Table 3.13: 8.702 MPa/m
    8.702
    """
    return 1.0 / ThreeSection.from_reed(reed).tip_deflection()


def three_section_shape(reed: Reed, s) -> np.ndarray:
    """The three-section method's static shape psi(s) = v(s) / v(L) under a uniform pressure (eqs 3.42-3.45,
    rigid tip section).

    Parameters
    ----------
    reed : geometry.Reed
        A one-step reed.
    s : array_like
        Positions from the clamp [m].

    Returns
    -------
    numpy.ndarray
        psi [-].
    """
    ts = ThreeSection.from_reed(reed)
    return ts.deflection(s) / ts.tip_deflection()
