"""The fluid around a reed valve as a layered tetrahedral mesh (half domain, y >= 0).

The flow domain of a reed valve is a stack of prisms over one plan view (s along the
reed from the clamp, y across, z up from the seat face):

- the **port** under the reed, a hole of depth ``port_depth`` through the seat plate, whose
  bottom is the inlet;
- the **gap** between the seat face (z = 0) and the reed's upstream face, z = gap(s), with
  gap(s) = g0 + (x - g0) psi(s) for a tip opening x and the reed's deflected shape psi
  (psi(L) = 1, psi(0) = 0), g0 = ``floor_fraction`` x the gap left at the clamp (the film
  there carries ~g0^3 of the flow: nothing);
- the **reed level**: the reed itself is a hole, the pockets of its grooves are fluid, and
  the chamber beside and beyond the reed;
- the **chamber** above the reed up to the stop, a flat plate at z = h + x_stop over the
  whole chamber; the chamber ends ``side_margin`` beside and ``tip_margin`` beyond the reed
  in open (outlet) boundaries and at the clamp wall s = 0.

gmsh (OCC) triangulates the plan view so that the reed outline, the port outline and the
groove edges are mesh lines, fine (``size_min``) near them and coarse (``size_max``) away;
each triangle is then extruded through the layers it is fluid in, with a fixed number of
element layers per layer (so a 20 um film has as many layers across as a 2 mm one) and each
prism split into three tetrahedra by the vertex-order rule (conforming across faces).

The seat is only drawn in the thesis (Figures 3.2, 3.14); :class:`ReedSeat` is a
documented reconstruction that follows the pressure sections of section 3.8.4.1: a sealing
land of 1/16 in along the sides and the tip (R_i = 6.35 mm, R_o = 7.94 mm), the port inside
it under the reed's last (widest) section, the base (section 4) between the clamp and the
port. A groove that runs into the reed's free outline would connect the port to the
downstream side (a leak no sealing valve has): the flow models seal the part of such a
groove within one land width of the outline (:func:`sealed_depth`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import skfem

from geometry.errors import InputError
from geometry.reed import Reed

from ..mesh import _gmsh_session, _groove_surfaces, _outline_curves, gmsh_cells

#: boundary names of the 3-D mesh (skfem ``mesh.boundaries``)
BOUNDARIES = ("inlet", "outlet", "symmetry", "reed", "wall")


@dataclass(frozen=True)
class ReedSeat:
    """The seat, port and chamber around a reed (reconstruction, see the module docstring) [m].

    ``port_start`` None: one land width after the start of the reed's last section (the
    prototype: 4.76 + 1.59 = 6.35 mm). ``stop_gap``: x_stop, the stop plate's height above
    the reed's downstream face at rest (Table 3.13: 1.9 mm).
    """

    land_width: float = 1.5875e-3
    port_start: float | None = None
    port_depth: float = 3.0e-3
    stop_gap: float = 1.9e-3
    side_margin: float = 6.0e-3
    tip_margin: float = 6.0e-3
    floor_fraction: float = 0.05

    def start(self, reed: Reed) -> float:
        """s [m] where the port begins."""
        if self.port_start is not None:
            return self.port_start
        last = reed.pieces()[-1]
        return last.s0 + self.land_width

    def check(self, reed: Reed) -> None:
        """InputError naming the field when the port does not fit under the reed's last section."""
        last, lw = reed.pieces()[-1], self.land_width
        if not 0.0 < lw < min(last.w0, last.w1) / 2:
            raise InputError("seat.land_width", f"{lw:g} m must be positive and less than half the reed's "
                             f"last section ({min(last.w0, last.w1):g} m)")
        a = self.start(reed)
        if not (last.s0 + lw - 1e-12 <= a < reed.length - lw - max(reed.tip_radius - lw, 0.0)):
            raise InputError("seat.port_start", f"{a:g} m: the port must start at least one land width inside "
                             f"the reed's last section (s >= {last.s0 + lw:g} m) and before its tip")
        for key in ("port_depth", "stop_gap", "side_margin", "tip_margin"):
            if not getattr(self, key) > 0.0:
                raise InputError(f"seat.{key}", f"must be positive, got {getattr(self, key)}")
        if not 0.0 < self.floor_fraction < 0.5:
            raise InputError("seat.floor_fraction", f"must lie in (0, 0.5), got {self.floor_fraction}")

    def port_half_width(self, reed: Reed, s):
        """Half width [m] of the port at s (0 outside it): the outline inset by the land."""
        s = np.asarray(s, dtype=float)
        last, lw, R = reed.pieces()[-1], self.land_width, reed.tip_radius
        half = np.asarray(last.width(s), dtype=float) / 2 - lw
        if R > lw:
            d = np.clip(s - reed.tip_start, 0.0, None)
            r = R - lw
            arc = half - r + np.sqrt(np.maximum(r**2 - d**2, 0.0))
            half = np.where(s > reed.tip_start, np.where(d <= r, arc, 0.0), half)
        end = reed.length - lw
        return np.where((s >= self.start(reed)) & (s <= end), np.maximum(half, 0.0), 0.0)

    def in_port(self, reed: Reed, s, y):
        """True where the plan point (s, y) [m] lies over the port."""
        return np.abs(np.asarray(y, float)) <= self.port_half_width(reed, s)


