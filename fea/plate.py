"""Kirchhoff plate reed with Argyris triangles (scikit-fem ``ElementTriArgyris``).

The reed face (s, y) as a thin plate of rigidity D = E h^3 / 12 (1 - nu^2), clamped on
s = 0: w = 0 and dw/dn = 0. Where a groove is cut the element carries the remaining
material thickness h - d (the mid-surface offset of a one-sided pocket is neglected:
the plate is the reed's "thickness per element" model). Mass rho h per unit area; the
uniform pressure p = 1 Pa gives kappa = p / w(L, 0) (eq 3.30). Argyris elements are
C1-conforming quintics, so frequencies converge from above.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla
from skfem import Basis, BilinearForm, ElementTriArgyris, LinearForm, asm, condense, solve as fem_solve
from skfem.helpers import dd, ddot, eye, trace

from geometry.reed import Reed
from lumped.mode_function import ReedProperties

from .mesh import face_mesh, scaled_mesh_size
from .modes import ModalResult, classify_by_symmetry, mirror_points

#: default element size [m] away from the clamp (about 0.2 % from converged on the stepped reeds, whose step corners converge slowest)
DEFAULT_MESH_SIZE = 2.0e-3
INTORDER = 10
N_SHAPE = 401



def default_mesh_size(reed: Reed) -> float:
    """The converged default element size [m]: DEFAULT_MESH_SIZE, scaled down for reeds shorter than 1 in."""
    return scaled_mesh_size(reed, DEFAULT_MESH_SIZE)


PlateResult = ModalResult


@BilinearForm
def _stiffness(u, v, w):
    # bending moments per unit curvature: D [(1 - nu) k + nu tr(k) I] with D = E h^3 / 12 (1 - nu^2)
    nu = w.nu
    D = w.E * w.h**3 / (12.0 * (1.0 - nu**2))
    k = dd(u)
    return D * ddot((1.0 - nu) * k + nu * eye(trace(k), 2), dd(v))


@BilinearForm
def _mass(u, v, w):
    return w.rho * w.h * u * v


@LinearForm
def _load(v, w):
    return 1.0 * v


def solve(reed: Reed, mesh_size: float | None = None, n_modes: int = 4) -> PlateResult:
    """Modes (classified), uniform-load stiffness [Pa/m] and centre-line shapes of the clamped plate."""
    size = default_mesh_size(reed) if mesh_size is None else float(mesh_size)
    fm = face_mesh(reed, size, quad=False)
    basis = Basis(fm.mesh, ElementTriArgyris(), intorder=INTORDER)
    hel = (reed.thickness - fm.depth)[:, None] * np.ones((1, basis.X.shape[1]))
    mat = reed.material
    K = asm(_stiffness, basis, E=mat.youngs_modulus, nu=mat.poisson_ratio, h=hel)
    M = asm(_mass, basis, rho=mat.density, h=hel)
    f = asm(_load, basis)
    # clamp: w and all its derivatives along the edge vanish; only w_xx stays free
    clamp = basis.get_dofs(lambda x: x[0] < 1e-12)
    D = np.concatenate([clamp.nodal[n] for n in ("u", "u_x", "u_y", "u_xy", "u_yy")] + [clamp.facet["u_n"]])
    u = fem_solve(*condense(K, f, D=D))
    Kc, Mc, _, I = condense(K, M, D=D)
    vals, vecs = spla.eigsh(Kc.tocsc(), k=n_modes, M=Mc.tocsc(), sigma=0.0, which="LM")
    order = np.argsort(vals)
    vals, vecs = vals[order], vecs[:, order]
    modes = np.zeros((K.shape[0], n_modes))
    modes[I] = vecs
    up, down = mirror_points(reed)
    Pu, Pd = basis.probes(up), basis.probes(down)
    kinds = [classify_by_symmetry(Pu @ modes[:, k], Pd @ modes[:, k]) for k in range(n_modes)]
    bending = kinds.index("bending") if "bending" in kinds else 0
    s = np.linspace(0.0, reed.length, N_SHAPE)
    P = basis.probes(np.vstack([np.clip(s, 1e-12, reed.length * (1 - 1e-12)), 0 * s]))
    w = P @ u
    phi = P @ modes[:, bending]
    return PlateResult(
        omega=np.sqrt(vals), kinds=kinds, bending_index=bending, kappa=1.0 / w[-1], s=s,
        psi_static=w / w[-1], psi_mode=phi / phi[-1], dofs=len(I), mesh_size=size,
    )


def reed_properties(reed: Reed, mesh_size: float | None = None) -> ReedProperties:
    """omega_n [rad/s], kappa [Pa/m] and gamma1..3 (Table 3.4, static shape) of the Kirchhoff plate."""
    r = solve(reed, mesh_size)
    return ReedProperties.from_shape("plate", reed, r.omega_n, r.kappa, r.s, r.psi_static,
                                     dofs=r.dofs, mesh_size=r.mesh_size)
