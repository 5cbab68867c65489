"""3-D linear-elastic reed: quadratic hexahedra swept through the thickness (scikit-fem).

The reference for omega_n and kappa (thesis section 3.2.3 and 3.5.1, Table 3.3): the reed
clamped on its whole s = 0 face, in vacuum. One sparse LU factorisation of the clamped
stiffness serves the static pressure solve and the shift-invert eigen-solve.

"Tip deflection" (kappa = p / x, eq 3.30) is the z-displacement at the tip of the centre
line on the reference surface, the point (s, y, z) = (L, 0, h/2) (h the tip section's
thickness); the deflection shape psi(s) is the z-displacement along (s, 0, h(s)/2) (a node
line of every mesh: the centre line and each piece's mid-plane are mesh lines).

Default element size: 1 mm on the 1 in thesis reeds (estimated discretisation error of
omega_n 0.005-0.22 % and of kappa 0.01-0.42 % on the four reeds, within a factor 1.5 of the
error against much finer meshes, docs/fea.md), scaled with the reed's in-plane size
(:func:`fea.mesh.scaled_mesh_size`); one element layer per half of the largest thickness,
more when the thickness exceeds twice the element size.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import Basis, ElementHex2, FacetBasis

from geometry.reed import Reed
from lumped.reed.mode_function import ReedProperties

from .mesh import SolidMesh, is_symmetric, scaled_mesh_size, solid_mesh, write_vtu
from .modes import (
    ModalResult, ModeShapes, describe_modes, face_grid, fidelity_functions, first_bending, probe_z, pull_inside,
)
from .resources import check_memory, solid_bytes

#: default element size [m] (away from the clamp) for the 1 in thesis reeds, scaled for others
#: (errors of omega_n / kappa at this size: uniform 0.005 / 0.009 %, stepped #1 0.12 / 0.22 %,
#: stepped #2 0.22 / 0.42 %, prototype 0.22 / 0.37 %; docs/fea.md)
DEFAULT_MESH_SIZE = 1.0e-3
#: elements through half the thickness (at least)
DEFAULT_LAYERS = 1
#: Gauss order: exact for the Q2 x Q2 mass on affine hexahedra (3 points per direction)
INTORDER = 4
#: points sampled along the centre line for psi(s)
N_SHAPE = 401
#: elements per chunk of the batched element-matrix assembly (bounds its memory)
CHUNK = 1000


def default_mesh_size(reed: Reed) -> float:
    """The solid's converged default element size: DEFAULT_MESH_SIZE scaled with the reed
    (fea.mesh.scaled_mesh_size).

    Parameters
    ----------
    reed : geometry.Reed
        The reed.

    Returns
    -------
    float
        [m].
    """
    return scaled_mesh_size(reed, DEFAULT_MESH_SIZE)


def default_layers(reed: Reed) -> int:
    """Elements through half the largest thickness: DEFAULT_LAYERS, more when h/2 exceeds the default size.

    Parameters
    ----------
    reed : geometry.Reed
        The reed.

    Returns
    -------
    int
    """
    return max(DEFAULT_LAYERS, int(round(reed.max_thickness / 2 / default_mesh_size(reed))))


@dataclass
class SolidResult(ModalResult):
    """Everything the solid model computes for one reed and mesh (SI units): the modal
    result plus the mesh, full displacement fields and timings."""

    mesh: SolidMesh
    u_static: np.ndarray         # displacement per unit pressure (full vector) [m/Pa]
    modes: np.ndarray            # mode vectors (full), columns
    basis: Basis
    antisymmetric: np.ndarray = None   # per mode: True if from the antisymmetric half model
    timings: dict = field(default_factory=dict)
    mass: sp.csr_matrix = None   # the (half) model's mass matrix [kg], full vector DOFs


#: the static solution (mesh, basis, displacement per unit pressure, free DOFs) of the last solve, keyed by
#: (reed, element size, layers, half model): a design check asks the solid for kappa and then for the
#: stress at the stop, which is the same solution scaled (fea.reed_stress.max_opening_stress)
_LAST_STATIC: dict = {}


def last_static(reed: Reed, h: float, layers: int, half: bool):
    """The static solution of the last :func:`solve` of this very model.

    Parameters
    ----------
    reed : geometry.Reed
        The reed.
    h : float
        Element size [m].
    layers : int
    half : bool
        Half model.

    Returns
    -------
    tuple or None
        (mesh, basis, u per 1 Pa [m/Pa], free DOFs), or None.
    """
    try:
        return _LAST_STATIC.get((reed, float(h), int(layers), bool(half)))
    except TypeError:        # an unhashable reed
        return None


def _scalar_basis(mesh, intorder=INTORDER) -> Basis:
    return Basis(mesh, ElementHex2(), intorder=intorder)


def assemble(basis: Basis, youngs_modulus: float, poisson_ratio: float, density: float,
             chunk: int = CHUNK) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Stiffness and mass matrices of 3-D linear elasticity on a scalar Q2 (or P2) basis.

    Parameters
    ----------
    basis : skfem.Basis
        The scalar basis of the mesh (vector DOF 3 k + i is component i of scalar DOF k).
    youngs_modulus, poisson_ratio, density : float
        E [Pa], nu [-], rho [kg/m^3].
    chunk : int
        Elements per batch (bounds the memory).

    Returns
    -------
    tuple of scipy.sparse.csr_matrix
        (K [N/m], M [kg]).

    Notes
    -----
    Element matrices by batched matrix products over chunks of elements (scikit-fem's
    generic form assembly evaluates the 81 x 81 vector form entry pair by pair, ~20x
    slower here); each chunk builds its own quadrature basis and is summed into K as a
    sparse matrix, so memory stays bounded. The mass is assembled as a scalar matrix and
    expanded to the three components. Vector DOF 3 k + i is component i of scalar DOF k,
    as in ``ElementVector``.

    References
    ----------
    Any text on linear elasticity FEM, e.g. Zienkiewicz & Taylor, *The Finite Element Method* (2000); scikit-fem.
    """
    E, nu = youngs_modulus, poisson_ratio
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    mesh, elem = basis.mesh, basis.elem
    nel = basis.nelems
    N = basis.N
    idx = np.int32 if 3 * N < 2**31 - 1 else np.int64
    parts: list[tuple[int, sp.csr_matrix]] = []  # (level, partial sum): balanced summation
    ms_rows, ms_cols, ms_data = [], [], []
    for e0 in range(0, nel, chunk):
        sel = np.arange(e0, min(e0 + chunk, nel))
        b = Basis(mesh, elem, quadrature=basis.quadrature, elements=sel, dofs=basis.dofs)
        nb = len(b.basis)
        edofs = b.element_dofs.astype(idx)                                     # (nb, ne)
        _add_balanced(parts, _chunk_stiffness(b, lam, mu, edofs, 3 * N))
        phi = np.stack([np.asarray(b.basis[a][0]) for a in range(nb)], axis=1)  # (ne, nb, nq)
        Me = density * np.matmul(phi * b.dx[:, None, :], phi.transpose(0, 2, 1))  # (ne, nb, nb)
        ed = edofs.T                                                             # (ne, nb)
        ms_rows.append(np.broadcast_to(ed[:, :, None], Me.shape).ravel())
        ms_cols.append(np.broadcast_to(ed[:, None, :], Me.shape).ravel())
        ms_data.append(Me.ravel())
    K = parts.pop()[1]
    while parts:
        K = parts.pop()[1] + K
    Ms = sp.csr_matrix((np.concatenate(ms_data), (np.concatenate(ms_rows), np.concatenate(ms_cols))),
                       shape=(N, N))
    M = sp.kron(Ms, sp.identity(3, format="csr"), format="csr")
    return K.tocsr(), M


