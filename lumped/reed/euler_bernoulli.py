"""Euler-Bernoulli reed: natural frequency, stiffness, deflection and mode shapes (thesis 3.2, 3.5, 3.6).

Three layers, each usable on its own:

1. Closed forms of the thesis (the uniform and stepped cantilever, eq 3.40's stiffness) and
2. the thesis's approximate three-section method: :mod:`lumped.reed.closed_forms`, re-exported here;
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

from geometry.reed import Reed

# the closed forms and the stepped beam, re-exported: this module is the reed's Euler-Bernoulli models' one name
from .closed_forms import (  # noqa: F401
    uniform_frequency_parameter, uniform_natural_frequency, frequency_parameter_from_omega, uniform_stiffness,
    stiffness_eq_3_40, Segment,
    segment_transfer_matrix, cantilever_characteristic, cantilever_frequencies, cantilever_mode_shape, stepped_segments,
    stepped_frequency_parameter, ThreeSection, three_section_stiffness, three_section_shape,
)
from .mode_function import ReedProperties, effective_thickness, mode_integrals
from .quadrature import NODES_PER_PIECE, ProfileQuadrature, profile_breaks

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
