"""Steady laminar incompressible Navier-Stokes in axisymmetric (r, z) coordinates: Taylor-Hood P2-P1, Newton.

The flow without swirl, u = (u_r, u_z)(r, z), obeys (Batchelor 1967, appendix 2)

    rho (u . grad) u_r = -dp/dr + mu (lap u_r - u_r / r^2),
    rho (u . grad) u_z = -dp/dz + mu lap u_z,
    (1/r) d(r u_r)/dr + du_z/dz = 0,

with lap f = (1/r) d/dr(r df/dr) + d^2 f/dz^2. Multiplied by r (the axisymmetric volume element
is 2 pi r dr dz) and integrated by parts over the meridian plane, the weak form is

    a(u, v) + c(u; u, v) + b(v, p) = <t, v>,   b(u, q) = 0,
    a(u, v) = int mu (grad u_r . grad v_r + grad u_z . grad v_z + u_r v_r / r^2) r dA,
    b(v, q) = -int q (dv_r/dr + v_r / r + dv_z/dz) r dA,
    c(w; u, v) = int rho ((w . grad) u) . v r dA,

(explicit ``BilinearForm``/``LinearForm`` below), on Taylor-Hood elements (P2 velocity, P1
pressure: inf-sup stable; velocity error O(h^3) in L2, pressure O(h^2); Elman, Silvester and
Wathen 2014, ch. 3). The Laplacian form's natural condition mu du/dn - p n = -p_b n is the
"do-nothing" outflow (exact for developed pipe flow) and a pressure inlet or outlet at p_b. On a
rigid no-slip wall it equals the true traction (there (grad u)^T n = n du_n/dn = 0), so the
force on a wall is the reaction of its Dirichlet values in the residual of the weak form
(consistent, exactly conservative). Boundary conditions: on the axis u_r = 0 (the symmetry of
the revolved field); walls and inflows prescribe u; pressure boundaries prescribe p_b.

Solution: the problem is made dimensionless with a length l and a velocity V (p in mu V / l,
so the only parameter is Re_l = rho V l / mu), solved first without inertia (Stokes, linear),
then by Newton's method (the exact Jacobian of c) along a continuation in the density
rho_k = lambda_k rho (lambda from 0 to 1; a step that fails to converge is halved). Each
Newton step is one direct sparse LU (SuperLU through scipy) of the saddle-point system.

References
----------
Batchelor (1967), An Introduction to Fluid Dynamics, appendix 2.
Elman, Silvester and Wathen (2014), Finite Elements and Fast Iterative Solvers, 2nd ed.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import Basis, BilinearForm, ElementTriP1, ElementTriP2, ElementVector, FacetBasis, LinearForm
from skfem.helpers import ddot, div, dot, grad, mul

#: a prescribed velocity [m/s]: a constant (u_r, u_z) or a callable (r, z) -> (u_r, u_z) in metres
Velocity = tuple | Callable


@dataclass(frozen=True)
class FlowBCs:
    """Boundary conditions by boundary name (every named boundary of the mesh in exactly one).

    ``axis``: r = 0, u_r = 0; ``velocity``: prescribed u [m/s] (walls: (0, 0), a moving disc:
    (0, U), an inflow: a profile); ``pressure``: p_b [Pa], a number or a callable (r, z) [m],
    with mu du/dn - p n = -p_b n (outflow or a pressure inlet).
    """

    axis: tuple = ()
    velocity: Mapping[str, Velocity] = field(default_factory=dict)
    pressure: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class FlowOptions:
    """Solver settings: Newton's tolerance on the relative velocity update and iteration cap, the
    smallest continuation step (density fraction), progress on stderr."""

    tolerance: float = 1e-9
    intermediate_tolerance: float = 1e-3
    max_newton: int = 12
    min_step: float = 1e-3
    progress: bool = False


@dataclass(frozen=True)
class FlowSolution:
    """A solved flow in SI units: u (DOFs of ``ubasis``) [m/s], p (DOFs of ``pbasis``) [Pa].

    ``forces[name]`` = F_z [N]: the axial force of the fluid on that velocity boundary over the
    whole revolution (the radial one cancels by symmetry); ``newton`` the Newton steps taken,
    ``factorisations`` the sparse LU factorisations among them.
    """

    ubasis: Basis
    pbasis: Basis
    u: np.ndarray
    p: np.ndarray
    forces: dict
    length: float
    density: float
    viscosity: float
    newton: int
    seconds: float
    dofs: int
    factorisations: int = 0

    def flow(self, facets) -> float:
        """Volume flow [m^3/s] through ``facets`` (a boundary name or indices), 2 pi int u . n r ds,
        along the facets' normals (outward on the domain boundary)."""
        fb = self._facets(facets)
        uu = np.asarray(fb.interpolate(self.u))
        r = np.asarray(fb.global_coordinates())[0]
        return float(2 * math.pi * ((uu[0] * fb.normals[0] + uu[1] * fb.normals[1]) * r * fb.dx).sum())

    def mean_pressure(self, facets) -> float:
        """Area-weighted mean pressure [Pa] over ``facets`` (int p r ds / int r ds)."""
        fb = self._facets(facets, scalar=True)
        pp = np.asarray(fb.interpolate(self.p))
        r = np.asarray(fb.global_coordinates())[0]
        return float((pp * r * fb.dx).sum() / (r * fb.dx).sum())

    def facet_integral(self, facets, integrand: Callable) -> float:
        """2 pi int integrand(u_r, u_z, r, z) r ds [SI] over ``facets`` (interior facets allowed)."""
        fb = self._facets(facets)
        uu = np.asarray(fb.interpolate(self.u))
        x = np.asarray(fb.global_coordinates())
        return float(2 * math.pi * (integrand(uu[0], uu[1], x[0], x[1]) * x[0] * fb.dx).sum())

    def probe(self, r, z) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u_r, u_z [m/s], p [Pa]) at the points (r, z) [m] (each inside the mesh)."""
        pts = np.vstack([np.atleast_1d(r), np.atleast_1d(z)]).astype(float)
        uu = self.ubasis.probes(pts) @ self.u
        n = pts.shape[1]
        return uu[:n], uu[n:], self.pbasis.probes(pts) @ self.p

    def _facets(self, facets, scalar: bool = False) -> FacetBasis:
        mesh = self.ubasis.mesh
        ids = mesh.boundaries[facets] if isinstance(facets, str) else np.asarray(facets)
        elem = self.pbasis.elem if scalar else self.ubasis.elem
        return FacetBasis(mesh, elem, facets=ids, intorder=6)


# ------------------------------------------------------------------ weak forms (dimensionless)
@BilinearForm
def viscous(u, v, w):
    """a(u, v) / mu: int (grad u : grad v + u_r v_r / r^2) r dA."""
    r = w.x[0]
    return (ddot(grad(u), grad(v)) + u[0] * v[0] / r**2) * r


@BilinearForm
def divergence(u, q, w):
    """b(u, q) = -int q (du_r/dr + u_r / r + du_z/dz) r dA (trial u, test q)."""
    r = w.x[0]
    return -q * (div(u) + u[0] / r) * r


@BilinearForm
def convection_jacobian(du, v, w):
    """Re d c(u; u, v) = Re int ((u0 . grad) du + (du . grad) u0) . v r dA (Newton's Jacobian at u0)."""
    u0 = w["u0"]
    return w.re * dot(mul(grad(du), u0) + mul(grad(u0), du), v) * w.x[0]


@LinearForm
def convection_residual(v, w):
    """Re c(u0; u0, v) = Re int ((u0 . grad) u0) . v r dA."""
    u0 = w["u0"]
    return w.re * dot(mul(grad(u0), u0), v) * w.x[0]


@LinearForm
def pressure_traction(v, w):
    """<t, v> = -int p_b n . v r ds of a pressure boundary (w.pb its dimensionless pressure)."""
    return -w.pb * dot(w.n, v) * w.x[0]


# ------------------------------------------------------------------ assembly and solution
class _System:
    """The dimensionless Taylor-Hood system on one mesh: constant blocks and the boundary data."""

    def __init__(self, mesh, bcs: FlowBCs, length: float, vscale: float, viscosity: float):
        self.pscale = viscosity * vscale / length          # the pressure unit mu V / l [Pa]
        self.mesh = mesh.scaled(1.0 / length)
        self.ub = Basis(self.mesh, ElementVector(ElementTriP2()), intorder=4)
        self.pb = self.ub.with_element(ElementTriP1())
        self.nu, self.np_ = self.ub.N, self.pb.N
        A = viscous.assemble(self.ub)
        B = divergence.assemble(self.ub, self.pb)
        self.stokes = sp.bmat([[A, B.T], [B, None]], format="csr")
        self.f = np.zeros(self.nu + self.np_)
        self.x_d = np.zeros(self.nu + self.np_)
        fixed = []
        named = self.mesh.boundaries or {}
        _check_cover(self.mesh, named, bcs)
        for name in bcs.axis:
            fixed.append(self.ub.get_dofs(named[name]).all("u^1"))
        for name, vel in bcs.velocity.items():
            dofs = self.ub.get_dofs(named[name])
            fixed.append(self._prescribe(dofs, vel, length, vscale))
        for name, pb in bcs.pressure.items():
            fb = FacetBasis(self.mesh, self.ub.elem, facets=named[name], intorder=4)
            if callable(pb):
                xy = np.asarray(fb.global_coordinates()) * length
                pb = np.asarray(pb(xy[0], xy[1]), dtype=float)
            self.f[: self.nu] += pressure_traction.assemble(fb, pb=pb / self.pscale)
        self.fixed = np.unique(np.concatenate(fixed)) if fixed else np.zeros(0, dtype=int)
        self.free = np.setdiff1d(np.arange(self.nu + self.np_), self.fixed)

    def _prescribe(self, dofs, vel, length: float, vscale: float) -> np.ndarray:
        """Set the Dirichlet values of ``dofs`` (both components) from ``vel`` [m/s]; return the indices."""
        out = []
        for comp, key in enumerate(("u^1", "u^2")):
            idx = dofs.all(key)
            if callable(vel):
                xy = self.ub.doflocs[:, idx] * length
                val = np.asarray(vel(xy[0], xy[1])[comp], dtype=float)
            else:
                val = float(vel[comp])
            self.x_d[idx] = val / vscale
            out.append(idx)
        return np.concatenate(out)

    def residual(self, x: np.ndarray, re: float) -> np.ndarray:
        """The full residual K x + Re c(u; u, .) - f (every DOF, boundary reactions included)."""
        r = self.stokes @ x - self.f
        if re:
            r[: self.nu] += convection_residual.assemble(self.ub, u0=self.ub.interpolate(x[: self.nu]), re=re)
        return r

    def jacobian(self, x: np.ndarray, re: float):
        if not re:
            return self.stokes
        C = convection_jacobian.assemble(self.ub, u0=self.ub.interpolate(x[: self.nu]), re=re)
        return (self.stokes + sp.bmat([[C, None], [None, sp.csr_matrix((self.np_, self.np_))]])).tocsr()


def _check_cover(mesh, named: Mapping, bcs: FlowBCs) -> None:
    """Every named boundary in exactly one condition and every boundary facet named (ValueError)."""
    used = [*bcs.axis, *bcs.velocity, *bcs.pressure]
    missing = [n for n in used if n not in named]
    if missing:
        raise ValueError(f"the mesh has no boundary {', '.join(missing)}")
    twice = sorted({n for n in used if used.count(n) > 1})
    if twice:
        raise ValueError(f"boundary in two conditions: {', '.join(twice)}")
    covered = np.concatenate([named[n] for n in used]) if used else np.zeros(0, dtype=int)
    loose = np.setdiff1d(mesh.boundary_facets(), covered)
    if loose.size:
        raise ValueError(f"{loose.size} boundary facets have no condition (name every boundary of the mesh)")


class _Linear:
    """Solves J dx = b on the free DOFs by a sparse LU (SuperLU, COLAMD ordering): 2-D saddle-point
    systems of up to a few 10^5 unknowns factorise in seconds. (Reusing a factorisation as the
    preconditioner of GMRES for later Newton steps was measured slower: 31 s against 7 s.)"""

    def __init__(self, free: np.ndarray):
        self.free, self.factorisations = free, 0

    def solve(self, J, b: np.ndarray) -> np.ndarray:
        self.factorisations += 1
        return spla.splu(J[self.free][:, self.free].tocsc(), permc_spec="COLAMD").solve(b)


#: dimensionless Reynolds number of the first continuation step (Newton converges from Stokes below it)
FIRST_STEP_RE = 20.0
#: ratio between successive continuation steps
STEP_GROWTH = 4.0


def _newton(sys_: _System, x: np.ndarray, re: float, opts: FlowOptions, lin: _Linear) -> tuple[np.ndarray, int, bool]:
    """Newton's method at Reynolds number ``re`` from ``x`` (Dirichlet values already in place)."""
    free = sys_.free
    nfree_u = int(np.searchsorted(free, sys_.nu))
    scale = max(float(np.abs(x[: sys_.nu]).max()), 1e-30)
    for k in range(1, opts.max_newton + 1):
        dx = lin.solve(sys_.jacobian(x, re), -sys_.residual(x, re)[free])
        if not np.all(np.isfinite(dx)):
            return x, k, False
        x = x.copy()
        x[free] += dx
        step = float(np.abs(dx[:nfree_u]).max()) / scale
        if opts.progress:
            print(f"  newton {k}: Re_l {re:.4g}, relative update {step:.2e}", file=sys.stderr, flush=True)
        if step < opts.tolerance:
            return x, k, True
        if step > 1e3:
            return x, k, False
    return x, opts.max_newton, False


def continuation_steps(re_full: float, start: float = 0.0) -> list:
    """Density fractions of the continuation from ``start``: the first at Re_l = FIRST_STEP_RE, then
    STEP_GROWTH times the last, the full problem (1.0) last."""
    steps, lam = [], max(start, FIRST_STEP_RE / re_full if re_full > 0 else 1.0)
    while lam < 1.0:
        steps.append(lam)
        lam *= STEP_GROWTH
    return steps + [1.0]


def solve_flow(mesh, bcs: FlowBCs, density: float, viscosity: float, length: float, velocity: float,
               options: FlowOptions = FlowOptions(), initial: FlowSolution | None = None) -> FlowSolution:
    """Solve the steady axisymmetric flow (module docstring) on ``mesh`` [m] with ``bcs``.

    ``length`` [m] and ``velocity`` [m/s] are the scales of the dimensionless system; any
    positive values give the same flow, but the continuation steps are set by Re_l = rho V l / mu,
    so they should make Re_l the Reynolds number that governs the flow's inertia (for a valve:
    the jet velocity and the gap's hydraulic diameter). ``initial``: a solution on the same
    mesh to start Newton from (a nearby operating point); if Newton fails from it, the
    continuation starts again from Stokes. RuntimeError when Newton does not converge even with
    the smallest continuation step.

    Examples
    --------
    Developed pipe flow (Hagen-Poiseuille) in a 1 mm radius, 5 mm pipe of the thesis oil:
    dP = 8 mu Q L / (pi R^4) = 8 * 0.0683 * 1e-6 * 5e-3 / (pi * 1e-12) = 869.6 Pa

    >>> from skfem import MeshTri
    >>> m = MeshTri.init_tensor(np.linspace(0, 1e-3, 5), np.linspace(0, 5e-3, 11)).with_boundaries({
    ...     "axis": lambda x: x[0] < 1e-12, "wall": lambda x: x[0] > 1e-3 - 1e-12,
    ...     "in": lambda x: x[1] < 1e-12, "out": lambda x: x[1] > 5e-3 - 1e-12})
    >>> V = 1e-6 / (math.pi * 1e-6)
    >>> bcs = FlowBCs(axis=("axis",), velocity={"wall": (0.0, 0.0),
    ...               "in": lambda r, z: (0 * r, 2 * V * (1 - (r / 1e-3) ** 2))}, pressure={"out": 0.0})
    >>> s = solve_flow(m, bcs, 876.0, 0.0683, 1e-3, V)
    >>> print(f"{s.mean_pressure('in'):.1f} Pa")
    869.6 Pa
    """
    t0 = time.perf_counter()
    sys_ = _System(mesh, bcs, length, velocity, viscosity)
    lin = _Linear(sys_.free)
    re_full = density * velocity * length / viscosity
    total = 0
    if initial is not None and re_full > 0:
        x = np.concatenate([initial.u / velocity, initial.p / (viscosity * velocity / length)])
        x[sys_.fixed] = sys_.x_d[sys_.fixed]
        trial, total, ok = _newton(sys_, x, re_full, options, lin)
        if ok:
            return _finish(sys_, trial, re_full, length, velocity, density, viscosity, bcs, total, t0, lin)
    x = sys_.x_d.copy()
    x[sys_.free] = lin.solve(sys_.stokes, -sys_.residual(x, 0.0)[sys_.free])      # Stokes: linear
    total += 1
    steps, lam = (continuation_steps(re_full) if re_full > 0 else []), 0.0
    while steps:
        target = steps[0]
        tol = options.tolerance if target == 1.0 else options.intermediate_tolerance
        trial, k, ok = _newton(sys_, x, target * re_full, replace(options, tolerance=tol), lin)
        total += k
        if ok:
            x, lam = trial, target
            steps.pop(0)
            continue
        if target - lam < options.min_step:
            raise RuntimeError(f"Newton did not converge at Re_l = {target * re_full:.4g} (density fraction "
                               f"{target:.3g}) even with continuation steps of {target - lam:.2g}")
        steps.insert(0, 0.5 * (lam + target))
    return _finish(sys_, x, re_full, length, velocity, density, viscosity, bcs, total, t0, lin)


def _finish(sys_, x, re, length, velocity, density, viscosity, bcs, newton, t0, lin) -> FlowSolution:
    """Dimensional fields and the wall forces from the residual's reactions."""
    pscale = viscosity * velocity / length
    r = sys_.residual(x, re)
    fscale = 2 * math.pi * viscosity * velocity * length      # force of a unit dimensionless traction
    named = sys_.mesh.boundaries
    forces, taken = {}, np.zeros(sys_.nu, dtype=bool)
    for name in bcs.velocity:
        idx = sys_.ub.get_dofs(named[name]).all("u^2")
        idx = idx[~taken[idx]]
        taken[idx] = True
        forces[name] = -fscale * float(r[idx].sum())
    ub = Basis(sys_.mesh.scaled(length), sys_.ub.elem, intorder=4)
    pb = ub.with_element(ElementTriP1())
    return FlowSolution(ubasis=ub, pbasis=pb, u=x[: sys_.nu] * velocity, p=x[sys_.nu:] * pscale, forces=forces,
                        length=length, density=density, viscosity=viscosity, newton=newton,
                        seconds=time.perf_counter() - t0, dofs=int(sys_.nu + sys_.np_),
                        factorisations=lin.factorisations)