def _chunk_stiffness(b: Basis, lam: float, mu: float, edofs: np.ndarray, n: int) -> sp.csr_matrix:
    """The stiffness of one chunk of elements (basis ``b`` on them, their scalar DOFs ``edofs``) as an n x n
    sparse matrix: Ke = lam D + mu (D^T + tr D I) from D = int d_i phi_a d_j phi_b dx, Lame's lam, mu [Pa]."""
    nb = len(b.basis)
    idx = edofs.dtype.type
    vd = (3 * edofs[:, None, :] + np.arange(3, dtype=idx)[None, :, None]).reshape(3 * nb, -1).T
    dx = b.dx                                                            # (ne, nq)
    G = np.stack([b.basis[a][0].grad for a in range(nb)])               # (nb, 3, ne, nq)
    G = G.transpose(2, 0, 1, 3).reshape(-1, 3 * nb, dx.shape[1])        # (ne, 3nb, nq)
    D = np.matmul(G * dx[:, None, :], G.transpose(0, 2, 1))            # d_i phi_a . d_j phi_b
    del G
    D4 = D.reshape(-1, nb, 3, nb, 3)
    tr = np.einsum("eakbk->eab", D4)
    Ke = lam * D4 + mu * D4.transpose(0, 1, 4, 3, 2)
    Ke += mu * tr[:, :, None, :, None] * np.eye(3)[None, None, :, None, :]
    del D, D4
    Ke = Ke.reshape(-1, 3 * nb, 3 * nb)
    rows = np.broadcast_to(vd[:, :, None], Ke.shape).ravel()
    cols = np.broadcast_to(vd[:, None, :], Ke.shape).ravel()
    return sp.csr_matrix((Ke.ravel(), (rows, cols)), shape=(n, n))


