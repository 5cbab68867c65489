"""3-D linear-elastic reed: quadratic hexahedra swept through the thickness (scikit-fem).

The reference for omega_n and kappa (thesis section 3.2.3 and 3.5.1, Table 3.3): the reed
clamped on its whole s = 0 face, in vacuum. One sparse LU factorisation of the clamped
stiffness serves the static pressure solve and the shift-invert eigen-solve.

"Tip deflection" (kappa = p / x, eq 3.30) is the z-displacement at the tip of the centre
line on the mid-surface, the point (s, y, z) = (L, 0, h/2); the deflection shape psi(s)
is the z-displacement along (s, 0, h/2) (a node line of every mesh: the centre line and
the mid-plane are mesh lines).
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
from lumped.mode_function import ReedProperties

from .mesh import SolidMesh, is_symmetric, scaled_mesh_size, solid_mesh, write_vtu
from .modes import ModalResult, classify_solid_modes, probe_z

#: default element size [m] (away from the clamp) for a 1 in reed: discretisation error
#: < 0.3 % in omega_n and kappa (three-mesh study, tests/test_fea_slow.py, docs/errata.md)
DEFAULT_MESH_SIZE = 1.0e-3
#: elements through half the thickness
DEFAULT_LAYERS = 1
#: Gauss order: exact for the Q2 x Q2 mass on affine hexahedra (3 points per direction)
INTORDER = 4
#: points sampled along the centre line for psi(s)
N_SHAPE = 401



def default_mesh_size(reed: Reed) -> float:
    """The converged default element size [m]: DEFAULT_MESH_SIZE, scaled down for reeds shorter than 1 in."""
    return scaled_mesh_size(reed, DEFAULT_MESH_SIZE)


@dataclass
class SolidResult(ModalResult):
    """Everything the solid model computes for one reed and mesh (SI units): the modal
    result plus the mesh, full displacement fields and timings."""

    mesh: SolidMesh
    u_static: np.ndarray         # displacement per unit pressure (full vector) [m/Pa]
    modes: np.ndarray            # mode vectors (full), columns
    basis: Basis
    timings: dict = field(default_factory=dict)


def _scalar_basis(mesh, intorder=INTORDER) -> Basis:
    return Basis(mesh, ElementHex2(), intorder=intorder)


def assemble(basis: Basis, youngs_modulus: float, poisson_ratio: float, density: float,
             chunk: int = 2000) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Stiffness K [N/m] and mass M [kg] of 3-D linear elasticity on a scalar Q2 basis.

    Element matrices by batched matrix products over elements (scikit-fem's generic
    form assembly evaluates the 81 x 81 vector form entry pair by pair, ~20x slower
    here). Vector DOF 3 k + i is component i of scalar DOF k, as in ``ElementVector``.
    """
    E, nu = youngs_modulus, poisson_ratio
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    nb = len(basis.basis)
    nel = basis.nelems
    edofs = basis.element_dofs  # (nb, nel)
    vdofs = (3 * edofs[:, None, :] + np.arange(3)[None, :, None]).reshape(3 * nb, nel).T  # (nel, 3nb)
    kdata = np.empty((nel, 3 * nb, 3 * nb))
    mdata = np.zeros((nel, 3 * nb, 3 * nb))
    for e0 in range(0, nel, chunk):
        sl = slice(e0, min(e0 + chunk, nel))
        dx = basis.dx[sl]                                                   # (ne, nq)
        G = np.stack([basis.basis[a][0].grad[:, sl] for a in range(nb)])    # (nb, 3, ne, nq)
        G = G.transpose(2, 0, 1, 3).reshape(-1, 3 * nb, dx.shape[1])        # (ne, 3nb, nq)
        D = np.matmul(G * dx[:, None, :], G.transpose(0, 2, 1))            # d_i phi_a . d_j phi_b
        D4 = D.reshape(-1, nb, 3, nb, 3)
        tr = np.einsum("eakbk->eab", D4)
        Ke = lam * D4 + mu * D4.transpose(0, 1, 4, 3, 2)
        Ke += mu * tr[:, :, None, :, None] * np.eye(3)[None, None, :, None, :]
        kdata[sl] = Ke.reshape(-1, 3 * nb, 3 * nb)
        phi = np.stack([np.asarray(basis.basis[a][0])[sl] for a in range(nb)], axis=1)  # (ne, nb, nq)
        Me = density * np.matmul(phi * dx[:, None, :], phi.transpose(0, 2, 1))  # (ne, nb, nb)
        for i in range(3):
            mdata[sl, i::3, i::3] = Me
    n = 3 * basis.N
    rows = np.broadcast_to(vdofs[:, :, None], kdata.shape).ravel()
    cols = np.broadcast_to(vdofs[:, None, :], kdata.shape).ravel()
    K = sp.csr_matrix((kdata.ravel(), (rows, cols)), shape=(n, n))
    M = sp.csr_matrix((mdata.ravel(), (rows, cols)), shape=(n, n))
    return K, M


