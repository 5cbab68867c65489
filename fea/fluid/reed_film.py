"""The reed valve's sealing film: the Reynolds equation under the reed, grooves included.

Where the reed sits on the seat (the base between the clamp and the port, and the sealing
land along the sides and the tip; :class:`fea.fluid.reed_mesh.ReedSeat`) the flow is a thin
film of thickness h(s, y) = gap(s) + d(s, y): the reed's deflected upstream face above the
seat (gap(s) = g0 + (x - g0) psi(s), the same as the 3-D model's) plus the depth of a groove
cut into the face (sealed where it runs into the outline, :func:`fea.fluid.reed_mesh.sealed_depth`).
The film is solved by part one's general solver (:func:`fea.fluid.reynolds.solve_film`)
with p = P_up on the port's edge, p = P_down on the reed's free outline, no flow through the
clamp line and the symmetry line; the squeeze term is the reed's own motion, dh/dt =
psi(s) u for a tip speed u (the thesis neglects it, eq 3.51).

Outputs at a tip opening x: the pressure load multiplier of eq 3.49,

    X = [ iint_port psi dA + iint_film psi (p - P_down) / dP dA ] / int_0^L psi W ds,

(over the port the whole dP acts), the mean pressure fractions F of eq 3.58 on the base
(F4, computed from the flow instead of assumed: Table 3.12), on the side lands (F2, eq 3.53)
and the tip land (F3, eq 3.59), the leakage flow Q [m^3/s], and the squeeze ("stiction")
coefficient c_sq = -F_sq / (u int psi W ds) [Pa s/m], the film's resistance to the reed's
motion in the pressure units of eq 3.21 (compare c = 1727 Pa s/m of eq 3.81).

All in SI units, both halves of the reed (the film is solved on y >= 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import skfem
from skfem import Basis, ElementTriP1, Functional

from geometry.reed import Reed

from .reed_mesh import PlanView, ReedSeat, gap_profile, plan_view, sealed_depth
from .reynolds import FilmOptions, solve_film

#: plan-view element size of the film [m] on the lands (the land is 1/16 in: 8 across)
FILM_SIZE = 0.2e-3


@dataclass(frozen=True)
class ReedFilm:
    """The sealing film at one tip opening (module docstring), SI units, both halves."""

    opening: float
    multiplier: float
    flow: float
    base_fraction: float
    side_fraction: float
    tip_fraction: float
    squeeze_coefficient: float
    dofs: int


def contact_mesh(plan: PlanView, reed: Reed) -> skfem.MeshTri:
    """The plan view's triangles where the reed rests on the seat (under the reed, not over the port).

    Boundaries: ``port`` (the port's edge), ``outline`` (the reed's free outline),
    ``clamp`` (s = 0) and ``symmetry`` (y = 0); the film carries no flow through the last two.
    """
    keep = plan.in_reed & ~plan.in_port
    tri = plan.triangles[keep]
    used = np.unique(tri)
    remap = np.full(len(plan.points), -1)
    remap[used] = np.arange(len(used))
    mesh = skfem.MeshTri(plan.points[used].T.copy(), remap[tri].T.copy())
    port_edges = {tuple(sorted(e)) for t in plan.triangles[plan.in_port] for e in ((t[0], t[1]), (t[1], t[2]),
                                                                                   (t[2], t[0]))}
    f = mesh.boundary_facets()
    ends = mesh.facets[:, f]
    xy = mesh.p[:, ends]                                          # (2, 2, k)
    tol = 1e-9 * reed.length
    sym = np.all(np.abs(xy[1]) < tol, axis=0)
    clamp = np.all(np.abs(xy[0]) < tol, axis=0)
    glob = used[ends]
    port = np.array([tuple(sorted(c)) in port_edges for c in glob.T])
    outline = ~(sym | clamp | port)
    return mesh.with_boundaries({"port": f[port], "outline": f[outline], "clamp": f[clamp], "symmetry": f[sym]})


def mean_fraction(basis: Basis, p: np.ndarray, dp: float, mask) -> float:
    """Mean of p / dP over the film where ``mask(s, y)`` holds (NaN if nowhere)."""
    pv = basis.interpolate(p)

    @Functional
    def num(w):
        return w["p"] * mask(w.x[0], w.x[1])

    @Functional
    def den(w):
        return 1.0 * mask(w.x[0], w.x[1])
    a = den.assemble(basis, p=pv)
    return float(num.assemble(basis, p=pv) / (dp * a)) if a > 0 else float("nan")


def _port_moment(plan: PlanView, valve) -> float:
    """iint_port psi dA [m^2] over the half port."""
    tri = plan.triangles[plan.in_port]
    used = np.unique(tri)
    remap = np.full(len(plan.points), -1)
    remap[used] = np.arange(len(used))
    m = skfem.MeshTri(plan.points[used].T.copy(), remap[tri].T.copy())

    @Functional
    def moment(w):
        return valve.psi(w.x[0])
    return float(moment.assemble(Basis(m, ElementTriP1(), intorder=4)))


def reed_film(valve, opening: float, speed: float = 1e-3, size: float = FILM_SIZE,
              plan: PlanView | None = None) -> ReedFilm:
    """The sealing film of ``valve`` (a :class:`fea.fluid.reed3d.ReedValveFlow`) at tip opening ``opening`` [m].

    ``speed`` [m/s]: the tip speed of the squeeze solve (the film is linear: only its sign
    and the ratio matter). ``plan``: a plan view to reuse (sizes ``size`` on the lands).
    """
    reed, seat = valve.reed, valve.seat
    if plan is None:
        plan = plan_view(reed, seat, size, 4 * size)
    mesh = contact_mesh(plan, reed)
    depth = plan.depth[plan.in_reed & ~plan.in_port]          # per film element (groove edges are mesh lines)
    s_psi, psi = valve.shape
    dp, mu = 1.0, valve.fluid.mu

    def gap(s, y):
        # the solver asks at the quadrature points, one row per element of ``mesh``
        d = depth[:, None] if np.shape(s)[:1] == depth.shape else sealed_depth(reed, seat, s, y)
        return gap_profile(s, opening, s_psi, psi, seat.floor_fraction) + d

    def hdot(s, y):
        return speed * (1 - seat.floor_fraction) * valve.psi(s)

    opts = FilmOptions(order=2, weight=lambda s, y: valve.psi(s))
    pois = solve_film(mesh, gap, mu, {"port": dp, "outline": 0.0}, options=opts)
    squeeze = solve_film(mesh, gap, mu, {"port": 0.0, "outline": 0.0}, wall_velocity=hdot, options=opts)
    half_area = valve.modal_area / 2
    X = (_port_moment(plan, valve) * dp + pois.force) / (dp * half_area)
    a = seat.start(reed)
    frac = [mean_fraction(pois.basis, pois.pressure, dp, m) for m in (
        lambda s, y: s < a, lambda s, y: (s >= a) & (s <= reed.tip_start), lambda s, y: s > reed.tip_start)]
    return ReedFilm(opening=float(opening), multiplier=float(X), flow=2.0 * pois.flows["outline"],
                    base_fraction=frac[0], side_fraction=frac[1], tip_fraction=frac[2],
                    squeeze_coefficient=-squeeze.force / (speed * half_area), dofs=pois.dofs)