def _add_balanced(parts: list, kc: sp.csr_matrix) -> None:
    """Add a chunk's matrix to the partial sums ``parts`` [(level, sum)], merging equal levels (a binary
    counter): each entry is summed O(log chunks) times, not once per chunk after it."""
    level = 0
    while parts and parts[-1][0] == level:
        kc = parts.pop()[1] + kc
        level += 1
    parts.append((level, kc))


def pressure_load(sm: SolidMesh, basis: Basis, pressure: float = 1.0) -> np.ndarray:
    """Nodal forces of a unit uniform pressure on the wetted upstream surface of a solid mesh (traction -p n, p = 1
    Pa).

    Parameters
    ----------
    sm : fea.mesh.SolidMesh
        The mesh (its pressure facets).
    basis : skfem.Basis
        Its scalar basis.

    Returns
    -------
    numpy.ndarray
        f [N] per vector DOF.
    """
    fb = FacetBasis(sm.mesh, basis.elem, facets=sm.pressure_facets, intorder=INTORDER)
    n = fb.normals  # outward normals (3, nf, nq)
    f = np.zeros(3 * basis.N)
    edofs = fb.element_dofs  # (nb, nf)
    for a in range(len(fb.basis)):
        phi = np.asarray(fb.basis[a][0])  # (nf, nq)
        for i in range(3):
            np.add.at(f, 3 * edofs[a] + i, -pressure * np.sum(n[i] * phi * fb.dx, axis=1))
    return f


def fixed_dofs(basis: Basis, half: bool, antisymmetric: bool = False, tol: float = 1e-12) -> np.ndarray:
    """Constrained vector DOFs: all three components on the clamp face s = 0; on the symmetry plane y = 0 of a half
    model u_y = 0 (symmetric modes and loads), or u_x = u_z = 0 (antisymmetric: torsion-like modes).

    Parameters
    ----------
    basis : skfem.Basis
        The scalar basis.
    half : bool
    antisymmetric : bool
    tol : float
        Relative distance to the plane.

    Returns
    -------
    array of int
        Vector DOF indices, sorted.
    """
    scale = max(1.0, float(np.max(np.abs(basis.mesh.p))))  # 1e-12 m on reeds up to 1 m
    d = basis.get_dofs(lambda x: x[0] < tol * scale).all()
    out = [(3 * d[:, None] + np.arange(3)[None, :]).ravel()]
    if half:
        c = basis.get_dofs(lambda x: np.abs(x[1]) < tol * scale).all()
        comps = [0, 2] if antisymmetric else [1]
        out.append((3 * c[:, None] + np.array(comps)[None, :]).ravel())
    return np.unique(np.concatenate(out))