def pressure_load(sm: SolidMesh, basis: Basis, pressure: float = 1.0) -> np.ndarray:
    """Nodal forces [N] of a uniform pressure [Pa] on the wetted upstream surface (traction -p n)."""
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
    """Constrained vector DOFs: all three components on the clamp face s = 0; on the symmetry
    plane y = 0 of a half model u_y = 0 (symmetric modes and loads), or u_x = u_z = 0
    (``antisymmetric``: torsion-like modes)."""
    d = basis.get_dofs(lambda x: x[0] < tol).all()
    out = [(3 * d[:, None] + np.arange(3)[None, :]).ravel()]
    if half:
        c = basis.get_dofs(lambda x: np.abs(x[1]) < tol).all()
        comps = [0, 2] if antisymmetric else [1]
        out.append((3 * c[:, None] + np.array(comps)[None, :]).ravel())
    return np.unique(np.concatenate(out))


def centre_line_probe(basis: Basis, reed: Reed, s: np.ndarray) -> sp.csr_matrix:
    """Matrix mapping the vector DOFs to u_z at (s, 0, h/2) [m per m]."""
    pts = np.vstack([np.clip(s, 1e-12, reed.length * (1 - 1e-12)), 0 * s, 0 * s + probe_z(reed)])
    P = basis.probes(pts).tocoo()  # scalar
    return sp.csr_matrix((P.data, (P.row, 3 * P.col + 2)), shape=(len(s), 3 * basis.N))


def _eigen(Kf, Mf, lu, n_modes: int, v0=None):
    """Lowest eigenpairs of K phi = omega^2 M phi by ARPACK shift-invert about 0 with the given LU of K."""
    op = spla.LinearOperator(Kf.shape, matvec=lu.solve, dtype=float)
    vals, vecs = spla.eigsh(Kf, k=n_modes, M=Mf, sigma=0.0, OPinv=op, which="LM", v0=v0, tol=1e-10)
    order = np.argsort(vals)
    return vals[order], vecs[:, order]