def gap_profile(s, x: float, s_psi, psi, floor_fraction: float):
    """gap(s) [m] between the seat and the reed's upstream face at tip opening x [m].

    g0 + (x - g0) psi(s) on 0 <= s <= L with g0 = floor_fraction x, psi interpolated from
    (s_psi, psi) and continued flat beyond the tip (the chamber's layers there).
    """
    g0 = floor_fraction * x
    p = np.interp(np.asarray(s, float), s_psi, psi, left=0.0, right=float(psi[-1]))
    return g0 + (x - g0) * p


# ------------------------------------------------------------------------------- plan view
def _free_outline(reed: Reed) -> np.ndarray:
    """Segments (n, 2, 2) of the reed outline without the clamp edge s = 0 [m]."""
    poly = reed.outline(48)
    seg = np.stack([poly, np.roll(poly, -1, axis=0)], axis=1)
    clamp = (np.abs(seg[:, 0, 0]) < 1e-12) & (np.abs(seg[:, 1, 0]) < 1e-12)
    return seg[~clamp]


def _distance(points: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Distance [m] of each point (n, 2) to the nearest segment."""
    a, b = seg[:, 0][None], seg[:, 1][None]
    p = points[:, None, :]
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, axis=2) / np.maximum(np.sum(ab * ab, axis=2), 1e-300), 0.0, 1.0)
    return np.min(np.linalg.norm(p - (a + t[..., None] * ab), axis=2), axis=1)


def sealed_depth(reed: Reed, seat: ReedSeat, s, y) -> np.ndarray:
    """Groove depth [m] the flow sees at plan points (s, y): a groove that reaches the reed's
    free outline is sealed (depth 0) within one land width of it (module docstring)."""
    s, y = np.broadcast_arrays(np.asarray(s, float), np.asarray(y, float))
    shape = s.shape
    s, y = s.ravel(), y.ravel()
    depth = np.zeros(s.shape)
    seg = _free_outline(reed)
    tol = 1e-9 * reed.length
    for g in reed.grooves:
        inside = g.contains(s, y)
        if not np.any(inside):
            continue
        probe = _groove_probe(g)
        if np.min(_distance(probe, seg)) < tol:        # it runs into the outline: seal its end
            near = _distance(np.column_stack([s, y]), seg) < seat.land_width - tol
            inside &= ~near
        depth = np.maximum(depth, np.where(inside, g.depth, 0.0))
    return depth.reshape(shape)


def _groove_probe(g) -> np.ndarray:
    """Points on a groove's outline (for the distance to the reed's outline)."""
    if g.kind == "rect":
        s = np.linspace(g.s_start, g.s_end, 64)
        y0, y1 = g.y_center - g.width / 2, g.y_center + g.width / 2
        ys = np.linspace(y0, y1, 16)
        return np.vstack([np.column_stack([s, np.full_like(s, y0)]), np.column_stack([s, np.full_like(s, y1)]),
                          np.column_stack([np.full_like(ys, g.s_start), ys]),
                          np.column_stack([np.full_like(ys, g.s_end), ys])])
    a = np.linspace(-np.pi / 2, np.pi / 2, 97)
    return np.vstack([np.column_stack([g.s_center + r * np.cos(a), r * np.sin(a)]) for r in (g.r_inner, g.r_outer)])


@dataclass(frozen=True)
class PlanView:
    """Triangles of the half plan view y >= 0 [m] and what each lies under."""

    points: np.ndarray      # (n, 2) s, y [m]
    triangles: np.ndarray   # (m, 3), counter-clockwise
    in_reed: np.ndarray     # (m,) bool: under the reed
    in_port: np.ndarray     # (m,) bool: over the port
    depth: np.ndarray       # (m,) groove depth the flow sees [m] (0: none)
    extent: tuple[float, float]   # chamber's end s and side y [m]


def _port_surface(occ, reed: Reed, seat: ReedSeat) -> int:
    """The half port (y >= 0) as an OCC surface: the land-inset outline of the last section."""
    a, lw, R, L = seat.start(reed), seat.land_width, reed.tip_radius, reed.length
    last = reed.pieces()[-1]
    if last.tapered and R > lw:
        ss = np.concatenate([np.linspace(a, reed.tip_start, 24), np.linspace(reed.tip_start, L - lw, 40)[1:]])
        pts = [(a, 0.0)] + [(si, float(seat.port_half_width(reed, si))) for si in ss[:-1]] + [(L - lw, 0.0)]
        tags = [occ.addPoint(si, yi, 0.0) for si, yi in pts]
        lines = [occ.addLine(tags[0], tags[1]), occ.addSpline(tags[1:]), occ.addLine(tags[-1], tags[0])]
        return occ.addPlaneSurface([occ.addCurveLoop(lines)])
    y_a = float(seat.port_half_width(reed, a))
    p0, p1 = occ.addPoint(a, 0.0, 0.0), occ.addPoint(a, y_a, 0.0)
    curves = [occ.addLine(p0, p1)]
    if R > lw:
        yc = last.w1 / 2 - R
        p2 = occ.addPoint(reed.tip_start, yc + R - lw, 0.0)
        p3 = occ.addPoint(reed.tip_start + R - lw, yc, 0.0)
        curves += [occ.addLine(p1, p2), occ.addCircleArc(p2, occ.addPoint(reed.tip_start, yc, 0.0), p3)]
        last_pt = p3
        if yc > 1e-12 * L:
            last_pt = occ.addPoint(L - lw, 0.0, 0.0)
            curves.append(occ.addLine(p3, last_pt))
    else:
        p2 = occ.addPoint(L - lw, float(last.width(L - lw)) / 2 - lw, 0.0)
        last_pt = occ.addPoint(L - lw, 0.0, 0.0)
        curves += [occ.addLine(p1, p2), occ.addLine(p2, last_pt)]
    curves.append(occ.addLine(last_pt, p0))
    return occ.addPlaneSurface([occ.addCurveLoop(curves)])


def plan_view(reed: Reed, seat: ReedSeat, size_min: float, size_max: float) -> PlanView:
    """Triangulate the half plan view (gmsh, one thread): chamber, reed, port and grooves as mesh lines.

    Sizes [m]: ``size_min`` on the reed's and the port's outlines and the groove edges,
    growing linearly to ``size_max`` at 4 land widths from them.
    """
    seat.check(reed)
    s_end = reed.length + seat.tip_margin
    y_end = reed.max_width / 2 + seat.side_margin
    with _gmsh_session() as gmsh:
        occ = gmsh.model.occ
        chamber = occ.addRectangle(0.0, 0.0, 0.0, s_end, y_end)
        half = occ.addRectangle(-reed.length, 0.0, 0.0, 3 * reed.length, 2 * y_end)
        tools = [(2, _outline_curves(gmsh, reed)), (2, _port_surface(occ, reed, seat))]
        tools += [(2, t) for t in _groove_surfaces(gmsh, reed)]
        cut, _ = occ.intersect(tools, [(2, half)])
        occ.fragment([(2, chamber)], cut)
        occ.synchronize()
        inner = [t for d, t in gmsh.model.getEntities(1) if _is_inner(gmsh.model.getBoundingBox(1, t), s_end, y_end)]
        f = gmsh.model.mesh.field
        dist = f.add("Distance")
        f.setNumbers(dist, "CurvesList", inner)
        f.setNumber(dist, "Sampling", 400)
        thr = f.add("Threshold")
        f.setNumber(thr, "InField", dist)
        f.setNumber(thr, "SizeMin", size_min)
        f.setNumber(thr, "SizeMax", size_max)
        f.setNumber(thr, "DistMin", 0.0)
        f.setNumber(thr, "DistMax", 4 * seat.land_width)
        f.setAsBackgroundMesh(thr)
        for opt in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
            gmsh.option.setNumber(f"Mesh.{opt}", 0)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.model.mesh.generate(2)
        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        etypes, _, enodes = gmsh.model.mesh.getElements(2)
    xyz, t = gmsh_cells(node_tags, coords, etypes, enodes, 2, 3)
    pts = xyz[:, :2]
    x, y = pts[t, 0], pts[t, 1]
    area = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    t[area < 0] = t[area < 0][:, [0, 2, 1]]
    c = pts[t].mean(axis=1)
    in_reed = (c[:, 0] <= reed.length) & (np.abs(c[:, 1]) <= np.asarray(reed.width(c[:, 0])) / 2)
    depth = np.where(in_reed, sealed_depth(reed, seat, c[:, 0], c[:, 1]), 0.0)
    return PlanView(points=pts, triangles=t, in_reed=in_reed, in_port=seat.in_port(reed, c[:, 0], c[:, 1]),
                    depth=depth, extent=(s_end, y_end))


def _is_inner(bbox, s_end: float, y_end: float) -> bool:
    """True for a curve that is not on the chamber's outer edges s = s_end, y = 0, y = y_end."""
    x0, y0, _, x1, y1, _ = bbox
    tol = 1e-9 * s_end
    on_edge = ((abs(x0 - s_end) < tol and abs(x1 - s_end) < tol) or (abs(y0) < tol and abs(y1) < tol)
               or (abs(y0 - y_end) < tol and abs(y1 - y_end) < tol))
    return not on_edge


