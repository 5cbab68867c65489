"""Euler-Bernoulli beam reed with Hermite elements (scikit-fem ``ElementLineHermite``).

The same theory as the analytic model (thesis eq 3.8 without damping and fluid):
(EI(s) v'')'' + m(s) v_tt = q(s), clamped at s = 0 (v = v' = 0), free at s = L.
EI(s) and m(s) = rho A(s) come from the exact outline and section of
:meth:`geometry.Reed.section` (grooves as a reduced section, neutral axis shifted);
the uniform pressure gives q(s) = p W(s) (eq 3.30 with X = 1). Only bending exists.
Default element length L / 200 (any reed size).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla
from skfem import Basis, BilinearForm, ElementLineHermite, LinearForm, asm, condense, solve as fem_solve

from geometry.reed import Reed

from .mesh import check_size, line_mesh
from .modes import ModalResult, ModeShapes, bending_labels, fidelity_functions
from .resources import beam_bytes, check_memory

#: default elements per reed length; Hermite cubics converge as h^4: L/200 is exact to ~1e-9
ELEMENTS_PER_LENGTH = 200
#: the default element length [m] of the 1 in thesis reeds (kept for reference)
DEFAULT_MESH_SIZE = 25.4e-3 / ELEMENTS_PER_LENGTH
#: Gauss order: high, because W(s) of a rounded tip has a square-root end
INTORDER = 10
N_SHAPE = 801


def default_mesh_size(reed: Reed) -> float:
    """The beam's default element length: L / 200 (0.127 mm on the 1 in thesis reeds).

    Parameters
    ----------
    reed : geometry.Reed
        The reed.

    Returns
    -------
    float
        [m].
    """
    return float(f"{reed.length / ELEMENTS_PER_LENGTH:.6g}")


def estimate(reed: Reed, mesh_size: float) -> tuple[int, float]:
    """The beam's DOFs and peak memory with elements of at most ``mesh_size`` (2 DOFs per node).

    Parameters
    ----------
    reed : geometry.Reed
        The reed.
    mesh_size : float
        Element size [m].

    Returns
    -------
    (dofs, bytes) : tuple of (int, float)
    """
    n = sum(max(1, int(np.ceil((b - a) / mesh_size - 1e-9)))
            for a, b in zip(reed.breakpoints()[:-1], reed.breakpoints()[1:]) if b - a >= 1e-12)
    return 2 * n, beam_bytes(2 * n)


@dataclass
class BeamResult(ModalResult):
    """The beam's modal result (every mode is a bending mode: bending_index = 0) and its mode shapes."""

    shapes: np.ndarray = None    # w of each mode at ``s``, columns


@BilinearForm
def _stiffness(u, v, w):
    return w.EI * u.hess[0, 0] * v.hess[0, 0]


@BilinearForm
def _mass(u, v, w):
    return w.m * u * v


@LinearForm
def _load(v, w):
    return w.q * v