def centre_line_probe(basis: Basis, reed: Reed, s: np.ndarray) -> sp.csr_matrix:
    """The matrix mapping the vector DOFs to u_z at (s, 0, z(s)), z the reference surface (fea.modes.probe_z).

    Parameters
    ----------
    basis : skfem.Basis
    reed : geometry.Reed
        The reed.
    s : array of float
        Arc lengths [m].

    Returns
    -------
    scipy.sparse.csr_matrix
        (len(s), 3 N) [m/m].
    """
    sc = np.clip(s, 1e-12 * reed.length, reed.length * (1 - 1e-12))
    pts = np.vstack([sc, 0 * s, probe_z(reed, sc)])
    P = basis.probes(pts).tocoo()  # scalar
    return sp.csr_matrix((P.data, (P.row, 3 * P.col + 2)), shape=(len(s), 3 * basis.N))


def _eigen(Kf, Mf, lu, n_modes: int, v0=None):
    """Lowest eigenpairs of K phi = omega^2 M phi by ARPACK shift-invert about 0 with the given LU of K."""
    op = spla.LinearOperator(Kf.shape, matvec=lu.solve, dtype=float)
    k = min(n_modes, Kf.shape[0] - 2)
    vals, vecs = spla.eigsh(Kf, k=k, M=Mf, sigma=0.0, OPinv=op, which="LM", v0=v0, tol=1e-10)
    order = np.argsort(vals)
    return vals[order], vecs[:, order]


def estimate(reed: Reed, sm: SolidMesh) -> tuple[int, float]:
    """The solid's DOFs and peak memory on the mesh (Q2 nodes = vertices + edges + faces + cells).

    Parameters
    ----------
    reed : geometry.Reed
        The reed.
    sm : fea.mesh.SolidMesh

    Returns
    -------
    (dofs, bytes) : tuple of (int, float)
    """
    m = sm.mesh
    nodes = m.p.shape[1] + m.edges.shape[1] + m.facets.shape[1] + m.t.shape[1]
    dofs = 3 * nodes
    return dofs, solid_bytes(dofs, m.t.shape[1])


def _mode_fields(basis: Basis, modes: np.ndarray, reed: Reed, half: bool, anti: np.ndarray, grid, sm_face):
    """u_z of each mode on :func:`fea.modes.face_grid` (mirrored on a half model) and in-plane flags."""
    s, eta, wts, W, pts = grid
    ns, ny = len(s), len(eta)
    pts = pull_inside(sm_face, pts, mirror=half)
    y = pts[1]
    z = probe_z(reed, pts[0])
    P = basis.probes(np.vstack([pts[0], np.abs(y) if half else y, z]))
    fields, in_plane = [], []
    for k in range(modes.shape[1]):
        u = modes[:, k].reshape(-1, 3)
        ux, uy, uz = (P @ u[:, i] for i in range(3))
        if half:  # symmetric half: u_z even in y; antisymmetric half: odd
            sign = np.where(y < 0, -1.0 if anti[k] else 1.0, 1.0)
            uz = uz * sign
        in_plane.append(bool(np.sum(uz**2) < np.sum(ux**2 + uy**2)))
        fields.append(uz.reshape(ns, ny))
    return fields, in_plane