# ------------------------------------------------------------------------------- 3-D mesh
@dataclass(frozen=True)
class Layers:
    """Element layers through each part of the stack (the resolution across the film is ``gap``)."""

    port: int = 2
    gap: int = 2
    reed: int = 1           # per interval between groove depths and the reed's thickness
    above: int = 3

    def __post_init__(self):
        # one element across the film puts every velocity node of its cells on a wall: pressure
        # nodes there get no equation (a singular Taylor-Hood system)
        if self.gap < 2:
            raise InputError("layers.gap", f"the film needs at least 2 element layers, got {self.gap}")
        for key in ("port", "reed", "above"):
            if getattr(self, key) < 1:
                raise InputError(f"layers.{key}", f"must be at least 1, got {getattr(self, key)}")


@dataclass(frozen=True)
class FluidMesh:
    """The 3-D fluid mesh of a reed valve at one tip opening (half domain y >= 0), SI units.

    ``mesh.boundaries``: inlet (port bottom), outlet (chamber's open sides), symmetry (y = 0),
    reed (every face of the reed, groove pockets included), wall (seat, port walls, clamp
    wall, stop plate). ``opening`` x [m]; ``s_psi``, ``psi``: the deflected shape used.
    """

    mesh: skfem.MeshTet
    plan: PlanView
    opening: float
    s_psi: np.ndarray
    psi: np.ndarray
    layers: Layers

    @property
    def cells(self) -> int:
        return int(self.mesh.t.shape[1])


