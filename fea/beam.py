"""Euler-Bernoulli beam reed with Hermite elements (scikit-fem ``ElementLineHermite``).

The same theory as the analytic model (thesis eq 3.8 without damping and fluid):
(EI(s) v'')'' + m(s) v_tt = q(s), clamped at s = 0 (v = v' = 0), free at s = L.
EI(s) and m(s) = rho A(s) come from the exact outline and section of
:meth:`geometry.Reed.section` (grooves as a reduced section, neutral axis shifted);
the uniform pressure gives q(s) = p W(s) (eq 3.30 with X = 1). Only bending exists.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla
from skfem import Basis, BilinearForm, ElementLineHermite, LinearForm, asm, condense, solve as fem_solve

from geometry.reed import Reed
from lumped.mode_function import ReedProperties

from .mesh import line_mesh
from .modes import ModalResult

#: default element length [m]; Hermite cubics converge as h^4: L/200 is exact to ~1e-9
DEFAULT_MESH_SIZE = 25.4e-3 / 200
#: Gauss order: high, because W(s) of a rounded tip has a square-root end
INTORDER = 10
N_SHAPE = 801


BeamResult = ModalResult   # every beam mode is a bending mode: bending_index = 0


@BilinearForm
def _stiffness(u, v, w):
    return w.EI * u.hess[0, 0] * v.hess[0, 0]


@BilinearForm
def _mass(u, v, w):
    return w.m * u * v


@LinearForm
def _load(v, w):
    return w.q * v


def _field(basis: Basis, fn) -> np.ndarray:
    """A function of s evaluated at the quadrature points, shaped (nelems, nq)."""
    x = np.asarray(basis.global_coordinates())[0]
    return np.asarray(fn(x.ravel()), dtype=float).reshape(x.shape)


def solve(reed: Reed, mesh_size: float | None = None, n_modes: int = 4) -> BeamResult:
    """Bending modes, uniform-load stiffness kappa = p / v(L) [Pa/m] and shapes of the E-B beam."""
    h = DEFAULT_MESH_SIZE if mesh_size is None else float(mesh_size)
    mesh = line_mesh(reed, h)
    basis = Basis(mesh, ElementLineHermite(), intorder=INTORDER)
    x = np.asarray(basis.global_coordinates())[0]
    A, I2 = reed.section(x.ravel())
    EI = reed.material.youngs_modulus * I2.reshape(x.shape)
    m = reed.material.density * A.reshape(x.shape)
    q = _field(basis, reed.width)  # p = 1 Pa
    K = asm(_stiffness, basis, EI=EI)
    M = asm(_mass, basis, m=m)
    f = asm(_load, basis, q=q)
    D = basis.get_dofs(lambda x: x[0] < 1e-15).all()
    u = fem_solve(*condense(K, f, D=D))
    Kc, Mc, _, I = condense(K, M, D=D)
    vals, vecs = spla.eigsh(Kc.tocsc(), k=n_modes, M=Mc.tocsc(), sigma=0.0, which="LM")
    order = np.argsort(vals)
    vals, vecs = vals[order], vecs[:, order]
    s = np.linspace(0.0, reed.length, N_SHAPE)
    P = basis.probes(np.clip(s, 0.0, reed.length * (1 - 1e-14))[None, :])
    w = P @ u
    phi_full = np.zeros(K.shape[0])
    phi_full[I] = vecs[:, 0]
    phi = P @ phi_full
    tip = basis.get_dofs(lambda x: np.abs(x[0] - reed.length) < 1e-12).nodal["u"][0]
    kappa = 1.0 / u[tip]
    return BeamResult(
        omega=np.sqrt(vals), kinds=["bending"] * n_modes, bending_index=0, kappa=kappa, s=s,
        psi_static=w / w[-1], psi_mode=phi / phi[-1], dofs=len(I), mesh_size=h,
    )


def reed_properties(reed: Reed, mesh_size: float | None = None) -> ReedProperties:
    """omega_n [rad/s], kappa [Pa/m] and gamma1..3 (Table 3.4, static shape) of the E-B beam FE model."""
    r = solve(reed, mesh_size)
    return ReedProperties.from_shape("beam", reed, r.omega_n, r.kappa, r.s, r.psi_static,
                                     dofs=r.dofs, mesh_size=r.mesh_size)