@dataclass
class BeamSystem:
    """The assembled Hermite beam of a reed, in units of the element length ``ell`` [m].

    ``K``, ``M``, ``f`` (full, sparse / dense) are assembled on the mesh scaled by 1/ell, so
    the true stiffness is K / ell^3 [N/m], mass M ell [kg] and uniform-pressure load f ell
    [m^2]; the DOFs are, at each node, w [m] and ell w' [m] (both in metres: well scaled).
    ``free`` are the DOFs left after clamping w = w' = 0 at s = 0.
    """

    basis: Basis
    ell: float
    K: object
    M: object
    f: np.ndarray
    free: np.ndarray
    clamped: np.ndarray
    mesh_size: float

    def probe(self, s) -> np.ndarray:
        """Dense (len(s), len(free)) matrix giving w [m] at stations s [m] from the free DOFs."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.basis.mesh.p.max() * self.ell * (1 - 1e-14))
        return self.basis.probes(s[None, :] / self.ell).tocsc()[:, self.free].toarray()

    def dense(self) -> tuple[np.ndarray, np.ndarray]:
        """(M [kg], K [N/m]) on the free DOFs, dense, in true units."""
        M = self.M[self.free][:, self.free].toarray() * self.ell
        K = self.K[self.free][:, self.free].toarray() / self.ell**3
        return M, K

    def nodes(self) -> np.ndarray:
        """The mesh nodes s [m] (where the Hermite shapes join)."""
        return np.sort(self.basis.mesh.p[0]) * self.ell


def assemble(reed: Reed, mesh_size: float | None = None) -> BeamSystem:
    """Stiffness, mass and uniform-pressure load of the Euler-Bernoulli beam (Hermite cubics, eq 3.8 without damping
    and fluid).

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    mesh_size : float, optional
        Element size [m]; None: the fidelity's default for this reed.

    Returns
    -------
    system
        K [N/m], M [kg] and the load of a unit pressure (SI), with its probes and free DOFs.

    Notes
    -----
    Elements of at most ``mesh_size`` [m] (default L/200) with nodes on every breakpoint;
    EI(s), rho A(s) and W(s) of the exact profile at Gauss points of order INTORDER. DOFs
    and memory are checked first.

    References
    ----------
    Knutson (2016), eq 3.8, section 3.2; scikit-fem.
    """
    h = default_mesh_size(reed) if mesh_size is None else float(mesh_size)
    check_size(reed, h)
    check_memory("beam model", *estimate(reed, h))
    mesh = line_mesh(reed, h)
    # Hermite DOFs are w and w': in metres their scales differ by the element length and
    # round-off is amplified ~(L/h)^4; assemble in units of the element length ell instead:
    # K = K'/ell^3, M = M' ell, f = f' ell, so omega^2 = lambda'/ell^4 and w = ell^4 K'^-1 f'.
    ell = h
    basis = Basis(type(mesh)(mesh.p / ell, mesh.t), ElementLineHermite(), intorder=INTORDER)
    x = np.asarray(basis.global_coordinates())[0] * ell
    A, I2 = reed.section(x.ravel())
    EI = reed.material.youngs_modulus * I2.reshape(x.shape)
    m = reed.material.density * A.reshape(x.shape)
    q = np.asarray(reed.width(x.ravel()), dtype=float).reshape(x.shape)  # p = 1 Pa
    K = asm(_stiffness, basis, EI=EI)
    M = asm(_mass, basis, m=m)
    f = asm(_load, basis, q=q)
    D = basis.get_dofs(lambda x: x[0] < 1e-12).all()
    free = np.setdiff1d(np.arange(K.shape[0]), D)
    return BeamSystem(basis=basis, ell=ell, K=K, M=M, f=f, free=free, clamped=D, mesh_size=h)


def _eigen(sys: BeamSystem, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Lowest omega^2 [rad^2/s^2] and the free-DOF mode vectors (M'-normalised) by shift-invert ARPACK."""
    Kc, Mc, _, I = condense(sys.K, sys.M, D=sys.clamped)
    k = min(int(n_modes), len(I) - 2)
    vals, vecs = spla.eigsh(Kc.tocsc(), k=k, M=Mc.tocsc(), sigma=0.0, which="LM",
                            v0=np.ones(Kc.shape[0]))  # a fixed start: reproducible results
    order = np.argsort(vals)
    return vals[order] / sys.ell**4, vecs[:, order]


def solve(reed: Reed, mesh_size: float | None = None, n_modes: int = 4) -> BeamResult:
    """The modes, the uniform-load stiffness kappa = p / w(L) and the centre-line shapes of the Euler-Bernoulli beam
    (Hermite cubics, eq 3.8 without damping and fluid).

    EI(s), rho A(s) of any profile (steps, tapers, thickness steps, grooves) from geometry.Reed.section. The DOFs
    and memory are estimated first: an InputError naming --mesh-size where they exceed what the machine has
    (fea.resources).

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    mesh_size : float, optional
        Element size [m]; None: the fidelity's default for this reed.
    n_modes : int
        Modes wanted.

    Returns
    -------
    result
        omega [rad/s] of the modes (named), kappa [Pa/m], the static and first-mode shapes psi(s) (psi(L) = 1), DOFs
        and mesh size.

    References
    ----------
    Knutson (2016), eqs 3.8, 3.30, section 3.5.
    """
    sys = assemble(reed, mesh_size)
    basis, ell, K, I = sys.basis, sys.ell, sys.K, sys.free
    u = fem_solve(*condense(K, sys.f, D=sys.clamped)) * ell**4
    vals, vecs = _eigen(sys, n_modes)
    k = len(vals)
    s = np.linspace(0.0, reed.length, N_SHAPE)
    P = basis.probes(np.clip(s, 0.0, reed.length * (1 - 1e-14))[None, :] / ell)
    w = P @ u
    full = np.zeros((K.shape[0], k))
    full[I] = vecs
    shapes = P @ full                      # (N_SHAPE, k) mode shapes on s
    phi = shapes[:, 0]
    tip = basis.get_dofs(lambda x: np.abs(x[0] - reed.length / ell) < 1e-9).nodal["u"][0]
    kappa = 1.0 / u[tip]
    return BeamResult(
        omega=np.sqrt(vals), kinds=["bending"] * k, bending_index=0, kappa=kappa, s=s,
        psi_static=w / w[-1], psi_mode=phi / phi[-1], dofs=len(I), mesh_size=sys.mesh_size,
        labels=bending_labels(k), shapes=shapes,
    )


#: the fidelity's functions (fea.fidelities): properties, the first n bending modes (labelled bending 1..n), both
reed_properties, modes, properties_and_modes = fidelity_functions("beam", solve, __name__)