def _level_heights(reed: Reed, seat: ReedSeat, plan: PlanView, layers: Layers, gap: np.ndarray):
    """z [m] of every node level at every plan vertex, shape (levels, vertices), and the reed cut depths."""
    h, D = reed.thickness, seat.port_depth
    cuts = sorted({float(d) for d in plan.depth if d > 0.0} | {h})
    rows = [np.full_like(gap, -D * (1 - k / layers.port)) for k in range(layers.port)]
    rows += [gap * j / layers.gap for j in range(layers.gap + 1)]
    lo = 0.0
    for d in cuts:
        rows += [gap + lo + (d - lo) * k / layers.reed for k in range(1, layers.reed + 1)]
        lo = d
    top = h + seat.stop_gap
    rows += [gap + h + (top - gap - h) * k / layers.above for k in range(1, layers.above + 1)]
    return np.array(rows), cuts


def _active(plan: PlanView, layers: Layers, cuts: list[float]) -> np.ndarray:
    """(layers, triangles) bool: is the prism of triangle j in layer i fluid."""
    edges = np.concatenate([[0.0], cuts])
    sub_top = np.concatenate([lo + (hi - lo) * np.arange(1, layers.reed + 1) / layers.reed
                              for lo, hi in zip(edges[:-1], edges[1:])])
    m = len(plan.triangles)
    port = np.repeat(plan.in_port[None, :], layers.port, axis=0)
    reed = (~plan.in_reed)[None, :] | (sub_top[:, None] <= plan.depth[None, :] + 1e-12)
    return np.vstack([port, np.ones((layers.gap, m), bool), reed, np.ones((layers.above, m), bool)])


def _prisms_to_tets(tri: np.ndarray, nv: int, active: np.ndarray) -> np.ndarray:
    """Tetrahedra (k, 4) of the active prisms; node = level * nv + vertex; vertex-order split (conforming)."""
    a, b, c = np.sort(tri, axis=1).T
    out = []
    for lvl in range(active.shape[0]):
        j = np.flatnonzero(active[lvl])
        if not len(j):
            continue
        A, B, C = a[j] + lvl * nv, b[j] + lvl * nv, c[j] + lvl * nv
        A1, B1, C1 = A + nv, B + nv, C + nv
        out += [np.column_stack(q) for q in ((A, B, C, C1), (A, B, B1, C1), (A, A1, B1, C1))]
    return np.vstack(out)


