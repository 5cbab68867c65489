"""Steady incompressible laminar Navier-Stokes on tetrahedra: Taylor-Hood P2-P1, Newton, scikit-fem.

rho (u . grad) u = div(sigma), div u = 0, sigma = -p I + mu (grad u + grad u^T), in the weak form
with the Laplacian viscous term mu grad u : grad v (equal to the symmetric one for
incompressible flow with no-slip walls; its natural boundary condition, mu du/dn - p n =
-P n, is the "do-nothing" traction of open inlets and outlets at pressure P). Taylor-Hood
P2 velocity / P1 pressure is inf-sup stable, so no stabilisation is added: the solver is for
the laminar regime the reed valve works in (Re of eq 3.87 of order 1-100).

The velocity block is assembled from scalar P2 matrices (Laplacian, convection, and the nine
Newton reaction blocks d w_a / d x_b), 9x fewer entries than a vector form; the saddle-point
system [[A, B^T], [B, 0]] is solved directly (PARDISO through pypardiso when installed, else
SuperLU). Newton starts from the Stokes solution (or a given state) and stops when the
velocity update is below ``tol`` of the velocity (relative, max norm).

SI units throughout. References: Elman, Silvester and Wathen (2014), Finite Elements and
Fast Iterative Solvers, ch. 3 and 8 (Taylor-Hood, Newton for steady Navier-Stokes).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import skfem
from skfem import Basis, BilinearForm, ElementTetP1, ElementTetP2, FacetBasis, Functional, LinearForm
from skfem.helpers import dot, grad

from geometry.errors import ModelFailure


@dataclass(frozen=True)
class Fluid:
    """A Newtonian liquid: density rho [kg/m^3] and dynamic viscosity mu [Pa s]."""

    rho: float
    mu: float


@BilinearForm
def _laplace(u, v, w):
    return dot(grad(u), grad(v))


@BilinearForm
def _mass(u, v, w):
    return u * v


class ScalarAssembler:
    """Fast assembly of the scalar P2 matrices that change with the velocity (one sparsity pattern).

    The convection matrix int (w . grad phi_j) phi_i and the weighted masses int g phi_j phi_i
    are built from the basis values at the quadrature points and summed into a CSR pattern
    computed once (``np.bincount`` over the element entries); ~10x faster than a
    ``BilinearForm`` per matrix for the nine Newton reaction blocks.
    """

    def __init__(self, V: Basis):
        self.n = V.N
        nl = len(V.basis)
        self.phi = np.array([np.asarray(V.basis[i][0]) for i in range(nl)])        # (nl, ne, nq)
        self.dphi = np.array([V.basis[i][0].grad for i in range(nl)])        # (nl, 3, ne, nq)
        self.dx = V.dx
        dofs = V.element_dofs                                                  # (nl, ne)
        rows = np.repeat(dofs[:, None, :], nl, axis=1).ravel()                 # [i, j, e] -> dof_i
        cols = np.repeat(dofs[None, :, :], nl, axis=0).ravel()                 # [i, j, e] -> dof_j
        key = rows.astype(np.int64) * self.n + cols
        uniq, self.inverse = np.unique(key, return_inverse=True)
        self.indices = (uniq % self.n).astype(np.int32)
        self.indptr = np.searchsorted(uniq // self.n, np.arange(self.n + 1)).astype(np.int32)

    def _csr(self, local: np.ndarray) -> sp.csr_matrix:
        """CSR of element matrices local[i, j, e] (test i, trial j)."""
        data = np.bincount(self.inverse, weights=local.ravel(), minlength=len(self.indices))
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))

    def weighted_mass(self, g: np.ndarray) -> sp.csr_matrix:
        """int g phi_j phi_i dx for g at the quadrature points (ne, nq)."""
        gp = self.phi * (g * self.dx)[None]
        return self._csr(np.einsum("ieq,jeq->ije", self.phi, gp, optimize=True))

    def derivative_pair(self, a: int, b: int) -> sp.csr_matrix:
        """int (d phi_j / d x_b) (d phi_i / d x_a) dx: the (a, b) block of the grad-div form (div u, div v)."""
        gp = self.dphi[:, b] * self.dx[None]
        return self._csr(np.einsum("ieq,jeq->ije", self.dphi[:, a], gp, optimize=True))

    def convection(self, w: list[np.ndarray]) -> sp.csr_matrix:
        """int (w . grad phi_j) phi_i dx for the velocity w (3 arrays (ne, nq))."""
        adv = sum(w[b][None] * self.dphi[:, b] for b in range(3)) * self.dx[None]   # (nl, ne, nq), trial j
        return self._csr(np.einsum("ieq,jeq->ije", self.phi, adv, optimize=True))


def _div_form(a: int) -> BilinearForm:
    @BilinearForm
    def form(u, q, w):
        return -u.grad[a] * q
    return form


@dataclass
class System:
    """The discrete Taylor-Hood system on one mesh: bases, fixed matrices, Dirichlet data."""

    mesh: skfem.MeshTet
    V: Basis                 # scalar P2 (each velocity component)
    Q: Basis                 # P1 pressure
    K: sp.csr_matrix         # scalar Laplacian
    B: sp.csr_matrix         # (nQ, 3 nV): -int q div u
    fixed: np.ndarray        # Dirichlet DOFs (global numbering): velocities, and the orphan pressures
    fluid: Fluid
    fast: ScalarAssembler
    orphans: np.ndarray      # pressure DOFs (global) coupled to no free velocity (see :func:`assemble`)
    backflow: FacetBasis | None = None   # the open boundaries stabilised against backflow (``_backflow``)
    grad_div: sp.csr_matrix | None = None   # gamma (div u, div v) on the velocities (``grad_div_matrix``)
    inflow: FacetBasis | None = None     # inlets at a total pressure (``_backflow`` with INFLOW_BETA)

    @property
    def nv(self) -> int:
        return self.V.N

    @property
    def ndofs(self) -> int:
        return 3 * self.V.N + self.Q.N


def _facet_dofs(V: Basis, mesh, names) -> np.ndarray:
    """Scalar P2 DOFs on the named boundaries."""
    return np.unique(np.concatenate([V.get_dofs(mesh.boundaries[n]).all() for n in names
                                     if n in mesh.boundaries] or [np.zeros(0, int)]))


def grad_div_matrix(fast: ScalarAssembler, gamma: float) -> sp.csr_matrix:
    """gamma int (div u)(div v) dx on the three velocity components (3 nV x 3 nV), gamma [Pa s].

    Grad-div stabilisation: consistent (zero on a solenoidal field, so the exact solution is
    unchanged), it penalises the discrete divergence Taylor-Hood leaves (its velocity is only
    weakly solenoidal), which improves mass conservation and the conditioning of the Newton and
    Oseen systems as the Reynolds number grows (Olshanskii and Reusken 2004; Olshanskii, Lube,
    Heister and Loewe 2009, where gamma of order the viscosity to O(1) in units rho U L is advised).

    References: M. A. Olshanskii and A. Reusken (2004), Grad-div stabilization for Stokes
    equations, Math. Comp. 73, 1699-1718; M. Olshanskii, G. Lube, T. Heister and J. Loewe
    (2009), Grad-div stabilization and subgrid pressure models for the incompressible
    Navier-Stokes equations, Comput. Methods Appl. Mech. Engrg. 198, 3975-3988.
    """
    return gamma * sp.bmat([[fast.derivative_pair(a, b) for b in range(3)] for a in range(3)], format="csr")


def assemble(mesh: skfem.MeshTet, fluid: Fluid, no_slip=("wall", "reed"), symmetry: str = "symmetry",
             backflow=("outlet",), grad_div: float = 0.0, inflow=()) -> System:
    """Bases and the Stokes matrices; velocity fixed on ``no_slip`` boundaries and u_y on ``symmetry``;
    the open boundaries ``backflow`` stabilised where fluid enters through them (``_backflow``);
    ``grad_div`` gamma [Pa s] > 0 adds :func:`grad_div_matrix` to the velocity block; the open boundaries
    ``inflow`` take their traction as a total pressure (``_backflow`` with :data:`INFLOW_BETA`)."""
    V = Basis(mesh, ElementTetP2())
    Q = Basis(mesh, ElementTetP1(), quadrature=V.quadrature)
    K = _laplace.assemble(V).tocsr()
    B = sp.hstack([_div_form(a).assemble(V, Q) for a in range(3)]).tocsr()
    ns = _facet_dofs(V, mesh, no_slip)
    sym = _facet_dofs(V, mesh, [symmetry])
    n = V.N
    fixed = np.unique(np.concatenate([ns, ns + n, ns + 2 * n, sym + n]))
    # a pressure node whose cells have every velocity node on a wall (a corner of a one-layer
    # pocket at a wall) has no continuity equation and no effect on the momentum rows: the
    # discrete problem leaves it free, so it is fixed in the solve and set afterwards to the mean
    # of its neighbours (fill_orphans)
    free_v = np.ones(3 * n, bool)
    free_v[fixed] = False
    coupled = np.asarray(abs(B[:, free_v]).sum(axis=1)).ravel() > 0
    orphans = 3 * n + np.flatnonzero(~coupled)
    fb, fin = (_open_basis(mesh, names) for names in (backflow, inflow))
    fast = ScalarAssembler(V)
    return System(mesh=mesh, V=V, Q=Q, K=K, B=B, fixed=np.concatenate([fixed, orphans]), fluid=fluid,
                  fast=fast, orphans=orphans, backflow=fb, inflow=fin,
                  grad_div=grad_div_matrix(fast, grad_div) if grad_div > 0.0 else None)


def _open_basis(mesh: skfem.MeshTet, names) -> FacetBasis | None:
    """A P2 facet basis on the named boundaries (those the mesh has), None when there are none."""
    open_ = [mesh.boundaries[b] for b in names if b in mesh.boundaries and len(mesh.boundaries[b])]
    return FacetBasis(mesh, ElementTetP2(), facets=np.concatenate(open_)) if open_ else None


def fill_orphans(sys_: System, x: np.ndarray) -> np.ndarray:
    """x with every orphan pressure (:func:`assemble`) set to the mean of the pressures it shares a cell with."""
    if not len(sys_.orphans):
        return x
    n3 = 3 * sys_.nv
    t = sys_.mesh.t
    x = x.copy()
    for dof in sys_.orphans:
        node = dof - n3
        cells = np.flatnonzero(np.any(t == node, axis=0))
        nb = np.setdiff1d(np.unique(t[:, cells]), sys_.orphans - n3)
        if len(nb):
            x[dof] = x[n3 + nb].mean()
    return x


def traction_load(sys_: System, pressures: dict[str, float]) -> np.ndarray:
    """Right-hand side of the open boundaries: -int P n . v over each named boundary at pressure P [Pa]."""
    rhs = np.zeros(sys_.ndofs)
    n = sys_.nv
    for name, P in pressures.items():
        if P == 0.0 or name not in sys_.mesh.boundaries:
            continue
        fb = FacetBasis(sys_.mesh, ElementTetP2(), facets=sys_.mesh.boundaries[name])
        for a in range(3):
            @LinearForm
            def load(v, w, a=a):
                return -P * w.n[a] * v
            rhs[a * n:(a + 1) * n] += load.assemble(fb)
    return rhs


#: weight beta of the backflow stabilisation (``_backflow``): 1 makes the inflow's convective
#: energy flux dissipative (1/2 would only cancel it)
BACKFLOW_BETA = 1.0
#: beta on an inlet (``assemble``'s ``inflow``): 1/2 cancels the convective energy flux the inflow
#: carries in (the "directional do-nothing" condition, Braack and Mucha 2014), and makes the prescribed
#: P the total pressure there: for an inflow u = -U n the normal stress is -(P - rho U^2 / 2)
INFLOW_BETA = 0.5


@BilinearForm
def _facet_weighted_mass(u, v, w):
    return w["g"] * u * v


def _backflow(fb: FacetBasis, beta: float, rho: float, comps: list[np.ndarray], newton: bool) -> list[list]:
    """Blocks [a][b] of the backflow stabilisation on the open boundaries (None where zero).

    The term -beta rho int (u . n)_- u . v dA, (u . n)_- = min(u . n, 0), added to the momentum
    equation where fluid enters through an open ("do-nothing") boundary: the do-nothing
    condition lets the inflow carry kinetic energy rho/2 |u|^2 (u . n) into the domain, which
    destabilises steady and pseudo-time solves once a recirculation reaches the boundary
    (here the chamber vortex at the open sides from Re ~ 10); with beta = 1 that flux is
    dissipated, with beta = 1/2 cancelled (an inlet's P is then a total pressure, :data:`INFLOW_BETA`).
    Zero where the flow leaves, so it leaves outflow (and the Stokes limit) unchanged.
    ``newton``: with its derivative, -beta rho int H(-u . n) (du . n) u . v dA.
    References: Bazilevs, Gohean, Hughes, Moser and Zhang (2009), Comput. Methods Appl. Mech.
    Engrg. 198, 3534-3550, eq 14; Moghadam, Bazilevs, Hsia, Vignon-Clementel and Marsden (2011),
    Comput. Mech. 48, 277-291; M. Braack and P. B. Mucha (2014), Directional do-nothing condition
    for the Navier-Stokes equations, J. Comput. Math. 32, 507-521.
    """
    uf = [fb.interpolate(c) for c in comps]
    un = sum(np.asarray(uf[b]) * fb.normals[b] for b in range(3))
    coef = -beta * rho
    blocks = [[None] * 3 for _ in range(3)]
    diag = _facet_weighted_mass.assemble(fb, g=coef * np.minimum(un, 0.0)).tocsr()
    for a in range(3):
        blocks[a][a] = diag
    if newton:
        inflow = (un < 0.0).astype(float)
        for a in range(3):
            for b in range(3):
                C = _facet_weighted_mass.assemble(fb, g=coef * inflow * np.asarray(uf[a]) * fb.normals[b]).tocsr()
                blocks[a][b] = C if blocks[a][b] is None else blocks[a][b] + C
    return blocks


def _velocity_block(sys_: System, u: np.ndarray | None, newton: bool) -> sp.csr_matrix:
    """mu K + rho N(u) on each component (+ the rho d u_a / d x_b reaction blocks for Newton), and the
    grad-div term when the system has one."""
    A = sp.block_diag([sys_.fluid.mu * sys_.K] * 3, format="csr") if u is None else _flow_blocks(sys_, u, newton)
    return A if sys_.grad_div is None else (A + sys_.grad_div).tocsr()


def _flow_blocks(sys_: System, u: np.ndarray, newton: bool) -> sp.csr_matrix:
    """:func:`_velocity_block` at a velocity ``u`` without the grad-div term: the viscous and convective
    blocks, Newton's reaction blocks, the open boundaries' backflow terms."""
    rho, n = sys_.fluid.rho, sys_.nv
    comps = [sys_.V.interpolate(u[a * n:(a + 1) * n]) for a in range(3)]
    diag = sys_.fluid.mu * sys_.K + rho * sys_.fast.convection([np.asarray(c) for c in comps])
    blocks = [[diag if a == b else None for b in range(3)] for a in range(3)]
    extras = []
    if newton:
        extras.append([[rho * sys_.fast.weighted_mass(comps[a].grad[b]) for b in range(3)] for a in range(3)])
    extras += [_backflow(fb, beta, rho, [u[a * n:(a + 1) * n] for a in range(3)], newton)
               for fb, beta in ((sys_.backflow, BACKFLOW_BETA), (sys_.inflow, INFLOW_BETA)) if fb is not None]
    for extra in extras:
        for a in range(3):
            for b in range(3):
                if extra[a][b] is not None:
                    blocks[a][b] = extra[a][b] if blocks[a][b] is None else blocks[a][b] + extra[a][b]
    return sp.bmat(blocks, format="csr")


def _saddle(sys_: System, A: sp.csr_matrix) -> sp.csr_matrix:
    return sp.bmat([[A, sys_.B.T], [sys_.B, None]], format="csr")


class Factor:
    """An LU factorization of a (condensed) sparse matrix: PARDISO when installed, else SuperLU.

    ``solve(b)`` applies the inverse; used directly, or as the preconditioner of GMRES for a
    nearby matrix (a later Newton step or pressure difference).
    """

    def __init__(self, M: sp.csr_matrix):
        self.matrix = M
        try:
            import pypardiso
        except ImportError:  # pragma: no cover - the fallback when pypardiso is absent
            self._lu = sp.linalg.splu(M.tocsc())
            self._pardiso = None
        else:
            self._pardiso = pypardiso.PyPardisoSolver(mtype=11)
            self._pardiso.factorize(M)

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self._pardiso is None:  # pragma: no cover
            return self._lu.solve(b)
        # phase 33 (solve with the stored factors) directly: pypardiso's solve() hashes the
        # whole matrix on every call to see whether it is the factorized one
        self._pardiso.set_phase(33)
        return self._pardiso._call_pardiso(self.matrix, np.asarray(b, dtype=float))

    def free(self) -> None:
        if self._pardiso is not None:
            self._pardiso.free_memory(everything=True)


def _free_dofs(n: int, fixed: np.ndarray) -> np.ndarray:
    return np.setdiff1d(np.arange(n), fixed)


def _dirichlet_solve(M: sp.csr_matrix, rhs: np.ndarray, fixed: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Solve M x = rhs with x[fixed] = values (condensed, direct)."""
    x = np.zeros(M.shape[0])
    x[fixed] = values
    free = _free_dofs(M.shape[0], fixed)
    b = rhs[free] - M[free][:, fixed] @ values
    lu = Factor(M[free][:, free].tocsr())
    x[free] = lu.solve(b)
    lu.free()
    return x


def stokes(sys_: System, rhs: np.ndarray, wall_values: np.ndarray) -> np.ndarray:
    """Stokes solution [u_x, u_y, u_z, p] (SI) for load ``rhs`` and Dirichlet values on ``sys_.fixed``."""
    x = _dirichlet_solve(_saddle(sys_, _velocity_block(sys_, None, False)), rhs, sys_.fixed, wall_values)
    return fill_orphans(sys_, x)


def residual(sys_: System, x: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Navier-Stokes residual of the state x (free DOFs only matter)."""
    n3 = 3 * sys_.nv
    A = _velocity_block(sys_, x[:n3], False)
    return _saddle(sys_, A) @ x - rhs


#: GMRES with a frozen factorization as preconditioner: a correction is accepted when the
#: preconditioned residual fell below KRYLOV_ACCEPT of its start (inexact Newton: the outer
#: loop checks the update); after KRYLOV_MAX iterations without that the factorization is
#: renewed at the current state
KRYLOV_ACCEPT = 1e-4
KRYLOV_MAX = 30
#: a factorization whose GMRES needed more than this many iterations is renewed for the next step
#: (a new LU costs about as much as 15-20 iterations on the reed's meshes)
KRYLOV_REFRESH = 12


def _newton_step(J_ff: sp.csr_matrix, r: np.ndarray, factor: Factor | None) -> tuple[np.ndarray, Factor, int]:
    """Solve J_ff d = -r: GMRES preconditioned by ``factor`` when given, else (or when it stalls) a new LU."""
    if factor is not None:
        M = sp.linalg.LinearOperator(J_ff.shape, matvec=factor.solve, dtype=float)
        count = [0]

        def cb(_):
            count[0] += 1
        d, _ = sp.linalg.gmres(J_ff, -r, M=M, rtol=0.1 * KRYLOV_ACCEPT, restart=KRYLOV_MAX, maxiter=1,
                               callback=cb, callback_type="pr_norm")
        start = np.linalg.norm(factor.solve(-r))
        if np.linalg.norm(factor.solve(-r - J_ff @ d)) <= KRYLOV_ACCEPT * start:
            return d, factor, count[0]
        factor.free()
    factor = Factor(J_ff)
    return factor.solve(-r), factor, 0


def _refresh(factor: Factor | None, iterations: int) -> Factor | None:
    """``factor``, or None (freed: the next step factorizes) when its last GMRES solve needed more
    than :data:`KRYLOV_REFRESH` iterations."""
    if factor is not None and iterations > KRYLOV_REFRESH:
        factor.free()
        return None
    return factor


def _line_search(sys_: System, x: np.ndarray, d_full: np.ndarray, rhs: np.ndarray, free: np.ndarray,
                 r0: float) -> tuple[np.ndarray, float]:
    """Backtracking on the residual norm (free DOFs): the largest of 1, 1/2, 1/4, 1/8 of the
    Newton step that lowers it (Armijo, c = 1e-4); the smallest if none does."""
    for step in (1.0, 0.5, 0.25, 0.125):
        trial = x + step * d_full
        if np.linalg.norm(residual(sys_, trial, rhs)[free]) <= (1 - 1e-4 * step) * r0:
            return trial, step
    return trial, step


#: consecutive damped Newton steps after which a solve is abandoned (the iterate wanders: a
#: smaller continuation step is cheaper than 25 damped steps of a minute each)
MAX_DAMPED = 4


def newton(sys_: System, rhs: np.ndarray, x0: np.ndarray, tol: float = 1e-7, max_iter: int = 25,
           factor: Factor | None = None, progress: bool = False,
           max_damped: int = MAX_DAMPED) -> tuple[np.ndarray, int, Factor]:
    """Steady Navier-Stokes by (inexact, damped) Newton from x0, which carries the Dirichlet values.

    Each correction is solved by GMRES preconditioned with ``factor`` (a factorization of a
    nearby Jacobian, e.g. the previous pressure difference's) or, without one or when GMRES
    stalls, by a new LU of the current Jacobian; the step is damped by backtracking on the
    residual (``_line_search``). Stops when the largest velocity update is below ``tol``
    of the largest velocity after a full step. Returns (state, steps, the factorization in
    use). ModelFailure (its ``factor``: the factorization in use) when it does not converge
    in ``max_iter`` steps or after ``max_damped`` damped steps in a row (a steady laminar
    solution may not exist at that Reynolds number, the mesh does not resolve it, or the
    start is too far from it).
    """
    x = x0.copy()
    n3 = 3 * sys_.nv
    free = _free_dofs(sys_.ndofs, sys_.fixed)
    vel = np.flatnonzero(free < n3)            # velocity entries of the condensed vector
    change, damped, kry = np.inf, 0, 0
    for it in range(1, max_iter + 1):
        t0 = time.perf_counter()
        J = _saddle(sys_, _velocity_block(sys_, x[:n3], True))
        R = residual(sys_, x, rhs)
        factor = _refresh(factor, kry)
        d, factor, kry = _newton_step(J[free][:, free].tocsr(), R[free], factor)
        d_full = np.zeros_like(x)
        d_full[free] = d
        x, step = _line_search(sys_, x, d_full, rhs, free, float(np.linalg.norm(R[free])))
        change = step * np.max(np.abs(d[vel])) / max(np.max(np.abs(x[:n3])), 1e-300)
        if progress:
            print(f"  newton {it}: |du|/|u| = {change:.2e}, step {step:g}, {kry} GMRES steps "
                  f"({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
        if change < tol and step == 1.0:
            return fill_orphans(sys_, x), it, factor
        damped = damped + 1 if step < 1.0 else 0
        if damped >= max_damped:
            raise _failure(f"steady Navier-Stokes: {damped} damped Newton steps in a row (last relative "
                           f"velocity update {change:.2e}); the start is too far from a solution", factor)
    raise _failure(f"steady Navier-Stokes did not converge in {max_iter} Newton steps "
                   f"(last relative velocity update {change:.2e})", factor)


#: pseudo-transient continuation: the first pseudo-time step is PTC_CFL0 mean cell sizes over the
#: largest velocity of the start (a convective CFL number of 10 on the mean cell)
PTC_CFL0 = 10.0
#: a PTC iterate counts as steady (not merely slow) only once dt is this multiple of dt_0: the mass
#: term is then below its share of the start (the iteration is Newton's method)
PTC_STEADY = 1e3
#: growth of the pseudo-time step per PTC step at most (SER alone may jump by orders of magnitude
#: after one good step and leave the basin the small steps found)
PTC_GROWTH = 10.0
#: PTC steps before a solve is abandoned
PTC_MAX_STEPS = 30
#: the factorization is renewed when 1/dt changed by more than this factor since it was made (GMRES
#: preconditioned by a factorization of a very different pseudo-time step stalls)
PTC_REFACTOR = 3.0
#: a PTC solve whose residual grew to this multiple of its start is abandoned (a smaller continuation
#: step is cheaper than waiting for the pseudo-time flow to come back)
PTC_DIVERGED = 10.0
#: ... or whose residual set no new low in this many steps (the pseudo-time flow wanders: measured on
#: the reed at Re ~ 15, 1.71 mm, the residual oscillating between 0.2 and 5 of its start)
PTC_PATIENCE = 8


def velocity_mass(sys_: System) -> sp.csr_matrix:
    """rho int u . v dx on the three velocity components, zero on the pressure block (ndofs x ndofs)."""
    M = sys_.fluid.rho * _mass.assemble(sys_.V).tocsr()
    return sp.block_diag([M, M, M, sp.csr_matrix((sys_.Q.N, sys_.Q.N))], format="csr")


def ptc(sys_: System, rhs: np.ndarray, x0: np.ndarray, tol: float = 1e-7, max_iter: int = PTC_MAX_STEPS,
        factor: Factor | None = None, progress: bool = False) -> tuple[np.ndarray, int, Factor]:
    """Steady Navier-Stokes by pseudo-transient continuation (PTC) from x0, which carries the Dirichlet values.

    Each step is one linearly implicit (backward Euler) step in pseudo-time of the momentum
    equation, (M / dt_k + J(x_k)) d = -R(x_k) with M the velocity mass (rho, :func:`velocity_mass`)
    and J the Newton Jacobian, x_{k+1} = x_k + d, no line search; the pseudo-time step follows the
    residual by switched evolution relaxation, dt_{k+1} = dt_k ||R(x_k)|| / ||R(x_{k+1})||
    (Mulder and van Leer 1985; by at most a factor :data:`PTC_GROWTH` either way), so the iteration follows the
    time-dependent flow while the residual is large (where Newton's basin is small: a damped
    Newton step is a Picard-like step with a large mass term) and becomes Newton's method as
    the residual vanishes (dt -> infinity): global convergence to a stable steady state and
    local quadratic convergence (Kelley and Keyes 1998). dt_0 = :data:`PTC_CFL0` mean cell sizes
    over the largest velocity of x0. The linear systems as in :func:`newton` (GMRES preconditioned
    by the last factorization, renewed when 1/dt changed by more than :data:`PTC_REFACTOR`).
    Stops when the largest velocity update is below ``tol`` of the largest velocity with dt at least
    :data:`PTC_STEADY` dt_0 (a small update from a small pseudo-time step is not a steady state). Returns
    (state, steps, factorization in use); ModelFailure (with ``.factor``) after ``max_iter`` steps
    or when the residual grows to :data:`PTC_DIVERGED` times its start or sets no new low in
    :data:`PTC_PATIENCE` steps (no stable steady state reached).

    References: C. T. Kelley and D. E. Keyes (1998), Convergence analysis of pseudo-transient
    continuation, SIAM J. Numer. Anal. 35(2), 508-523; W. A. Mulder and B. van Leer (1985),
    Experiments with implicit upwind methods for the Euler equations, J. Comput. Phys. 59, 232-246.
    """
    x = x0.copy()
    n3 = 3 * sys_.nv
    free, vel, M, dt0 = _ptc_start(sys_, x)
    dt = dt0
    R = residual(sys_, x, rhs)
    r0 = r = best = float(np.linalg.norm(R[free]))
    dt_f, kry, since = np.inf, 0, 0                  # the pseudo-time step of the factorization in use
    for it in range(1, max_iter + 1):
        t0 = time.perf_counter()
        factor = _ptc_current(factor, dt, dt_f, dt0)
        J = _saddle(sys_, _velocity_block(sys_, x[:n3], True))[free][:, free].tocsr() + M / dt
        factor = _refresh(factor, kry)
        old = factor
        d, factor, kry = _newton_step(J, R[free], factor)
        if factor is not old:
            dt_f = dt
        x[free] += d
        change = float(np.max(np.abs(d[vel])) / max(np.max(np.abs(x[:n3])), 1e-300))
        R = residual(sys_, x, rhs)
        r_new = float(np.linalg.norm(R[free]))
        if progress:
            print(f"  ptc {it}: |R|/|R0| = {r_new / r0:.2e}, |du|/|u| = {change:.2e}, dt = {dt:.2e} s, "
                  f"{kry} GMRES steps ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
        if change < tol and dt >= PTC_STEADY * dt0:       # a small update, not a small pseudo-time step
            return fill_orphans(sys_, x), it, factor
        best, since = _ptc_progress(r_new, r0, best, since, factor)
        dt = _ptc_next_dt(dt, r, r_new)
        r = r_new
    raise _failure(f"pseudo-transient continuation did not converge in {max_iter} steps "
                   f"(last relative velocity update {change:.2e})", factor)


def _ptc_start(sys_: System, x: np.ndarray) -> tuple:
    """(free dofs, their velocity positions, the velocity mass on them, the first pseudo-time step [s]) of
    :func:`ptc`: dt_0 = :data:`PTC_CFL0` mean cell sizes over the largest velocity of ``x``."""
    n3 = 3 * sys_.nv
    free = _free_dofs(sys_.ndofs, sys_.fixed)
    M = velocity_mass(sys_)[free][:, free].tocsr()
    h = float(np.cbrt(np.sum(sys_.V.dx) / sys_.mesh.t.shape[1]))        # mean cell size [m]
    return free, np.flatnonzero(free < n3), M, PTC_CFL0 * h / max(float(np.max(np.abs(x[:n3]))), 1e-300)


def _ptc_current(factor: Factor | None, dt: float, dt_f: float, dt0: float) -> Factor | None:
    """The factorization to precondition a :func:`ptc` step at pseudo-time step ``dt`` with (``dt_f``: the one
    it was made at): freed and None when 1/dt changed by more than :data:`PTC_REFACTOR` since, unless both
    steps are steady-sized (at least :data:`PTC_STEADY` dt_0, where the mass term no longer matters)."""
    if factor is not None and max(dt_f / dt, dt / dt_f) > PTC_REFACTOR and min(dt, dt_f) < PTC_STEADY * dt0:
        factor.free()
        return None
    return factor


def _ptc_next_dt(dt: float, r: float, r_new: float) -> float:
    """The next pseudo-time step by switched evolution relaxation, dt ||R_k|| / ||R_k+1||, by at most a factor
    :data:`PTC_GROWTH` either way (:func:`ptc`)."""
    return dt * float(np.clip(r / r_new, 1.0 / PTC_GROWTH, PTC_GROWTH))


def _ptc_progress(r_new: float, r0: float, best: float, since: int, factor: Factor | None) -> tuple[float, int]:
    """(the lowest residual so far, steps since it) after a :func:`ptc` step with residual norm ``r_new``;
    ModelFailure when the residual grew to :data:`PTC_DIVERGED` times its start ``r0`` or set no new low in
    :data:`PTC_PATIENCE` steps."""
    if not np.isfinite(r_new) or r_new > PTC_DIVERGED * r0:
        raise _failure(f"pseudo-transient continuation diverged (residual {r_new / r0:.2e} of its start)", factor)
    best, since = (r_new, 0) if r_new < best else (best, since + 1)
    if since >= PTC_PATIENCE:
        raise _failure(f"pseudo-transient continuation does not settle (no new low of the residual in "
                       f"{since} steps; {r_new / r0:.2e} of its start)", factor)
    return best, since


def _failure(message: str, factor: Factor | None) -> ModelFailure:
    """A ModelFailure carrying the factorization in use (``.factor``: the caller may precondition a
    retry with it, and frees it)."""
    exc = ModelFailure(message)
    exc.factor = factor
    return exc


def mesh_peclet(sys_: System, x: np.ndarray) -> np.ndarray:
    """The mesh Peclet (cell Reynolds) number of each cell, P_T = |u|_T h_T / (2 nu) [-].

    |u|_T the largest speed at the cell's vertices, h_T its longest edge, nu = mu / rho. Where
    P_T > 1 the Galerkin discretization of convection is not resolved on the cell (Elman,
    Silvester and Wathen 2014, section 6.3 and ch. 8: oscillations of the unstabilised scheme in
    boundary and shear layers); reported beside the results, not used by the solver.
    """
    mesh, n = sys_.mesh, sys_.nv
    vdofs = sys_.V.nodal_dofs[0]                                   # vertex -> its P2 DOF
    speed = np.sqrt(sum(x[a * n + vdofs] ** 2 for a in range(3)))
    t, p = mesh.t, mesh.p
    pairs = [(i, j) for i in range(4) for j in range(i + 1, 4)]
    h = np.max([np.linalg.norm(p[:, t[i]] - p[:, t[j]], axis=0) for i, j in pairs], axis=0)
    nu = sys_.fluid.mu / sys_.fluid.rho
    return np.max(speed[t], axis=0) * h / (2.0 * nu)


def boundary_flux(sys_: System, x: np.ndarray, name: str) -> float:
    """Volume flow OUT of the domain through boundary ``name`` [m^3/s]: int u . n dA."""
    fb = FacetBasis(sys_.mesh, ElementTetP2(), facets=sys_.mesh.boundaries[name])
    n = sys_.nv
    comps = [fb.interpolate(x[a * n:(a + 1) * n]) for a in range(3)]

    @Functional
    def flux(w):
        return w["u0"] * w.n[0] + w["u1"] * w.n[1] + w["u2"] * w.n[2]
    return float(flux.assemble(fb, u0=comps[0], u1=comps[1], u2=comps[2]))