def mode_shapes(result: BeamResult, reed: Reed, n: int | None = None) -> ModeShapes:
    """w(s) of the first n modes (each max |w| = 1) for plots; y = 0.

    Parameters
    ----------
    result : BeamResult
    reed : geometry.Reed
        The reed.
    n : int, optional
        Modes; None: all solved.

    Returns
    -------
    fea.modes.ModeShapes
    """
    n = result.shapes.shape[1] if n is None else min(n, result.shapes.shape[1])
    w = result.shapes[:, :n].T / np.max(np.abs(result.shapes[:, :n]), axis=0)[:, None]
    return ModeShapes(s=result.s, y=np.zeros((len(result.s), 1)), w=w[:, :, None],
                      omega=result.omega[:n], labels=result.labels[:n], fidelity="beam")


def write_modes_vtu(result: BeamResult, reed: Reed, path) -> None:
    """Write the line s in [0, L] with each mode's w (max |w| = 1) as point data (VTU).

    Parameters
    ----------
    result : BeamResult
    reed : geometry.Reed
        The reed.
    path : str or Path

    Returns
    -------
    None
    """
    import meshio

    pts = np.column_stack([result.s, 0 * result.s, 0 * result.s])
    cells = [("line", np.column_stack([np.arange(len(result.s) - 1), np.arange(1, len(result.s))]))]
    data = {f"mode{k + 1}_{lab.replace(' ', '_')}_{w:.0f}rad_s": result.shapes[:, k] / np.abs(result.shapes[:, k]).max()
            for k, (lab, w) in enumerate(zip(result.labels, result.omega))}
    meshio.write(str(path), meshio.Mesh(pts, cells, point_data=data), file_format="vtu")


# -- the modal reed and the whole FE reed (lumped.reed.modal_basis) ---------------------------------
#: default elements per reed length of the whole FE reed: about 50-60 DOFs (2 per node),
#: mode 6 within ~1e-4 of exact E-B on the thesis reeds (docs/reed_dynamics.md)
FE_ELEMENTS_PER_LENGTH = 24


def default_fe_mesh_size(reed: Reed) -> float:
    """The whole FE reed's default element length: L / 24 (plus nodes at every breakpoint).

    Parameters
    ----------
    reed : geometry.Reed
        The reed.

    Returns
    -------
    float
        [m].
    """
    return float(f"{reed.length / FE_ELEMENTS_PER_LENGTH:.6g}")


def modal_basis(reed: Reed, port=None, mesh_size: float | None = None, n_modes: int = 6):
    """The ``beam`` fidelity's modal basis for the modal reed valve: the first modes of the Euler-Bernoulli beam
    (Hermite cubics, eq 3.8 without damping and fluid) with their modal masses, loads, openings and station values.

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    port : geometry.reed_port.ReedPort, optional
        The port's footprint on the face (None: the whole face, eq 3.21's load).
    mesh_size : float, optional
        Element size [m]; None: the fidelity's default for this reed.
    n_modes : int
        Modes wanted.

    Returns
    -------
    lumped.reed.modal_basis.ModalBasis
        (SI units; lumped.reed.modal_basis).

    References
    ----------
    docs/reed_dynamics.md; Knutson (2016), eq 3.21.
    """
    from lumped.reed.modal_basis import Modes, Sampling, build_basis

    sys = assemble(reed, mesh_size)
    vals, vecs = _eigen(sys, n_modes)
    raw = np.einsum("ij,ij->j", vecs, sys.M[sys.free][:, sys.free] @ vecs) * sys.ell
    modes = Modes(np.sqrt(vals), bending_labels(len(vals)), raw, lambda s, y: sys.probe(s) @ vecs,
                  mesh_size=sys.mesh_size, dofs=len(sys.free))
    return build_basis(reed, port, "beam", modes, Sampling(breaks=sys.nodes()))


def fe_reed(reed: Reed, port=None, mesh_size: float | None = None):
    """The whole beam FE reed for the reference stepper: dense M, K on the free DOFs, the load of a unit pressure on
    the footprint, the opening, tip and station rows.

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    port : geometry.reed_port.ReedPort, optional
        The port's footprint on the face (None: the whole face, eq 3.21's load).
    mesh_size : float, optional
        Element size [m]; None: default_fe_mesh_size.

    Returns
    -------
    lumped.reed.modal_basis.FEReed
        (SI units).

    References
    ----------
    docs/reed_dynamics.md.
    """
    from lumped.reed.modal_basis import FESystem, Sampling, fe_reed_from

    sys = assemble(reed, default_fe_mesh_size(reed) if mesh_size is None else mesh_size)
    M, K = sys.dense()
    system = FESystem(M, K, lambda s, y: sys.probe(s), mesh_size=sys.mesh_size,
                      dof_units=f"w [m] and ell w' [m] at each node, ell = {sys.ell:.6g} m")
    return fe_reed_from(reed, port, "beam", system, Sampling(breaks=sys.nodes()))