def solve(reed: Reed, mesh_size: float | None = None, layers: int = DEFAULT_LAYERS,
          n_modes: int = 4, symmetry: bool | None = None, torsion: bool = False) -> SolidResult:
    """First modes, uniform-load stiffness and centre-line shapes of the clamped 3-D reed.

    omega [rad/s] from K phi = omega^2 M phi (shift-invert about 0, ARPACK), kappa [Pa/m]
    per eq 3.30 from the static solve K u = f(p = 1 Pa); both use one LU of K.
    ``symmetry`` (default: when the reed is symmetric) solves the half y >= 0 with the
    symmetric plane condition, which holds the bending modes and the pressure response;
    ``torsion=True`` then also solves the antisymmetric half for the torsion modes.
    """
    h = default_mesh_size(reed) if mesh_size is None else float(mesh_size)
    half = is_symmetric(reed) if symmetry is None else bool(symmetry and is_symmetric(reed))
    tm = {}
    t0 = time.perf_counter()
    sm = solid_mesh(reed, h, layers=layers, half=half)
    tm["mesh"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    basis = _scalar_basis(sm.mesh)
    m = reed.material
    K, M = assemble(basis, m.youngs_modulus, m.poisson_ratio, m.density)
    f = pressure_load(sm, basis)
    tm["assembly"] = time.perf_counter() - t0
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
    t0 = time.perf_counter()
    # the static shape is close to the first bending mode: a good start vector
    vals, vecs = _eigen(Kf, Mf, lu, n_modes, v0=u[free] / np.abs(u[free]).max())
    modes = np.zeros((K.shape[0], n_modes))
    modes[free] = vecs
    kinds = classify_solid_modes(basis, modes, reed, half=half)
    if half and torsion:
        free_a = np.setdiff1d(np.arange(K.shape[0]), fixed_dofs(basis, half, antisymmetric=True))
        Ka = K[free_a][:, free_a].tocsc()
        lu_a = spla.splu(Ka, permc_spec="MMD_AT_PLUS_A")
        va, xa = _eigen(Ka, M[free_a][:, free_a].tocsr(), lu_a, n_modes)
        ma = np.zeros((K.shape[0], n_modes))
        ma[free_a] = xa
        kinds_a = ["torsion" if k == "bending" else "in-plane" for k in
                   classify_solid_modes(basis, ma, reed, half=True)]
        vals = np.concatenate([vals, va])
        modes = np.hstack([modes, ma])
        kinds = kinds + kinds_a
        order = np.argsort(vals)
        vals, modes, kinds = vals[order], modes[:, order], [kinds[i] for i in order]
    tm["eigen"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    bending = kinds.index("bending") if "bending" in kinds else 0
    s = np.linspace(0.0, reed.length, N_SHAPE)
    P = centre_line_probe(basis, reed, s)
    w = P @ u
    phi = P @ modes[:, bending]
    tm["post"] = time.perf_counter() - t0
    return SolidResult(
        omega=np.sqrt(np.abs(vals)), kinds=kinds, bending_index=bending, kappa=1.0 / w[-1],
        s=s, psi_static=w / w[-1], psi_mode=phi / phi[-1], dofs=len(free), mesh_size=h,
        mesh=sm, u_static=u, modes=modes, basis=basis, timings=tm,
    )


def reed_properties(reed: Reed, mesh_size: float | None = None) -> ReedProperties:
    """omega_n [rad/s], kappa [Pa/m] and gamma1..3 (Table 3.4, static shape) from 3-D FEA.

    Memoised in memory per (reed, mesh size): the tables and the check ask for the same
    reeds several times in one run.
    """
    return _reed_properties(reed, None if mesh_size is None else float(mesh_size))


@functools.lru_cache(maxsize=16)
def _reed_properties(reed: Reed, mesh_size: float | None) -> ReedProperties:
    r = solve(reed, mesh_size)
    return ReedProperties.from_shape("solid", reed, r.omega_n, r.kappa, r.s, r.psi_static,
                                     dofs=r.dofs, mesh_size=r.mesh_size)


def write_modes_vtu(result: SolidResult, path) -> None:
    """Write the static shape (per unit pressure) and the mode shapes (max |u| = 1) as VTU point data."""
    mesh = result.mesh.mesh
    nv = mesh.p.shape[1]
    # the first nv scalar DOFs of ElementHex2 are the vertices
    data = {"u_static_per_Pa": result.u_static.reshape(-1, 3)[:nv]}
    for k in range(result.modes.shape[1]):
        v = result.modes[:, k].reshape(-1, 3)[:nv]
        v = v / np.abs(v).max()
        data[f"mode{k + 1}_{result.kinds[k]}_{result.omega[k]:.0f}rad_s"] = v
    write_vtu(path, mesh, data)
