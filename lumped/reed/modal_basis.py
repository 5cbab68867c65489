"""The reed's first modes as a modal basis, and the whole FE reed, for a reed valve beyond one mode.

The reed's transverse deflection is w(s, y, t) = sum_i phi_i(s, y) q_i(t) (s from the clamp,
y across from the centre line), phi_i the free-vibration modes in vacuum of the chosen
fidelity (K phi = omega^2 M phi), each normalised so that max |phi_i| over the face is 1
and positive, so the modal coordinates q_i are in metres. Per mode (:class:`ModalBasis`):

- modal mass m_i = int rho_c h phi_i^2 dA [kg] and stiffness k_i = m_i omega_i^2 [N/m];
- modal load Gamma_i = int_F phi_i dA [m^2] over the port footprint F (the whole face by
  default, as eq 3.21 assumes): a pressure difference dP X(x) on F gives the generalised
  force dP X(x) Gamma_i [N];
- the opening functional c_i: x = sum_i c_i q_i [m] is the reed's mean lift over the
  footprint's outline (the sealing line), scaled so that for the first bending mode it is
  that mode's tip deflection (the one-mode model's x is the tip opening, and its orifice
  length l_o was calibrated to the tip): c_i = <phi_i>_edge / <phi_1>_edge phi_1(L, 0).
  With the whole face as footprint the edge is the tip centre, so c_i = phi_i(L, 0);
- the tip value phi_i(L, 0) (the quantity the thesis measured);
- at stations s_k along the reed (Gauss points on the reed's pieces, weights, widths
  W(s_k)): the width-mean deflection wbar_i(s_k) = (1/W) int phi_i dy and the twist
  theta_i(s_k) = (12 / W^3) int phi_i y dy (the least-squares slope across the width),
  from which the strip-theory added mass and the quadratic drag are formed
  (:meth:`ModalBasis.added_mass`).

With one mode (the first bending mode, the whole face, tip normalisation) and the modal
equation divided by int psi^2 W ds this is eq 3.21 of Knutson (2016) with Table 3.4's
integrals taken over that mode shape: m_1 = rho_c h_eff int psi^2 W ds (eq 3.20),
Gamma_1 = gamma1 int psi^2 W ds, k_1 = gamma1 kappa int psi^2 W ds. The pump's one-mode
valve takes its gammas and kappa from the static uniform-load shape instead
(:mod:`lumped.reed.mode_function`), so the two differ by the shape difference (about 1 % in the
static tip deflection of a uniform reed; docs/reed_dynamics.md).

:class:`FEReed` is the whole finite-element reed (dense M, K with the clamp removed, the
consistent load of a unit pressure over the footprint, the opening and tip vectors and the
station matrices): the reference the modal model converges to.

Fidelities are registered like :mod:`lumped.reed.fidelities`'s: ``analytic`` (exact
Euler-Bernoulli, bending only) here; ``beam``, ``plate`` and ``solid`` from ``fea``
through the entry point groups ``valvelab.reed_modes`` and ``valvelab.reed_fe``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from geometry import validate
from geometry.errors import InputError
from geometry.reed import Reed
from geometry.reed_port import ReedPort, check_port, edge_rule, face_grid, face_rule, station_rule
from lumped import plugins

#: the most modes a modal reed valve may use (model-file key ``modes``)
MAX_MODES = 6
#: stations along the reed for the width-mean deflection and twist (strip theory)
N_STATIONS = 32
#: Gauss points across the width at each station (twist and width mean)
N_ACROSS = 8
GROUP = "valvelab.reed_modes"
FE_GROUP = "valvelab.reed_fe"
ORDER = ("analytic", "beam", "plate", "solid")


def _frozen(a) -> np.ndarray:
    out = np.array(a, dtype=float)
    out.setflags(write=False)  # cached and shared between simulations
    return out


# ------------------------------------------------------------------------------ the basis
@dataclass(frozen=True, eq=False)
class ModalBasis:
    """The first N modes of a reed with what a modal reed valve needs (SI units).

    omega (N,) [rad/s] ascending; modal_mass (N,) [kg]; modal_stiffness (N,) [N/m];
    load (N,) Gamma_i [m^2]; opening (N,) c_i [-]; tip (N,) phi_i(L, 0) [-]; kinds (N,)
    names by nodal pattern ("bending 1", "torsion 1", ...); stations (K,) s_k [m],
    weights (K,) [m], widths (K,) W(s_k) [m]; wbar (N, K) width-mean deflection and
    theta (N, K) twist [1/m] of each mode at the stations; fidelity, port (None: whole
    face), mesh_size [m] (None: analytic), dofs of the eigenproblem (None: analytic).
    See the module docstring for the definitions.
    """

    fidelity: str
    omega: np.ndarray
    modal_mass: np.ndarray
    modal_stiffness: np.ndarray
    load: np.ndarray
    opening: np.ndarray
    tip: np.ndarray
    kinds: tuple
    stations: np.ndarray
    weights: np.ndarray
    widths: np.ndarray
    wbar: np.ndarray
    theta: np.ndarray
    port: ReedPort | None = None
    mesh_size: float | None = None
    dofs: int | None = None

    @property
    def n_modes(self) -> int:
        return len(self.omega)

    def truncated(self, n: int) -> "ModalBasis":
        """The first ``n`` modes of this basis."""
        n = int(n)
        if not 1 <= n <= self.n_modes:
            raise ValueError(f"n must be 1..{self.n_modes}, got {n}")
        cut = {k: _frozen(getattr(self, k)[:n]) for k in
               ("omega", "modal_mass", "modal_stiffness", "load", "opening", "tip", "wbar", "theta")}
        return replace(self, kinds=tuple(self.kinds[:n]), **cut)

    def static_coordinates(self, dp: float, n: int | None = None) -> np.ndarray:
        """q_i = Gamma_i dP / k_i [m]: the modal coordinates under a pressure difference dP [Pa] on the footprint."""
        n = self.n_modes if n is None else int(n)
        return self.load[:n] * dp / self.modal_stiffness[:n]

    def static_deflection(self, dp: float, n: int | None = None) -> tuple[float, float]:
        """(tip deflection, opening x) [m] under dP [Pa] on the footprint with the first n modes:
        sum_i Gamma_i dP / k_i phi_i(tip) and sum_i Gamma_i dP / k_i c_i."""
        q = self.static_coordinates(dp, n)
        return float(q @ self.tip[:len(q)]), float(q @ self.opening[:len(q)])

    def free_response(self, q0, t, qdot0=None) -> np.ndarray:
        """q(t) [m], shape (len(t), N), of the free undamped reed: q_i0 cos(w_i t) + qdot_i0 / w_i sin(w_i t)."""
        q0 = np.asarray(q0, dtype=float)
        v0 = np.zeros_like(q0) if qdot0 is None else np.asarray(qdot0, dtype=float)
        wt = np.outer(np.asarray(t, dtype=float), self.omega[:len(q0)])
        return q0 * np.cos(wt) + v0 / self.omega[:len(q0)] * np.sin(wt)

    def added_mass(self, rho: float, gamma_f: float = 1.0, gamma_t: float = 1.0) -> np.ndarray:
        """Strip-theory added mass matrix M_a [kg] of the modes in a fluid of density rho [kg/m^3].

        M_a,ij = rho pi/4 Gamma_f int wbar_i wbar_j W^2 ds + rho pi/128 Gamma_t int theta_i theta_j W^4 ds:
        each strip of width W translating with wbar carries the potential-flow mass of a
        circular cylinder of diameter W (eq 3.17, Sader 1998; Gamma_f the flexural
        hydrodynamic function, eq 3.13, 1 in the inviscid slender limit), and rotating with
        theta the added moment of inertia pi rho W^4 / 128 of a flat plate (Green & Sader
        2002, Gamma_t = 1 its inviscid limit). With one mode, Gamma_t = 0 and tip
        normalisation it is eq 3.21's gamma3 rho W_2 pi/4 Gamma_f int psi^2 W ds.
        """
        w2 = self.weights * self.widths**2
        bend = (self.wbar * w2) @ self.wbar.T
        tors = (self.theta * w2 * self.widths**2) @ self.theta.T
        return rho * (np.pi / 4 * gamma_f * bend + np.pi / 128 * gamma_t * tors)


def _opening_mode(tip) -> int:
    """Index of the mode that scales the opening: the lowest whose tip-centre value is at least half
    its largest |w| (``tip`` of shapes normalised to max |w| = 1): the first bending mode, not a
    torsion mode (0 at the tip centre of a symmetric reed) even if that one is lower."""
    big = np.nonzero(np.abs(np.asarray(tip)) >= 0.5)[0]
    return int(big[0]) if big.size else 0


@dataclass(frozen=True)
class Sampling:
    """How a fidelity's shapes are sampled on the face: ``plane`` (they vary across the width: plate, solid;
    else one point across suffices), ``breaks`` (extra s [m] where they are not smooth: FE nodes)."""

    plane: bool = False
    breaks: object = None


@dataclass(frozen=True)
class Modes:
    """A fidelity's modes as it computed them: ``omega`` [rad/s], ``kinds`` (names), raw modal masses
    int rho_c h phi^2 dA [kg], ``evaluate(s, y) -> (len(s), N)`` the raw shapes at face points [m], and
    ``raw_load`` [m^2], Gamma of the raw shapes when the fidelity integrates it itself (an FE model's
    consistent load vector f . phi; None: the face rule), ``mesh_size`` [m] and ``dofs`` of its model."""

    omega: object
    kinds: tuple
    raw_mass: object
    evaluate: Callable
    raw_load: object = None
    mesh_size: float | None = None
    dofs: int | None = None


def build_basis(reed: Reed, port: ReedPort | None, fidelity: str, modes: Modes,
                sampling: Sampling = Sampling()) -> ModalBasis:
    """A :class:`ModalBasis` from a fidelity's :class:`Modes`: the modal mass, stiffness, load, opening and strips
    of eqs 3.8-3.21 generalised to several modes.

    Each shape normalised to max |phi| = 1 on the face grid (positive there); Gamma_i = int_F phi_i dA (unless
    ``modes.raw_load``), the edge mean and the strips by geometry.reed_port's rules; the opening scaled to the
    first bending mode.

    Parameters
    ----------
    reed, port : geometry.Reed, geometry.reed_port.ReedPort or None
        The reed and its loaded footprint (None: the whole face, eq 3.21).
    fidelity : str
        Names the basis.
    modes : Modes
        The fidelity's frequencies [rad/s], raw modal masses [kg] and shape evaluator.
    sampling : Sampling
        Plane (Gauss points across the width) or not; the breakpoints.

    Returns
    -------
    ModalBasis
        Modal mass [kg], stiffness [N/m], load Gamma [m^2], opening and tip weights [-], strips (eqs 3.8-3.21,
        docs/reed_dynamics.md).
    """
    omega, kinds, raw_mass, evaluate = modes.omega, modes.kinds, modes.raw_mass, modes.evaluate
    plane, breaks, raw_load = sampling.plane, sampling.breaks, modes.raw_load
    omega = np.asarray(omega, dtype=float)
    n = len(omega)
    gs, gy = face_grid(reed)
    G = evaluate(gs, gy)
    peak = G[np.argmax(np.abs(G), axis=0), np.arange(n)]
    scale = 1.0 / peak
    mass = np.asarray(raw_mass, dtype=float) * scale**2
    if raw_load is None:
        S, Y, wt = face_rule(reed, port, n_y=12 if plane else 1, breaks=breaks)
        load = wt @ evaluate(S, Y) * scale
    else:
        load = np.asarray(raw_load, dtype=float) * scale
    L = reed.length
    tip = evaluate(np.array([L]), np.array([0.0]))[0] * scale
    if port is None:
        opening = tip.copy()
    else:
        es, ey, ew = edge_rule(reed, port)
        edge = ew @ evaluate(es, ey) * scale / ew.sum()
        b = _opening_mode(tip)
        opening = edge / edge[b] * tip[b]
    sk, wk, Wk = station_rule(reed, N_STATIONS)
    eta, we = np.polynomial.legendre.leggauss(N_ACROSS if plane else 1)
    V = evaluate(np.repeat(sk, len(eta)), (eta[None, :] * Wk[:, None] / 2).ravel()) * scale
    V = V.reshape(len(sk), len(eta), n)
    wbar = np.einsum("j,kji->ik", we / 2, V)
    theta = np.einsum("j,kji->ik", 1.5 * we * eta, V) * 2 / Wk            # 12/W^3 int w y dy
    return ModalBasis(fidelity=fidelity, omega=_frozen(omega), modal_mass=_frozen(mass),
                      modal_stiffness=_frozen(mass * omega**2), load=_frozen(load), opening=_frozen(opening),
                      tip=_frozen(tip), kinds=tuple(kinds), stations=_frozen(sk), weights=_frozen(wk),
                      widths=_frozen(Wk), wbar=_frozen(wbar), theta=_frozen(theta), port=port,
                      mesh_size=modes.mesh_size, dofs=modes.dofs)


# ------------------------------------------------------------------------------ exact E-B
def analytic_basis(reed: Reed, port: ReedPort | None = None, mesh_size=None, n_modes: int = MAX_MODES) -> ModalBasis:
    """The ``analytic`` modal basis: the first bending modes of exact Euler-Bernoulli theory, (EI(s) w'')'' =
    omega^2 m(s) w, clamped-free (eq 3.8 in vacuum, no damping).

    Piecewise-uniform reeds: roots of the exact transfer-matrix determinant (Naguleswaran 2002) and the exact
    segment shapes (lumped.reed.euler_bernoulli.cantilever_mode_shape); others (rounded tips, grooves, tapers): w =
    omega^2 G[m w] on the spectral quadrature (lumped.reed.euler_bernoulli.BeamModel). Modal masses int m phi^2 ds
    by that quadrature. Bending only: w does not vary across the width.

    Parameters
    ----------
    reed, port
        As :func:`build_basis`.
    mesh_size : float or None
        Ignored (no mesh).
    n_modes : int
        Modes to find.

    Returns
    -------
    ModalBasis
        As :func:`build_basis`.

    References
    ----------
    Knutson (2016), eq 3.8, Table 3.3 (:func:`modal_basis`'s example); Naguleswaran (2002).
    """
    from .quadrature import NODES_PER_PIECE, ProfileQuadrature, profile_breaks
    from .euler_bernoulli import BeamModel, cantilever_frequencies, cantilever_mode_shape, stepped_segments

    n = int(n_modes)
    nodes = max(NODES_PER_PIECE, 10 * n)   # mode 6 of a uniform reed: int phi^2 to 1e-8
    if reed.is_piecewise_uniform:
        segs = stepped_segments(reed)
        omega = cantilever_frequencies(segs, n)

        def shapes(s):
            u, inv = np.unique(np.clip(s, 0.0, reed.length), return_inverse=True)
            return np.column_stack([cantilever_mode_shape(segs, w, u) for w in omega])[inv]

        quad = ProfileQuadrature(profile_breaks(reed), nodes)
        m = reed.mass_per_length(quad.s)
        raw = quad.weights @ (m[:, None] * shapes(quad.s) ** 2)
    else:
        from scipy.sparse.linalg import eigs

        bm = BeamModel.of(reed, nodes)
        # the n largest 1 / omega^2 of G diag(m) (ARPACK; a dense eig of every mode costs 50x more)
        A = bm.flexibility() * bm.m[None, :]
        vals, vecs = eigs(A, k=n, which="LM", v0=np.ones(len(A)), tol=1e-14)
        order = np.argsort(-vals.real)[:n]
        omega = 1.0 / np.sqrt(vals.real[order])
        slopes = np.column_stack([bm.slope(bm.m * vecs[:, k].real) for k in order])

        def shapes(s):
            return bm.quad.forward_at(np.clip(s, 0.0, reed.length)) @ slopes

        raw = bm.quad.weights @ (bm.m[:, None] * (bm.quad.Q @ slopes) ** 2)
    labels = [f"bending {k + 1}" for k in range(n)]
    return build_basis(reed, port, "analytic", Modes(omega, labels, raw, lambda s, y: shapes(np.asarray(s, float))))


# ------------------------------------------------------------------------------ the FE reed
@dataclass(frozen=True, eq=False)
class FEReed:
    """The whole finite-element reed, clamped DOFs removed (SI units; n = n_dof).

    mass, stiffness (n, n) [kg, N/m] dense; load (n,) f_j = int_F N_j dA [m^2], the
    consistent nodal forces of a unit pressure on the footprint F; opening (n,) c with
    x = c . u [m] (the modal basis's opening functional: the mean lift over F's outline
    scaled to the first bending mode's tip); tip (n,) with w(L, 0) = tip . u; stations (K,),
    weights (K,), widths (K,) as in :class:`ModalBasis` and wbar (K, n), theta (K, n)
    giving the width-mean deflection and twist there (wbar @ u). ``dof_units`` says what
    the DOFs are (every DOF is in metres, derivatives scaled by an element length).
    """

    fidelity: str
    mass: np.ndarray
    stiffness: np.ndarray
    load: np.ndarray
    opening: np.ndarray
    tip: np.ndarray
    stations: np.ndarray
    weights: np.ndarray
    widths: np.ndarray
    wbar: np.ndarray
    theta: np.ndarray
    port: ReedPort | None = None
    mesh_size: float | None = None
    dof_units: str = ""

    @property
    def n_dof(self) -> int:
        return len(self.load)

    def static_displacement(self, dp: float) -> np.ndarray:
        """u = K^-1 f dP [DOF units] under a pressure difference dP [Pa] on the footprint."""
        return np.linalg.solve(self.stiffness, self.load * dp)

    def static_deflection(self, dp: float) -> tuple[float, float]:
        """(tip deflection, opening x) [m] of the static FE solution under dP [Pa] on the footprint."""
        u = self.static_displacement(dp)
        return float(self.tip @ u), float(self.opening @ u)

    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """All natural frequencies [rad/s] ascending and mass-normalised mode vectors (columns), dense eigh."""
        return _dense_modes(self.mass, self.stiffness)

    def free_response(self, u0, t, udot0=None) -> np.ndarray:
        """u(t), shape (len(t), n), of the free undamped FE reed by exact superposition of all its modes."""
        omega, P = self.modes()
        a = P.T @ (self.mass @ np.asarray(u0, dtype=float))
        b = np.zeros_like(a) if udot0 is None else P.T @ (self.mass @ np.asarray(udot0, dtype=float)) / omega
        wt = np.outer(np.asarray(t, dtype=float), omega)
        return (a * np.cos(wt) + b * np.sin(wt)) @ P.T


def _dense_modes(mass, stiffness, n: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The lowest n (default all) omega [rad/s] and mass-normalised modes of K phi = omega^2 M phi.

    Solved as M phi = mu K phi, mu = 1 / omega^2 (scipy eigh, Cholesky of K): the largest mu,
    the low modes, come out to round-off relative to themselves; eigh(K, M) would give the
    lowest omega^2 only to round-off relative to the highest (1e-5 on a plate of 2500 DOFs).
    """
    from scipy.linalg import eigh

    k = len(mass) if n is None else int(n)
    mu, vecs = eigh(mass, stiffness, subset_by_index=[len(mass) - k, len(mass) - 1])
    mu, vecs = mu[::-1], vecs[:, ::-1]
    omega = 1.0 / np.sqrt(mu)
    return omega, vecs * omega       # K-normalised phi^T K phi = 1 -> M-normalised


@dataclass(frozen=True, eq=False)
class FESystem:
    """A fidelity's whole FE reed as it assembled it: dense ``mass``, ``stiffness`` [kg, N/m] on the free DOFs,
    ``probe(s, y) -> (len(s), n)`` the interpolation of the DOFs to w at face points, ``load`` [m^2] if the FE
    model assembles the footprint's load itself (None: the face rule), ``mesh_size`` [m], ``dof_units``."""

    mass: np.ndarray
    stiffness: np.ndarray
    probe: Callable
    load: np.ndarray | None = None
    mesh_size: float | None = None
    dof_units: str = ""


def fe_reed_from(reed: Reed, port: ReedPort | None, fidelity: str, system: FESystem,
                 sampling: Sampling = Sampling()) -> FEReed:
    """An :class:`FEReed` from a fidelity's :class:`FESystem`, the load (unless the FE model assembles it), opening,
    tip and station rows built with the rules of :func:`build_basis`.

    Parameters
    ----------
    reed : geometry.Reed
        The reed.
    port : geometry.reed_port.ReedPort or None
        The loaded footprint; None: the whole face (eq 3.21).
    fidelity : str
        Names the FE reed.
    system : FESystem
        Mass [kg] and stiffness [N/m] matrices, a probe of the nodal deflection, the load (or None).
    sampling : Sampling
        As :func:`build_basis`.

    Returns
    -------
    FEReed
        M, K, f [m^2], opening and tip rows [-], strips.

    References
    ----------
    docs/reed_dynamics.md.
    """
    mass, stiffness, probe, load = system.mass, system.stiffness, system.probe, system.load
    plane, breaks = sampling.plane, sampling.breaks
    if load is None:
        S, Y, wt = face_rule(reed, port, n_y=12 if plane else 1, breaks=breaks)
        load = wt @ probe(S, Y)
    L = reed.length
    tip = probe(np.array([L]), np.array([0.0]))[0]
    if port is None:
        opening = tip.copy()
    else:
        # x = <w>_edge phi_1(tip) / <phi_1>_edge, phi_1 this reed's first bending mode
        es, ey, ew = edge_rule(reed, port)
        edge = ew @ probe(es, ey) / ew.sum()
        _, V = _dense_modes(mass, stiffness, min(4, len(mass)))
        V = V / np.abs(probe(*face_grid(reed)) @ V).max(axis=0)
        v1 = V[:, _opening_mode(tip @ V)]
        opening = edge * float(tip @ v1) / float(edge @ v1)
    sk, wk, Wk = station_rule(reed, N_STATIONS)
    eta, we = np.polynomial.legendre.leggauss(N_ACROSS if plane else 1)
    P = probe(np.repeat(sk, len(eta)), (eta[None, :] * Wk[:, None] / 2).ravel()).reshape(len(sk), len(eta), -1)
    wbar = np.einsum("j,kjd->kd", we / 2, P)
    theta = np.einsum("j,kjd->kd", 1.5 * we * eta, P) * (2 / Wk)[:, None]
    return FEReed(fidelity=fidelity, mass=_frozen(mass), stiffness=_frozen(stiffness), load=_frozen(load),
                  opening=_frozen(opening), tip=_frozen(tip), stations=_frozen(sk), weights=_frozen(wk),
                  widths=_frozen(Wk), wbar=_frozen(wbar), theta=_frozen(theta), port=port,
                  mesh_size=system.mesh_size, dof_units=system.dof_units)


# ------------------------------------------------------------------------------ registries
#: fidelity -> f(reed, port=None, mesh_size=None, n_modes=MAX_MODES) -> ModalBasis
FIDELITIES: dict[str, Callable] = {"analytic": analytic_basis}
#: fidelity -> f(reed, port=None, mesh_size=None) -> FEReed
FE_FIDELITIES: dict[str, Callable] = {}
_loaded = {"entry_points": False}


def register(name: str, func: Callable) -> None:
    """Add (or replace) a modal-basis fidelity.

    Parameters
    ----------
    name : str
        The fidelity's name.
    func : callable
        ``f(reed, port=None, mesh_size=None, n_modes=MAX_MODES) -> ModalBasis``.

    Returns
    -------
    None
    """
    FIDELITIES[name] = func
    _cached_basis.cache_clear()


def register_fe(name: str, func: Callable) -> None:
    """Add (or replace) an FE-reed fidelity.

    Parameters
    ----------
    name : str
        The fidelity's name.
    func : callable
        ``f(reed, port=None, mesh_size=None) -> FEReed``.

    Returns
    -------
    None
    """
    FE_FIDELITIES[name] = func
    _cached_fe.cache_clear()


def _load_plugins() -> None:
    if not _loaded["entry_points"]:
        _loaded["entry_points"] = True
        for name, func in plugins.entry_points(GROUP).items():
            FIDELITIES.setdefault(name, func)
        for name, func in plugins.entry_points(FE_GROUP).items():
            FE_FIDELITIES.setdefault(name, func)


def _ordered(names) -> list[str]:
    return [n for n in ORDER if n in names] + sorted(n for n in names if n not in ORDER)


def names() -> list[str]:
    """Every fidelity that gives a modal basis, cheapest first.

    Returns
    -------
    list of str
    """
    _load_plugins()
    return _ordered(FIDELITIES)


def fe_names() -> list[str]:
    """Every fidelity that gives a whole FE reed.

    Returns
    -------
    list of str
    """
    _load_plugins()
    return _ordered(FE_FIDELITIES)


def check_modes(n_modes, field: str = "modes") -> int:
    """``n_modes`` as an int 1..MAX_MODES, else an InputError naming ``field``.

    Parameters
    ----------
    n_modes : int or str
        What the user wrote.
    field : str
        The key it came from.

    Returns
    -------
    int
    """
    return int(validate.number(n_modes, field, bounds=(1, MAX_MODES), integer=True))


@functools.lru_cache(maxsize=32)
def _cached_basis(reed: Reed, fidelity: str, port: ReedPort | None, mesh_size: float | None) -> ModalBasis:
    return FIDELITIES[fidelity](reed, port=port, mesh_size=mesh_size, n_modes=MAX_MODES)


@functools.lru_cache(maxsize=8)
def _cached_fe(reed: Reed, fidelity: str, port: ReedPort | None, mesh_size: float | None) -> FEReed:
    return FE_FIDELITIES[fidelity](reed, port=port, mesh_size=mesh_size)


def _checked(reed: Reed, port, mesh_size, port_field: str):
    from geometry.reed_io import check_reed

    check_reed(reed)
    check_port(port, reed, port_field)
    if mesh_size is not None:
        mesh_size = float(validate.number(mesh_size, "--mesh-size", unit="m", positive=True))
    return mesh_size


def modal_basis(reed: Reed, fidelity: str = "analytic", n_modes: int = 1, port: ReedPort | None = None,
                mesh_size: float | None = None, *, field: str = "modes", fidelity_field: str = "fidelity",
                port_field: str = "port") -> ModalBasis:
    """The first ``n_modes`` modes of ``reed`` by ``fidelity`` with their modal quantities (a ModalBasis).

    Parameters
    ----------
    reed : geometry.Reed
    fidelity : str
        ``analytic`` (exact Euler-Bernoulli) or ``beam`` (bending only), ``plate`` or ``solid``
        (bending and torsion).
    n_modes : int
        1..6; more than the fidelity's eigen solve returned is an InputError naming ``field``.
    port : geometry.reed_port.ReedPort, optional
        The loaded footprint; None: the whole face (eq 3.21). Checked against the reed
        (errors name ``port_field.<key>``).
    mesh_size : float, optional
        FE element size [m]; None: the fidelity's default.

    Returns
    -------
    ModalBasis
        Cached per (reed, fidelity, port, mesh_size): the six-mode basis is solved once
        and truncated.

    References
    ----------
    Knutson (2016), eqs 3.8-3.21 and Table 3.4 (the one-mode reduction this generalises).

    Examples
    --------
    >>> from geometry import load_reed
    >>> b = modal_basis(load_reed("uniform"), "analytic", 2)
    >>> print(f"{b.omega[0]:.0f} rad/s, {b.kinds}")      # Table 3.3: exact E-B 3046 rad/s
    3046 rad/s, ('bending 1', 'bending 2')
    """
    n = check_modes(n_modes, field)
    _load_plugins()
    if fidelity not in FIDELITIES:
        raise InputError(fidelity_field, f"expected one of {', '.join(names())}, got {fidelity!r}")
    mesh_size = _checked(reed, port, mesh_size, port_field)
    full = _cached_basis(reed, fidelity, port, mesh_size)
    if full.n_modes < n:
        raise InputError(field, f"{n} modes asked but the {fidelity} eigen solve gave {full.n_modes} "
                         f"({', '.join(full.kinds)}); ask at most {full.n_modes}")
    return full if n == full.n_modes else full.truncated(n)


def fe_reed(reed: Reed, port: ReedPort | None = None, fidelity: str = "beam", mesh_size: float | None = None,
            *, fidelity_field: str = "fidelity", port_field: str = "port") -> FEReed:
    """The whole FE reed of ``fidelity`` (``beam``; ``plate`` where registered) with the load of ``port``.

    Parameters
    ----------
    reed : geometry.Reed
        The reed.
    port : geometry.reed_port.ReedPort or None
        The loaded footprint; None: the whole face (eq 3.21).
    fidelity : str
        An FE fidelity; unknown: InputError naming ``fidelity_field``.
    mesh_size : float or None
        Element size [m]; None: the fidelity's default.
    fidelity_field, port_field : str
        The keys errors name (a port off the reed names ``port_field.<key>``).

    Returns
    -------
    FEReed
        Cached per (reed, fidelity, port, mesh_size).
    """
    _load_plugins()
    if fidelity not in FE_FIDELITIES:
        raise InputError(fidelity_field, f"the whole FE reed exists for {', '.join(fe_names()) or 'no fidelity'}"
                         f", got {fidelity!r}")
    mesh_size = _checked(reed, port, mesh_size, port_field)
    return _cached_fe(reed, fidelity, port, mesh_size)


# ------------------------------------------------------------------------------ checks
def static_convergence(basis: ModalBasis, fe: FEReed, dp: float = 1.0) -> dict:
    """The modal static deflection with N = 1..basis.n_modes modes against the FE reed's K^-1 f dP.

    Parameters
    ----------
    basis : ModalBasis
    fe : FEReed
    dp : float
        Pressure on the footprint [Pa].

    Returns
    -------
    dict
        {"fe": {"tip", "opening"} [m], "rows": [{"modes", "tip", "opening" [m], "tip_error", "opening_error"
        (relative to the FE values)}]}.
    """
    tip_fe, x_fe = fe.static_deflection(dp)
    rows = []
    for n in range(1, basis.n_modes + 1):
        tip, x = basis.static_deflection(dp, n)
        rows.append({"modes": n, "tip": tip, "opening": x, "tip_error": tip / tip_fe - 1.0,
                     "opening_error": x / x_fe - 1.0})
    return {"fe": {"tip": tip_fe, "opening": x_fe}, "rows": rows}


def release_errors(basis: ModalBasis, fe: FEReed, periods: float = 20.0, samples_per_period: int = 2000,
                   dp: float = 1.0) -> dict:
    """The free reed released from rest at its static deflection under dP on the footprint: tip and opening
    histories of the N-mode model (N = 1..basis.n_modes) against the whole FE reed.

    The FE reed starts from u0 = K^-1 f dP and moves by exact superposition of all its modes; the N-mode model from
    its own static deflection q_i = Gamma_i dP / k_i (no damping, no flow, no contact).

    Parameters
    ----------
    basis : ModalBasis
    fe : FEReed
    periods : float
        Span, in periods of mode 1.
    samples_per_period : int
    dp : float
        Pressure on the footprint [Pa].

    Returns
    -------
    dict
        Per N the largest difference of the tip and the opening relative to the FE amplitude (max |.| of the FE
        history), and ``bound``: the sum over the FE modes the N-mode model lacks of |a_j tip . phi_j| / amplitude
        when the basis is the FE reed's own modes (same fidelity and mesh; None otherwise), the largest the tip
        error can get.
    """
    t = np.linspace(0.0, periods * 2 * np.pi / basis.omega[0], int(periods * samples_per_period) + 1)
    omega, P = fe.modes()
    a = P.T @ (fe.mass @ fe.static_displacement(dp))          # modal amplitudes of u0
    tips, xs = P.T @ fe.tip, P.T @ fe.opening                 # each FE mode's tip and opening
    fe_tip = np.zeros(len(t))
    fe_x = np.zeros(len(t))
    for c0 in range(0, len(t), 4000):                         # chunks bound the memory
        cw = np.cos(np.outer(t[c0:c0 + 4000], omega))
        fe_tip[c0:c0 + 4000] = cw @ (a * tips)
        fe_x[c0:c0 + 4000] = cw @ (a * xs)
    amp_tip, amp_x = np.abs(fe_tip).max(), np.abs(fe_x).max()
    same = fe.fidelity == basis.fidelity and fe.mesh_size == basis.mesh_size
    order = np.argsort(omega)
    rows = []
    for n in range(1, basis.n_modes + 1):
        q = basis.free_response(basis.static_coordinates(dp, n), t)
        e_tip = np.abs(q @ basis.tip[:n] - fe_tip).max() / amp_tip
        e_x = np.abs(q @ basis.opening[:n] - fe_x).max() / amp_x
        bound = float(np.abs(a * tips)[order[n:]].sum() / amp_tip) if same else None
        rows.append({"modes": n, "tip_error": float(e_tip), "opening_error": float(e_x), "bound": bound})
    return {"periods": periods, "amplitude_tip": float(amp_tip), "amplitude_opening": float(amp_x),
            "fe_dofs": fe.n_dof, "rows": rows}
