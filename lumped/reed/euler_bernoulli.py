"""Euler-Bernoulli reed: natural frequency, stiffness, deflection and mode shapes (thesis 3.2, 3.5, 3.6).

Three layers, each usable on its own:

1. Closed forms of the thesis: the uniform cantilever (eqs 3.1-3.4), the stepped
   cantilever (eqs 3.5-3.7) from the exact characteristic determinant of
   piecewise-uniform beams (Naguleswaran 2002, written as a product of exact
   segment transfer matrices), and the uniform-load stiffness of eq 3.40.
2. The thesis's approximate static method for a stepped reed with a rounded tip
   (Tables 3.5, 3.6, eqs 3.37-3.39 for kappa, eqs 3.42-3.45 for the shape); it
   takes the tip section as rigid.
3. Exact Euler-Bernoulli theory on the real profile of any :class:`geometry.Reed`
   (width and thickness steps, tapers, several sections, rounded tips, grooves):
   EI(s) = E I(s) and m(s) = rho A(s) from ``reed.section``. The static deflection of a cantilever is a chain of four
   integrals (shear, moment, slope, deflection), evaluated with a spectral
   quadrature on the pieces between the profile's breakpoints; the free-vibration
   problem w = omega^2 G[m w] (G the static flexibility operator) is solved on the
   same quadrature. Both converge exponentially: ~1e-10 relative with the default
   node count. :func:`reed_properties` is the ``analytic`` fidelity; :func:`modes` gives
   the first n bending modes (Naguleswaran determinant of the segment chain where the
   profile is piecewise uniform, else the dense eigenproblem of G diag(m)).

SI units throughout; s runs from the clamp (0) to the tip (L).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from geometry.errors import InputError
from geometry.reed import Reed

from .mode_function import ReedProperties, effective_thickness, mode_integrals
from .quadrature import NODES_PER_PIECE, ProfileQuadrature, profile_breaks

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


# --------------------------------------------------------------------------------
# 3. Exact Euler-Bernoulli theory on the real profile
# --------------------------------------------------------------------------------

@dataclass(frozen=True)
class BeamModel:
    """A reed discretised for exact E-B: nodes s [m], W(s) [m], EI(s) [N m^2], m(s) [kg/m]."""

    reed: Reed
    quad: ProfileQuadrature
    W: np.ndarray
    EI: np.ndarray
    m: np.ndarray

    @classmethod
    def of(cls, reed: Reed, n: int = NODES_PER_PIECE) -> "BeamModel":
        quad = ProfileQuadrature(profile_breaks(reed), n)
        A, I = reed.section(quad.s)
        return cls(reed, quad, np.asarray(reed.width(quad.s)),
                   reed.material.youngs_modulus * np.asarray(I), reed.material.density * np.asarray(A))

    def slope(self, q) -> np.ndarray:
        """theta(s) [rad] at the nodes under distributed load q(s) [N/m] (cantilever, exact E-B)."""
        Qq = self.quad
        V = Qq.R @ q            # shear  V(s) = int_s^L q
        M = Qq.R @ V            # moment M(s) = int_s^L V
        return Qq.Q @ (M / self.EI)

    def deflection(self, q, s_out=None) -> np.ndarray:
        """w [m] under distributed load q(s) [N/m] at the nodes, or at ``s_out`` (eqs 3.34-3.36 integrated)."""
        th = self.slope(q)
        if s_out is None:
            return self.quad.Q @ th
        return self.quad.forward_at(s_out) @ th

    def flexibility(self) -> np.ndarray:
        """Matrix G with w = G q at the nodes (static cantilever flexibility)."""
        Qq = self.quad
        return Qq.Q @ Qq.Q @ (Qq.R @ Qq.R / self.EI[:, None])


def static_shape(reed: Reed, s_out=None, n: int = NODES_PER_PIECE):
    """Exact Euler-Bernoulli deflection of any reed per unit uniform pressure (load q = W(s) per unit dP), by
    integrating the moment twice on the spectral quadrature (eqs 3.34-3.36).

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    s_out : array_like, optional
        Positions [m] (None: the quadrature nodes).
    n : int
        Chebyshev nodes per piece.

    Returns
    -------
    tuple
        (s [m], v(s) [m/Pa], v_tip [m/Pa]).
    """
    bm = BeamModel.of(reed, n)
    th = bm.slope(bm.W)
    tip = float((bm.quad.forward_at(reed.length) @ th)[0])
    if s_out is None:
        return bm.quad.s, bm.quad.Q @ th, tip
    return np.asarray(s_out, float), bm.quad.forward_at(s_out) @ th, tip


def exact_stiffness(reed: Reed, n: int = NODES_PER_PIECE) -> float:
    """Stiffness of any reed, kappa = dP / x_tip, by exact Euler-Bernoulli integration on the real profile
    (eq 3.30; the tip flexible, unlike the three-section method).

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    n : int
        Chebyshev nodes per piece.

    Returns
    -------
    float
        kappa [Pa/m].

    References
    ----------
    Knutson (2016), eq 3.30.

    Examples
    --------
    A uniform reed: the closed form 2 E h^3 / (3 L^4):

    >>> from geometry import load_reed
    >>> r = load_reed("uniform")
    >>> round(exact_stiffness(r) / uniform_stiffness(2.9e9, r.thickness, r.length), 12)
    1.0
    """
    return 1.0 / static_shape(reed, [reed.length], n)[2]


def _first_mode(bm: BeamModel):
    """omega_n [rad/s] and the slope theta(s) at the nodes of the first mode (tip deflection not yet normalised).

    w = omega^2 G[m w]: power iteration on G diag(m), whose largest eigenvalue is
    1 / omega_n^2 and is separated from the next by (omega_2 / omega_1)^2 > 10 for any
    cantilever, so it converges in a few tens of steps (dense eig as a fallback).
    """
    w = bm.quad.s**2  # close to the first mode already
    lam = 0.0
    for _ in range(400):
        th = bm.slope(bm.m * w)
        w_new = bm.quad.Q @ th
        lam_new = float(w_new @ w / (w @ w))
        w = w_new / np.max(np.abs(w_new))
        if abs(lam_new - lam) <= 1e-14 * abs(lam_new):
            lam = lam_new
            break
        lam = lam_new
    else:  # pragma: no cover - not reached for physical profiles
        vals, vecs = np.linalg.eig(bm.flexibility() * bm.m[None, :])
        k = int(np.argmax(vals.real))
        lam, w = float(vals[k].real), vecs[:, k].real
    omega = 1.0 / np.sqrt(lam)
    return omega, bm.slope(omega**2 * bm.m * w)


def free_vibration(reed: Reed, n: int = NODES_PER_PIECE, s_out=None):
    """First bending mode of any reed in vacuum (exact Euler-Bernoulli): w = omega^2 G[m w] on the spectral
    quadrature, G the static flexibility of the cantilever.

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    n : int
        Chebyshev nodes per piece.
    s_out : array_like, optional
        Positions [m] (None: the quadrature nodes).

    Returns
    -------
    tuple
        (omega_n [rad/s], s [m], psi(s) [-] with psi(L) = 1).
    """
    bm = BeamModel.of(reed, n)
    omega, th = _first_mode(bm)
    tip = float((bm.quad.forward_at(reed.length) @ th)[0])
    if s_out is None:
        return omega, bm.quad.s, (bm.quad.Q @ th) / tip
    s_out = np.asarray(s_out, dtype=float)
    return omega, s_out, (bm.quad.forward_at(s_out) @ th) / tip


def natural_frequency(reed: Reed, n: int = NODES_PER_PIECE, model: BeamModel | None = None) -> float:
    """First bending frequency of any reed in vacuum by exact Euler-Bernoulli on the real profile.

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    n : int
        Chebyshev nodes per piece.
    model : BeamModel, optional
        The discretised reed, if the caller has it.

    Returns
    -------
    float
        omega_n [rad/s].

    References
    ----------
    Knutson (2016), eqs 3.2-3.8, Table 3.3; Naguleswaran (2002).

    Examples
    --------
    >>> from geometry import load_reed
    >>> round(natural_frequency(load_reed("stepped1")))         # Table 3.3: 2427 rad/s
    2427

    Notes
    -----
    Piecewise-uniform reeds (square tip, no grooves, no taper; width and thickness
    steps allowed) use the exact Naguleswaran determinant; others the spectral solution
    of :func:`free_vibration`.
    """
    if reed.is_piecewise_uniform:
        return float(cantilever_frequencies(stepped_segments(reed), 1)[0])
    return _first_mode(model if model is not None else BeamModel.of(reed, n))[0]


@dataclass(frozen=True)
class BendingModes:
    """The first bending modes of an E-B reed (SI): omega [rad/s] ascending, labels
    ("bending 1", ...: mode n has n - 1 nodes), shapes w(s) at ``s`` [m] (columns, max |w| = 1)."""

    omega: np.ndarray
    labels: list
    s: np.ndarray
    shapes: np.ndarray

    def first(self, n: int):
        """The first n frequencies [rad/s] and labels (CONTRACT ``frequencies``, ``mode_kinds``)."""
        return [float(w) for w in self.omega[:n]], list(self.labels[:n])


def modes(reed: Reed, n_modes: int, mesh_size=None, nodes: int | None = None) -> BendingModes:
    """First bending natural frequencies and mode shapes of any reed by exact Euler-Bernoulli.

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    n_modes : int
        How many.
    mesh_size : float, optional
        Ignored (the fidelities' common signature).
    nodes : int, optional
        Chebyshev nodes per piece (None: max(24, 6 n)).

    Returns
    -------
    BendingModes
        omega [rad/s], labels, shapes on :func:`plot_grid`.

    Notes
    -----
    (EI(s) w'')'' = omega^2 m(s) w, clamped-free. Piecewise-uniform profiles (width and
    thickness steps, square tip, no grooves): roots of the Naguleswaran (2002) determinant
    of the exact segment transfer matrices and their exact shapes. Others (tapers, rounded
    tips, grooves): the eigenproblem w = omega^2 G[m w] on the spectral quadrature, with
    max(24, 6 n) Chebyshev nodes per piece (mode 8 of a uniform reed to 3e-8).
    ``mesh_size`` is ignored.
    """
    n_modes = max(int(n_modes), 1)
    s_out = plot_grid(reed)
    if reed.is_piecewise_uniform:
        segs = stepped_segments(reed)
        omega = cantilever_frequencies(segs, n_modes)
        shapes = np.column_stack([cantilever_mode_shape(segs, w, s_out) for w in omega])
    else:
        n = max(NODES_PER_PIECE, 6 * n_modes) if nodes is None else nodes
        bm = BeamModel.of(reed, n)
        vals, vecs = np.linalg.eig(bm.flexibility() * bm.m[None, :])
        order = np.argsort(-vals.real)[:n_modes]
        lam = vals.real[order]
        omega = 1.0 / np.sqrt(lam)
        shapes = np.column_stack([bm.quad.forward_at(s_out) @ bm.slope(bm.m * vecs[:, k].real)
                                  for k in order])
    shapes = shapes / np.max(np.abs(shapes), axis=0)
    labels = [f"bending {k + 1}" for k in range(n_modes)]
    return BendingModes(omega=np.asarray(omega, dtype=float), labels=labels, s=s_out, shapes=shapes)


def properties_and_modes(reed: Reed, n: int, mesh_size=None):
    """The analytic fidelity's properties and its first bending modes from one call.

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    n : int
        Modes.
    mesh_size : float, optional
        Ignored.

    Returns
    -------
    tuple
        (ReedProperties of :func:`reed_properties`, :class:`BendingModes` of :func:`modes`).
    """
    return reed_properties(reed), modes(reed, n)


#: shapes :func:`shape_mode_parameters` knows
SHAPES = ("load", "free", "three_section")


def shape(reed: Reed, kind: str = "load", s_out=None, n: int = NODES_PER_PIECE):
    """A reed's mode function psi(s), psi(L) = 1: the exact static uniform-pressure shape (``load``), the exact
    first vibration mode (``free``) or the thesis's three-section shape of eqs 3.42-3.45 (``three_section``).

    Parameters
    ----------
    reed : geometry.Reed
        Any profile (one-step for ``three_section``).
    kind : str
        ``load``, ``free`` or ``three_section``.
    s_out : array_like, optional
        Positions [m] (None: the quadrature nodes).
    n : int
        Chebyshev nodes per piece.

    Returns
    -------
    tuple
        (s [m], psi [-]).
    """
    if kind == "load":
        s, v, tip = static_shape(reed, s_out, n)
        return s, v / tip
    if kind == "free":
        _, s, psi = free_vibration(reed, n, s_out)
        return s, psi
    if kind == "three_section":
        s = BeamModel.of(reed, n).quad.s if s_out is None else np.asarray(s_out, dtype=float)
        return s, three_section_shape(reed, s)
    raise ValueError(f"unknown shape {kind!r}; expected one of {SHAPES}")


def shape_mode_parameters(reed: Reed, kind: str = "load", n: int = NODES_PER_PIECE):
    """The mode-function parameters gamma1, gamma2, gamma3 of a reed's ``kind`` shape (:func:`shape`), integrated
    on the spectral quadrature (Table 3.4).

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    kind : str
        ``load``, ``free`` or ``three_section``.
    n : int
        Chebyshev nodes per piece.

    Returns
    -------
    tuple of float
        (gamma1, gamma2, gamma3) [-].

    References
    ----------
    Knutson (2016), Table 3.4, Table 3.8.

    Examples
    --------
    >>> from geometry import load_reed
    >>> [round(g, 3) for g in shape_mode_parameters(load_reed("stepped1"), "load")]    # Table 3.8: 1.534, 0.743, 1.0
    [1.534, 0.743, 1.0]
    """
    bm = BeamModel.of(reed, n)
    _, psi = shape(reed, kind, bm.quad.s, n)
    return mode_integrals(bm.quad, psi, bm.W, reed.width_tip)


def plot_grid(reed: Reed, n: int = 401) -> np.ndarray:
    """Sample points for drawing a reed's shapes: uniform in s, plus every section breakpoint.

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    n : int
        Uniform points.

    Returns
    -------
    numpy.ndarray
        s [m], sorted.
    """
    return np.unique(np.concatenate([np.linspace(0.0, reed.length, n), profile_breaks(reed)]))


def reed_properties(reed: Reed, mesh_size=None) -> ReedProperties:
    """The ``analytic`` fidelity: omega_n, kappa, gamma1..3 and h_eff of any reed by exact Euler-Bernoulli.

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    mesh_size : float, optional
        Ignored.

    Returns
    -------
    lumped.reed.mode_function.ReedProperties

    References
    ----------
    Knutson (2016), eqs 3.30, 3.62, Table 3.4.

    Notes
    -----
    omega_n from the free-vibration eigenproblem (Naguleswaran determinant where the
    profile is piecewise uniform), kappa = Delta P / x from the static uniform-pressure
    deflection (load q = Delta P W(s)), gammas (Table 3.4) from that static shape,
    h_eff = gamma1 kappa / (rho_c omega_n^2) (eq 3.62). ``mesh_size`` is ignored.
    """
    bm = BeamModel.of(reed)
    th = bm.slope(bm.W)
    tip = float((bm.quad.forward_at(reed.length) @ th)[0])
    psi_nodes = (bm.quad.Q @ th) / tip
    g1, g2, g3 = mode_integrals(bm.quad, psi_nodes, bm.W, reed.width_tip)
    kappa = 1.0 / tip
    omega = natural_frequency(reed, model=bm)
    s = plot_grid(reed)
    psi = (bm.quad.forward_at(s) @ th) / tip
    h_eff = effective_thickness(g1, kappa, reed.material.density, omega)
    return ReedProperties(fidelity="analytic", omega_n=omega, kappa=kappa, gamma1=g1, gamma2=g2,
                          gamma3=g3, h_eff=h_eff, s=s, psi=psi, dofs=None, mesh_size=None)


def free_mode_shape(reed: Reed, mesh_size=None) -> tuple[np.ndarray, np.ndarray]:
    """The first free-vibration mode of a reed on :func:`plot_grid`, psi(L) = 1 (exact Euler-Bernoulli).

    Parameters
    ----------
    reed : geometry.Reed
        Any profile.
    mesh_size : float, optional
        Ignored.

    Returns
    -------
    tuple
        (s [m], psi [-]).

    Notes
    -----
    The optional hook of a fidelity module that ``valvelab reed --plot`` draws beside
    the static shape; ``mesh_size`` is ignored.
    """
    return shape(reed, "free", plot_grid(reed))