def _static(basis, system: tuple, half: bool, tm: dict) -> tuple:
    """(free DOFs, K and M on them, the LU of K, the static displacement u [m] under the unit pressure load):
    ``system`` = (K, M, f); the factorisation's and the solve's seconds into ``tm``."""
    K, M, f = system
    t0 = time.perf_counter()
    free = np.setdiff1d(np.arange(K.shape[0]), fixed_dofs(basis, half))
    Kf = K[free][:, free].tocsc()
    Mf = M[free][:, free].tocsr()
    lu = spla.splu(Kf, permc_spec="MMD_AT_PLUS_A")
    tm["factorisation"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    u = np.zeros(K.shape[0])
    u[free] = lu.solve(f[free])
    tm["static"] = time.perf_counter() - t0
    return free, Kf, Mf, lu, u


def _with_torsion(basis, matrices: tuple, symmetric: tuple, n_modes: int) -> tuple:
    """(omega^2, modes, antisymmetric flags) of the half model's symmetric modes with the antisymmetric half's
    ``n_modes`` added (the torsion modes: the symmetry plane held in y instead), sorted by frequency."""
    K, M = matrices
    vals, modes, anti = symmetric
    free_a = np.setdiff1d(np.arange(K.shape[0]), fixed_dofs(basis, True, antisymmetric=True))
    Ka = K[free_a][:, free_a].tocsc()
    lu_a = spla.splu(Ka, permc_spec="MMD_AT_PLUS_A")
    va, xa = _eigen(Ka, M[free_a][:, free_a].tocsr(), lu_a, n_modes)
    del lu_a, Ka
    ma = np.zeros((K.shape[0], xa.shape[1]))
    ma[free_a] = xa
    vals = np.concatenate([vals, va])
    modes = np.hstack([modes, ma])
    anti = np.concatenate([anti, np.ones(xa.shape[1], dtype=bool)])
    order = np.argsort(vals)
    return vals[order], modes[:, order], anti[order]


def solve(reed: Reed, mesh_size: float | None = None, layers: int | None = None,
          n_modes: int = 4, symmetry: bool | None = None, torsion: bool = False) -> SolidResult:
    """The first modes, the uniform-load stiffness kappa = p / w(L) and the centre-line shapes of the clamped 3-D
    reed.

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    mesh_size : float, optional
        Element size [m]; None: the fidelity's default for this reed.
    layers : int, optional
        Elements per half thickness (None: default_layers).
    n_modes : int
        Modes wanted.
    symmetry : bool, optional
        Solve the half y >= 0 (None: when the reed is symmetric).
    torsion : bool
        Also solve the antisymmetric half for the torsion modes.

    Returns
    -------
    SolidResult
        omega [rad/s] (named by nodal pattern), kappa [Pa/m] (eq 3.30), shapes, DOFs, timings.

    Notes
    -----
    omega from K phi = omega^2 M phi (shift-invert about 0, ARPACK), kappa per eq 3.30 from the static solve
    K u = f(p = 1 Pa), both with one LU of K. The half model's symmetric plane condition holds the bending modes
    and the pressure response; the antisymmetric half adds the torsion modes (each half gives ``n_modes``).

    References
    ----------
    Knutson (2016), eq 3.30, section 3.5, Table 3.3.
    """
    h = default_mesh_size(reed) if mesh_size is None else float(mesh_size)
    layers = default_layers(reed) if layers is None else int(layers)
    half = is_symmetric(reed) if symmetry is None else bool(symmetry and is_symmetric(reed))
    tm = {}
    sm, basis, K, M, f = _mesh_and_assemble(reed, h, layers, half, tm)
    free, Kf, Mf, lu, u = _static(basis, (K, M, f), half, tm)
    t0 = time.perf_counter()
    # the static shape is close to the first bending mode: a good start vector
    vals, vecs = _eigen(Kf, Mf, lu, n_modes, v0=u[free] / np.abs(u[free]).max())
    del lu, Kf, Mf
    modes = np.zeros((K.shape[0], vecs.shape[1]))
    modes[free] = vecs
    anti = np.zeros(vecs.shape[1], dtype=bool)
    if half and torsion:
        vals, modes, anti = _with_torsion(basis, (K, M), (vals, modes, anti), n_modes)
    tm["eigen"] = time.perf_counter() - t0
    kinds, labels, bending, s, w, phi = _named_shapes(basis, reed, sm, (u, modes, anti), tm)
    _LAST_STATIC.clear()
    _LAST_STATIC[(reed, h, layers, half)] = (sm, basis, u, len(free))
    return SolidResult(
        omega=np.sqrt(np.abs(vals)), kinds=kinds, bending_index=bending, kappa=1.0 / w[-1],
        s=s, psi_static=w / w[-1], psi_mode=phi / phi[-1], dofs=len(free), mesh_size=h, labels=labels,
        mesh=sm, u_static=u, modes=modes, basis=basis, antisymmetric=anti, timings=tm, mass=M,
    )


def _named_shapes(basis: Basis, reed: Reed, sm: SolidMesh, fields: tuple, tm: dict):
    """(kinds, labels, the first bending mode's index, s [m], w(s) [m/Pa], phi(s)) of the solution ``fields`` =
    (static u per 1 Pa, modes, antisymmetric flags): the modes named by their nodal pattern (fea.modes), the
    static and first bending shapes on the centre line; the time into ``tm``."""
    u, modes, anti = fields
    t0 = time.perf_counter()
    half = sm.half
    face_fields, in_plane = _mode_fields(basis, modes, reed, half, anti, face_grid(reed), sm.face.mesh)
    kinds, labels = describe_modes(face_fields, reed, in_plane)
    bending = first_bending(kinds, labels)
    s = np.linspace(0.0, reed.length, N_SHAPE)
    P = centre_line_probe(basis, reed, s)
    w = P @ u
    phi = P @ modes[:, bending]
    tm["post"] = time.perf_counter() - t0
    return kinds, labels, bending, s, w, phi


def _mesh_and_assemble(reed: Reed, h: float, layers: int, half: bool, tm: dict):
    """(mesh, scalar basis, K, M, unit-pressure load) of the reed at element size h [m]; the DOFs and memory
    estimated first (an InputError naming --mesh-size where they exceed the machine's, fea.resources); the
    times of meshing and assembly into ``tm``."""
    t0 = time.perf_counter()
    sm = solid_mesh(reed, h, layers=layers, half=half)
    dofs_est, nbytes = estimate(reed, sm)
    check_memory("solid model", dofs_est, nbytes)
    tm["mesh"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    basis = _scalar_basis(sm.mesh)
    m = reed.material
    K, M = assemble(basis, m.youngs_modulus, m.poisson_ratio, m.density)
    f = pressure_load(sm, basis)
    tm["assembly"] = time.perf_counter() - t0
    return sm, basis, K, M, f


def reed_properties(reed: Reed, mesh_size: float | None = None) -> ReedProperties:
    """omega_n, kappa and gamma1..3 of eq 3.21's one mode (Table 3.4, static shape) from 3-D FEA.

    Parameters
    ----------
    reed : geometry.Reed
        The reed.
    mesh_size : float, optional
        Element size [m]; None: :func:`default_mesh_size`.

    Returns
    -------
    lumped.reed.euler_bernoulli.ReedProperties
        omega_n [rad/s], kappa [Pa/m], gammas [-]. Memoised per (reed, mesh size): the tables and the check ask for
        the same reeds several times in one run.

    References
    ----------
    Knutson (2016), eqs 3.21, 3.30, Table 3.4.
    """
    return _reed_properties(reed, None if mesh_size is None else float(mesh_size))


#: the fidelity's functions (fea.fidelities): properties (memoised below), the modes with torsion (a symmetric reed is
#: solved as its symmetric and antisymmetric halves, n modes each), both
_reed_properties, modes, properties_and_modes = fidelity_functions("solid", solve, __name__, torsion=True)
_reed_properties = functools.lru_cache(maxsize=16)(_reed_properties)


def mode_shapes(result: SolidResult, reed: Reed, n: int | None = None, ns: int = 60, ny: int = 21) -> ModeShapes:
    """u_z of the first n modes on an (s, y) grid of the reference surface, each max |u_z| = 1 (for plots).

    Parameters
    ----------
    result : SolidResult
    reed : geometry.Reed
        The reed.
    n : int, optional
        Modes; None: all solved.
    ns, ny : int
        Grid points along and across.

    Returns
    -------
    fea.modes.ModeShapes
    """
    n = result.modes.shape[1] if n is None else min(n, result.modes.shape[1])
    s = np.linspace(1e-4, 1 - 1e-4, ns) * reed.length
    eta = np.linspace(-1.0, 1.0, ny) * 0.999
    W = np.asarray(reed.width(s))
    Y = eta[None, :] * W[:, None] / 2
    S = np.repeat(s[:, None], ny, axis=1)
    half = result.mesh.half
    sy = pull_inside(result.mesh.face.mesh, np.vstack([S.ravel(), Y.ravel()]), mirror=half)
    pts = np.vstack([sy[0], np.abs(sy[1]) if half else sy[1], probe_z(reed, sy[0])])
    P = result.basis.probes(pts)
    w = np.empty((n, ns, ny))
    for k in range(n):
        uz = P @ result.modes[:, k].reshape(-1, 3)[:, 2]
        if half and result.antisymmetric is not None and result.antisymmetric[k]:
            uz = uz * np.where(Y.ravel() < 0, -1.0, 1.0)
        uz = uz.reshape(ns, ny)
        w[k] = uz / (np.max(np.abs(uz)) or 1.0)
    return ModeShapes(s=s, y=Y, w=w, omega=result.omega[:n], labels=result.labels[:n], fidelity="solid")


def write_modes_vtu(result: SolidResult, path) -> None:
    """Write the static shape (per unit pressure) and the mode shapes (max |u| = 1) as VTU point data.

    Parameters
    ----------
    result : SolidResult
    path : str or Path

    Returns
    -------
    None
    """
    mesh = result.mesh.mesh
    nv = mesh.p.shape[1]
    # the first nv scalar DOFs of ElementHex2 are the vertices
    data = {"u_static_per_Pa": result.u_static.reshape(-1, 3)[:nv]}
    for k in range(result.modes.shape[1]):
        v = result.modes[:, k].reshape(-1, 3)[:nv]
        v = v / np.abs(v).max()
        data[f"mode{k + 1}_{result.labels[k].replace(' ', '_')}_{result.omega[k]:.0f}rad_s"] = v
    write_vtu(path, mesh, data)


# -- the modal reed (lumped.reed.modal_basis) ---------------------------------------------------------
def modal_basis(reed: Reed, port=None, mesh_size: float | None = None, n_modes: int = 6):
    """The ``solid`` fidelity's modal basis for the modal reed valve: the first out-of-plane modes of the 3-D reed
    with their modal masses, loads, openings and station values.

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
        (SI units).

    References
    ----------
    docs/reed_dynamics.md.
    """
    from matplotlib.tri import Triangulation

    from lumped.reed.modal_basis import Modes, Sampling, build_basis

    from .mesh import is_symmetric

    half = is_symmetric(reed)
    r = solve(reed, mesh_size, n_modes=n_modes if half else n_modes + 4, torsion=True)
    keep = [k for k, kind in enumerate(r.kinds) if kind != "in-plane"][:n_modes]
    modes = r.modes[:, keep]
    anti = np.zeros(len(keep), dtype=bool) if r.antisymmetric is None else r.antisymmetric[keep]
    raw = (2.0 if r.mesh.half else 1.0) * np.einsum("ij,ij->j", modes, r.mass @ modes)
    uz = modes[2::3]                                 # z component of each scalar node
    inset = 1e-6 * reed.min_thickness

    face = r.mesh.face
    t = face.mesh.t if face.mesh.t.shape[0] == 3 else np.hstack([face.mesh.t[[0, 1, 2]], face.mesh.t[[0, 2, 3]]])
    depth = face.depth if face.mesh.t.shape[0] == 3 else np.concatenate([face.depth, face.depth])
    finder = Triangulation(face.mesh.p[0], face.mesh.p[1], t.T).get_trifinder()

    def evaluate(s, y):
        sy = pull_inside(face.mesh, np.vstack([np.asarray(s, float), np.asarray(y, float)]), mirror=r.mesh.half)
        # the meshed groove floor (the mesh's chords, not the exact arcs, decide what is pocket)
        z = depth[finder(sy[0], np.abs(sy[1]) if r.mesh.half else sy[1])] + inset
        P = r.basis.probes(np.vstack([sy[0], np.abs(sy[1]) if r.mesh.half else sy[1], z]))
        w = P @ uz
        if r.mesh.half:                              # antisymmetric modes are odd in y
            w = w * np.where((sy[1] < 0)[:, None] & anti[None, :], -1.0, 1.0)
        return np.asarray(w)

    modes = Modes(r.omega[keep], [r.labels[k] for k in keep], raw, evaluate, mesh_size=r.mesh_size, dofs=r.dofs)
    return build_basis(reed, port, "solid", modes, Sampling(plane=True))
