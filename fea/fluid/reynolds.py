"""The Reynolds thin-film equation on any 2-D triangle mesh (scikit-fem, P1 or P2).

A film of thickness h(x, y) [m] between two walls, one of them moving apart at the rate
dh/dt [m/s], carries the volume flux q = -(h^3 / (12 mu)) grad p [m^2/s] (Poiseuille flow
between plates; the walls do not slide, so there is no Couette term). Mass conservation
gives the Reynolds equation (Hamrock et al. 2004, eq 7.58 without sliding; thesis eq 2.7)

    div( h^3 / (12 mu) grad p ) = dh/dt      in the film,
    p = p_b on the named Dirichlet boundaries b,   q . n = 0 on the others,

solved in its weak form  a(p, v) = l(v)  with  a(p, v) = int h^3 / (12 mu) grad p . grad v dA
and  l(v) = -int dh/dt v dA  (explicit ``BilinearForm``/``LinearForm``). The problem is
linear, so the pressure splits into a Poiseuille part (the boundary pressures, dh/dt = 0)
and a squeeze part (zero boundary pressures, the wall velocity): both are solved with one
factorisation and returned apart, which gives the thesis's C1 and C2 (eqs 2.13-2.15) for
any footprint.

Outputs: the pressure field; the force  F = int psi (p - p_ref) dA  [N] (psi a mode
function for a reed's pressure load multiplier X of eq 3.49, 1 for a rigid disc; p_ref the
pressure on the wall's other side) and its two parts; the volume flow out of each named
boundary [m^3/s] from the consistent residual of the weak form (the reaction of the
Dirichlet values: exactly conservative, flows + int dh/dt dA = 0 to round-off).

Cavitation (option ``cavitation_pressure``): a pressure floor p >= p_cav solved as the
complementarity problem of the Reynolds (Swift-Stieber) condition in its variational form
(Christopherson's obstacle problem; Kinderlehrer and Stampacchia 1980): p >= p_cav,
a(p, v) - l(v) >= 0 for every nodal test function, with equality where p > p_cav. It is
solved by the primal-dual active-set method (Hintermueller, Ito and Kunisch 2002), which
for the P1 M-matrix converges in a few iterations. The floor is imposed at the nodes. It
is not mass-conserving across the cavity (the Elrod / JFO form is): where the film ruptures
the multiplier is a volume source, reported as ``cavity_source``.

References
----------
Hamrock, Schmid and Jacobson (2004), Fundamentals of Fluid Film Lubrication, 2nd ed., ch. 7.
Knutson (2016), eqs 2.7-2.15 (the disc's conical film), 3.49-3.60 (the reed's film).
Hintermueller, Ito and Kunisch (2002), SIAM J. Optim. 13, 865-888.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np
import scipy.sparse.linalg as spla
from skfem import Basis, BilinearForm, ElementTriP1, ElementTriP2, LinearForm
from skfem.helpers import dot, grad

from geometry.errors import InputError

#: a field over the film: a number, a callable f(x, y) -> array [SI], or nodal values (one per
#: mesh vertex, interpolated linearly, or one per DOF of the solution basis)
Field = float | Callable | np.ndarray


@dataclass(frozen=True)
class FilmOptions:
    """How to solve the film.

    ``order`` 1 (P1) or 2 (P2) Lagrange elements; ``cavitation_pressure`` [Pa] the floor of the
    film pressure (None: no floor); ``reference_pressure`` [Pa] subtracted in the force (the
    pressure behind the moving wall); ``weight`` psi of the force integral (None: 1);
    ``intorder`` the quadrature order (None: exact for h^3 of a linear gap with P2).
    """

    order: int = 1
    cavitation_pressure: float | None = None
    reference_pressure: float = 0.0
    weight: Field | None = None
    intorder: int | None = None
    max_active_set_iterations: int = 100


@dataclass(frozen=True)
class FilmSolution:
    """A solved film (SI units; flows positive out of the film).

    ``pressure`` are the DOF values [Pa] in ``basis``; ``force`` = int psi (p - p_ref) dA [N]
    with its ``force_poiseuille`` (boundary pressures alone) and ``force_squeeze`` (wall
    velocity alone) parts, which add up to ``force`` unless the film cavitated; ``flows``
    {boundary: Q [m^3/s]} likewise with ``flows_poiseuille`` and ``flows_squeeze``.
    """

    basis: Basis
    pressure: np.ndarray
    force: float
    force_poiseuille: float
    force_squeeze: float
    flows: dict
    flows_poiseuille: dict
    flows_squeeze: dict
    area: float
    weight_integral: float
    cavitated_area: float = 0.0
    cavity_source: float = 0.0
    active_set_iterations: int = 0
    dofs: int = 0
    extra: dict = field(default_factory=dict)


@BilinearForm
def film_stiffness(p, v, w):
    """a(p, v) = int h^3 / (12 mu) grad p . grad v dA (w.k = h^3 / (12 mu) [m^3 / (Pa s)])."""
    return w.k * dot(grad(p), grad(v))


@LinearForm
def squeeze_load(v, w):
    """l(v) = -int dh/dt v dA (w.hdot [m/s], > 0 where the walls separate)."""
    return -w.hdot * v


@LinearForm
def weighted_area(v, w):
    """int psi v dA: the force per nodal pressure (w.psi the weight)."""
    return w.psi * v


def _element(order: int):
    if order == 1:
        return ElementTriP1()
    if order == 2:
        return ElementTriP2()
    raise InputError("order", f"the film has P1 or P2 elements (order 1 or 2), got {order!r}")


def at_quadrature(basis: Basis, value: Field, name: str) -> np.ndarray:
    """A film field at the quadrature points of ``basis`` (shape (elements, points)).

    ``value``: a number, a callable f(x, y) of the coordinates [m], or nodal values, one per
    mesh vertex (interpolated linearly) or one per DOF of ``basis``; InputError naming
    ``name`` otherwise.
    """
    shape = (basis.nelems, basis.X.shape[-1])
    if callable(value):
        x = basis.global_coordinates()
        out = np.asarray(value(x[0], x[1]), dtype=float)
        return np.broadcast_to(out, shape).copy()
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return np.full(shape, float(arr))
    if arr.shape == (basis.N,):
        return np.asarray(np.asarray(basis.interpolate(arr)))
    mesh = basis.mesh
    if arr.shape == (mesh.p.shape[1],):
        p1 = Basis(mesh, ElementTriP1(), quadrature=basis.quadrature)
        return np.asarray(np.asarray(p1.interpolate(arr)))
    raise InputError(name, f"expected a number, a callable f(x, y) or {mesh.p.shape[1]} nodal values "
                     f"(or {basis.N} DOF values), got an array of shape {arr.shape}")


def _dirichlet(basis: Basis, pressures: Mapping[str, float]) -> dict:
    """{boundary: DOF indices} of the named Dirichlet boundaries (a DOF shared by two goes to the first)."""
    named = basis.mesh.boundaries or {}
    if not pressures:
        raise InputError("pressures", "the film needs at least one boundary with a given pressure")
    out, taken = {}, np.zeros(basis.N, dtype=bool)
    for name, value in pressures.items():
        if name not in named:
            raise InputError("pressures", f"the mesh has no boundary {name!r} (it has: {', '.join(named) or 'none'})")
        if not np.isfinite(value):
            raise InputError(f"pressures.{name}", f"must be a finite pressure in Pa, got {value!r}")
        dofs = basis.get_dofs(named[name]).all()
        dofs = dofs[~taken[dofs]]
        taken[dofs] = True
        out[name] = dofs
    return out


def _active_set(A, f, p, free, floor: float, max_iter: int) -> tuple[np.ndarray, np.ndarray, int]:
    """p >= floor on the ``free`` DOFs with A p - f >= 0 where p = floor (primal-dual active set).

    ``p`` holds the Dirichlet values on the other DOFs. Returns (p, multiplier on the free DOFs,
    iterations); RuntimeError if the active set keeps changing.
    """
    c = float(np.abs(A.diagonal()[free]).mean())
    active = np.zeros(free.size, dtype=bool)
    p = p.copy()
    for it in range(1, max_iter + 1):
        p[free[active]] = floor
        inner = free[~active]
        fixed = np.setdiff1d(np.arange(p.size), inner)
        if inner.size:
            rhs = f[inner] - A[inner][:, fixed] @ p[fixed]
            p[inner] = spla.spsolve(A[inner][:, inner].tocsc(), rhs)
        lam = A[free] @ p - f[free]
        lam[~active] = 0.0
        new = lam + c * (floor - p[free]) > 0.0
        if np.array_equal(new, active):
            return p, lam, it
        active = new
    raise RuntimeError(f"the cavitation active set did not settle in {max_iter} iterations")


def solve_film(mesh, gap: Field, viscosity: float, pressures: Mapping[str, float],
               wall_velocity: Field | None = None, options: FilmOptions = FilmOptions()) -> FilmSolution:
    """Solve the Reynolds equation on ``mesh``: pressure, force, boundary flows, Poiseuille/squeeze split.

    Parameters
    ----------
    mesh : skfem.MeshTri or skfem.MeshTri2
        The film's footprint [m] in its own plane, with named boundaries (``mesh.boundaries``).
    gap : number, callable f(x, y) or nodal array
        Film thickness h [m], > 0 everywhere.
    viscosity : float
        Dynamic viscosity mu [Pa s].
    pressures : {boundary name: p [Pa]}
        Dirichlet pressures; the other boundaries carry no flow.
    wall_velocity : number, callable or nodal array, optional
        dh/dt [m/s], > 0 where the walls separate (the squeeze term). None: 0.
    options : FilmOptions
        Element order, cavitation floor, reference pressure and weight of the force.

    Returns
    -------
    FilmSolution

    Examples
    --------
    Plane Poiseuille flow in a 1 mm x 10 mm channel of a 10 um film: Q = h^3 W dP / (12 mu L)

    >>> from skfem import MeshTri
    >>> m = MeshTri.init_tensor(np.linspace(0, 1e-3, 5), np.linspace(0, 1e-2, 3)).with_boundaries(
    ...     {"in": lambda x: x[0] < 1e-9, "out": lambda x: x[0] > 1e-3 - 1e-9})
    >>> s = solve_film(m, 1e-5, 0.0683, {"in": 1e5, "out": 0.0})
    >>> print(f"{s.flows['out'] * 1e9:.3f} mm^3/s")    # 1e-15 * 1e-2 * 1e5 / (12 * 0.0683 * 1e-3)
    1.220 mm^3/s
    """
    if not (np.isfinite(viscosity) and viscosity > 0):
        raise InputError("viscosity", f"must be a positive viscosity in Pa s, got {viscosity!r}")
    elem = _element(options.order)
    basis = Basis(mesh, elem, intorder=options.intorder or 3 * options.order + 1)
    h = at_quadrature(basis, gap, "gap")
    if not np.all(np.isfinite(h)) or h.min() <= 0.0:
        raise InputError("gap", f"the film thickness must be positive and finite, its least value is {h.min():g} m")
    hdot = np.zeros_like(h) if wall_velocity is None else at_quadrature(basis, wall_velocity, "wall_velocity")
    psi = np.ones_like(h) if options.weight is None else at_quadrature(basis, options.weight, "weight")
    A = film_stiffness.assemble(basis, k=h**3 / (12.0 * viscosity)).tocsr()
    f_sq = squeeze_load.assemble(basis, hdot=hdot)
    b = weighted_area.assemble(basis, psi=psi)
    area = float(weighted_area.assemble(basis, psi=np.ones_like(h)).sum())
    bc = _dirichlet(basis, pressures)
    fixed = np.concatenate(list(bc.values()))
    free = np.setdiff1d(np.arange(basis.N), fixed)
    p_d = np.zeros(basis.N)
    for name, dofs in bc.items():
        p_d[dofs] = pressures[name]
    lu = spla.splu(A[free][:, free].tocsc())
    p_pois = p_d.copy()
    p_pois[free] = lu.solve(-(A[free][:, fixed] @ p_d[fixed]))
    p_sq = np.zeros(basis.N)
    p_sq[free] = lu.solve(f_sq[free])

    def flows(p, f):
        r = A @ p - f
        return {name: float(-r[dofs].sum()) for name, dofs in bc.items()}

    ref = options.reference_pressure
    f_pois = float(b @ p_pois) - ref * float(b.sum())
    f_squeeze = float(b @ p_sq)
    q_pois, q_sq = flows(p_pois, np.zeros(basis.N)), flows(p_sq, f_sq)
    p, iters, cav_area, source = p_pois + p_sq, 0, 0.0, 0.0
    floor = options.cavitation_pressure
    if floor is not None and p[free].min() < floor:
        if any(v < floor for v in pressures.values()):
            raise InputError("cavitation_pressure", f"a boundary pressure lies below the floor {floor:g} Pa")
        p, lam, iters = _active_set(A, f_sq, p_d, free, float(floor), options.max_active_set_iterations)
        on = free[p[free] <= floor]
        cav_area = float(weighted_area.assemble(basis, psi=np.ones_like(h))[on].sum())
        source = float(lam.sum())
    total_q = flows(p, f_sq) if iters else {k: q_pois[k] + q_sq[k] for k in bc}
    force = float(b @ p) - ref * float(b.sum()) if iters else f_pois + f_squeeze
    return FilmSolution(basis=basis, pressure=p, force=force, force_poiseuille=f_pois, force_squeeze=f_squeeze,
                        flows=total_q, flows_poiseuille=q_pois, flows_squeeze=q_sq, area=area,
                        weight_integral=float(b.sum()), cavitated_area=cav_area, cavity_source=source,
                        active_set_iterations=iters, dofs=int(basis.N))