def _orient(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Tetrahedra with positive volume (two nodes swapped where negative)."""
    x = p[t]
    vol = np.einsum("ij,ij->i", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), x[:, 3] - x[:, 0])
    t = t.copy()
    t[vol < 0] = t[vol < 0][:, [0, 2, 1, 3]]
    return t


@dataclass(frozen=True)
class MeshOptions:
    """Plan-view sizes [m] and element layers of a fluid mesh (defaults: the study's medium mesh)."""

    size_min: float = 0.7e-3
    size_max: float = 2.5e-3
    layers: Layers = Layers(port=1, gap=2, reed=1, above=2)

    def refined(self, factor: float) -> "MeshOptions":
        """Sizes divided by ``factor`` and every layer count multiplied by it (rounded, at least 1)."""
        lay = Layers(*(max(lo, int(round(n * factor))) for lo, n in zip((1, 2, 1, 1), (
            self.layers.port, self.layers.gap, self.layers.reed, self.layers.above))))
        return MeshOptions(self.size_min / factor, self.size_max / factor, lay)


def fluid_mesh(reed: Reed, seat: ReedSeat, opening: float, shape: tuple[np.ndarray, np.ndarray],
               options: MeshOptions = MeshOptions(), plan: PlanView | None = None) -> FluidMesh:
    """The fluid around ``reed`` deflected to tip opening ``opening`` [m] along ``shape`` = (s [m], psi).

    ``plan``: a plan view from :func:`plan_view` to reuse (it does not depend on the opening).
    InputError when the opening is not in (0, x_stop).
    """
    if not 0.0 < opening < seat.stop_gap:
        raise InputError("opening", f"{opening:g} m must lie between 0 and the stop gap {seat.stop_gap:g} m")
    s_psi, psi = (np.asarray(a, dtype=float) for a in shape)
    if plan is None:
        plan = plan_view(reed, seat, options.size_min, options.size_max)
    nv = len(plan.points)
    gap = gap_profile(plan.points[:, 0], opening, s_psi, psi, seat.floor_fraction)
    z, cuts = _level_heights(reed, seat, plan, options.layers, gap)
    active = _active(plan, options.layers, cuts)
    tets = _prisms_to_tets(plan.triangles, nv, active)
    used = np.unique(tets)
    remap = np.full(z.size, -1)
    remap[used] = np.arange(len(used))
    lvl, vtx = used // nv, used % nv
    p = np.column_stack([plan.points[vtx], z[lvl, vtx]])
    t = _orient(p, remap[tets])
    mesh = skfem.MeshTet(p.T.copy(), t.T.copy())
    bnd = _classify(mesh, lvl, vtx, plan, options.layers.port, z.shape[0] - 1)
    return FluidMesh(mesh=mesh.with_boundaries(bnd), plan=plan, opening=float(opening), s_psi=s_psi, psi=psi,
                     layers=options.layers)


def _classify(mesh: skfem.MeshTet, lvl: np.ndarray, vtx: np.ndarray, plan: PlanView, seat_level: int,
              top_level: int) -> dict[str, np.ndarray]:
    """Boundary facets by name (:data:`BOUNDARIES`) from the levels and plan positions of their nodes."""
    f = mesh.boundary_facets()
    nodes = mesh.facets[:, f]
    L, V = lvl[nodes], vtx[nodes]
    xy = plan.points[V]                                  # (3, k, 2)
    s_end, y_end = plan.extent
    tol = 1e-9 * s_end
    flat = (L.min(axis=0) == L.max(axis=0))
    level = L[0]
    sym = np.all(np.abs(xy[..., 1]) < tol, axis=0)
    out = np.all(np.abs(xy[..., 0] - s_end) < tol, axis=0) | np.all(np.abs(xy[..., 1] - y_end) < tol, axis=0)
    clamp = np.all(np.abs(xy[..., 0]) < tol, axis=0)
    port_wall = ~flat & (L.max(axis=0) <= seat_level)
    names = {
        "inlet": flat & (level == 0),
        "symmetry": ~flat & sym,
        "outlet": ~flat & out,
        "wall": (flat & ((level == seat_level) | (level == top_level))) | (~flat & ~sym & ~out & (clamp | port_wall)),
    }
    taken = np.zeros(len(f), bool)
    for m in names.values():
        taken |= m
    names["reed"] = ~taken
    return {k: f[v] for k, v in names.items()}
