"""The disc valve's axisymmetric flow domain (r, z) and its gmsh triangle mesh, refined in the gap.

The thesis gives the port, the seat radii, the bevel and the stop gaps (Table 2.3,
``geometry/data/disc_valve.toml``); the housing is only in figures. The domain, with z = 0 at
the top of the port (where the seating cone starts) and x the lift:

- port: the bore of radius d_port / 2 and length L (Table 2.3), inlet at z = -L;
- seat: a flat land from the bore to R_i when R_i > d_port / 2 (none on the thesis valve),
  the cone of half angle theta from R_i to R_o, rising z_c = (R_o - R_i) / tan(theta), then the
  seat ring's flat top out to the housing wall;
- disc: flat underside at z = x inside R_i, its bevel parallel to the cone from R_i to R_o (the
  film of eqs 2.7-2.15), a cylindrical rim and a flat top. Its thickness is not given: the disc
  is taken as solid steel (7900 kg/m^3, assumed) of the measured 2.5 g (section 2.4.1), which
  fixes the rim height above the bevel (0.59 mm for the thesis disc);
- housing (``geometry/data/seat_stop.toml``, valvelab's plausible choices): the wall at
  ``stop.inner_radius`` (8 mm); its four flow windows (6 x 4 mm, 1 mm above the seat) become
  one slot round the whole circumference (an axisymmetric model cannot hold four windows; the
  slot's open area is 2.1 times theirs, small beside the valve's throttling) through the wall's
  thickness to the cartridge's outside, an outlet at the downstream pressure; the end wall's
  central hole (radius 4 mm, 2 mm long) is the second outlet. The end wall is put a clearance
  ``END_CLEARANCE`` above the disc's top at the stop: the stop's contact ring and the spring are
  not modelled (an assumption: the spring's space above the disc), so the chamber above the disc
  stays open at every lift up to the stop.

The gap between the cones is a parallelogram meshed as a structured (transfinite) region with
``resolution`` cells across the film's normal width x sin(theta), graded toward both ends;
the rest is meshed by gmsh's Frontal-Delaunay with a size field that grows from the gap's size
near the disc and seat to the far size. ``resolution`` scales every size together, so the
meshes of a GCI ladder (resolution n/2, n, 2n) are in the ratio 2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from skfem import MeshTri

from geometry.errors import InputError

from ..mesh import _gmsh_session, gmsh_cells

#: assumed density of the disc [kg/m^3] (stainless steel; not stated in the thesis)
DISC_DENSITY = 7900.0
#: least rim height above the bevel [m] when the mass would give less
MIN_RIM = 0.2e-3
#: clearance between the disc's top at the stop and the end wall [m] (assumed: the spring's space)
END_CLEARANCE = 1.0e-3
#: cells across the film in the default mesh
DEFAULT_RESOLUTION = 4
#: cell aspect ratio allowed along the film (length / width) in its middle
FILM_ASPECT = 4.0
#: the far size as a fraction of R_o at resolution 1
FAR_SIZE = 0.25
#: element size at the corners (re-entrant: singular pressure) relative to the film's cells
CORNER_REFINEMENT = 0.25
#: growth of the element size with the distance from the disc and seat (dimensionless slope)
GROWTH = 0.25


@dataclass(frozen=True)
class DiscDomain:
    """The flow domain's dimensions [m] (module docstring); ``stop`` the lift at the stop."""

    port_radius: float
    port_length: float
    inner_radius: float
    outer_radius: float
    bevel_angle: float
    rim: float
    housing_radius: float
    wall_thickness: float
    window_base: float
    window_height: float
    hole_radius: float
    end_thickness: float
    stop: float
    end_clearance: float = END_CLEARANCE

    @property
    def cone_height(self) -> float:
        """z_c = (R_o - R_i) / tan(theta) [m]."""
        return (self.outer_radius - self.inner_radius) / math.tan(self.bevel_angle)

    @property
    def end_wall(self) -> float:
        """z of the end wall's underside [m]."""
        return self.cone_height + self.rim + self.stop + self.end_clearance

    def check_lift(self, lift: float, field: str = "--lift-mm") -> float:
        """The lift [m] if 0 < lift <= stop, else InputError naming ``field``."""
        if not (np.isfinite(lift) and 0.0 < lift <= self.stop * (1 + 1e-9)):
            raise InputError(field, f"the lift must lie in (0, {self.stop * 1e3:.4g}] mm (the stop), "
                             f"got {lift * 1e3:.4g} mm")
        return float(lift)


def rim_height(disc_mass: float, inner_radius: float, outer_radius: float, bevel_angle: float) -> float:
    """Rim height above the bevel [m] of a solid disc of ``disc_mass`` [kg] (DISC_DENSITY):
    V = pi R_o^2 (z_c + t) - 2 pi / tan(theta) int_Ri^Ro r (r - R_i) dr (module docstring)."""
    zc = (outer_radius - inner_radius) / math.tan(bevel_angle)
    ri, ro = inner_radius, outer_radius
    bevel = 2 * math.pi / math.tan(bevel_angle) * ((ro**3 - ri**3) / 3 - ri * (ro**2 - ri**2) / 2)
    t = (disc_mass / DISC_DENSITY + bevel) / (math.pi * ro**2) - zc
    return max(t, MIN_RIM)


def disc_domain(valve, housing=None) -> DiscDomain:
    """The domain of a disc valve (``lumped.valves.disc.DiscValve``) in the thesis housing
    (``geometry.seat_stop.load_housing_stop()`` unless given); InputError naming the field when
    the port is wider than the seat's inner radius or the disc wider than the housing."""
    from geometry.seat_stop import load_housing_stop

    h = housing or load_housing_stop()
    rp = valve.port_diameter / 2
    if rp > valve.inner_radius * (1 + 1e-9):
        raise InputError("port.diameter", f"the port ({valve.port_diameter * 1e3:.4g} mm) is wider than the seat's "
                         f"inner diameter 2 R_i = {2e3 * valve.inner_radius:.4g} mm")
    if not valve.outer_radius < h.inner_radius:
        raise InputError("seat.outer_radius", f"the disc (R_o = {valve.outer_radius * 1e3:.4g} mm) must be smaller "
                         f"than the housing's inner radius {h.inner_radius * 1e3:.4g} mm")
    rim = rim_height(valve.disc_mass, valve.inner_radius, valve.outer_radius, valve.bevel_angle)
    return DiscDomain(port_radius=rp, port_length=valve.port_length, inner_radius=valve.inner_radius,
                      outer_radius=valve.outer_radius, bevel_angle=valve.bevel_angle, rim=rim,
                      housing_radius=h.inner_radius, wall_thickness=h.outer_radius - h.inner_radius,
                      window_base=h.window_base, window_height=h.window_height,
                      hole_radius=min(h.hole_radius, valve.outer_radius), end_thickness=h.end_thickness,
                      stop=valve.stop_gap)


def outline(d: DiscDomain, lift: float) -> dict:
    """Named corner points [m] and boundary segments of the domain at ``lift`` (module docstring)."""
    x, zc = lift, d.cone_height
    zd, zw = zc + x + d.rim, d.end_wall
    w0 = zc + d.window_base
    w1 = min(zc + d.window_base + d.window_height, zw - 0.25 * d.window_base)
    if not w1 > w0:
        raise InputError("stop.window_base", "the housing's window lies above its end wall")
    ro_out = d.housing_radius + d.wall_thickness
    P = {"in0": (0.0, -d.port_length), "in1": (d.port_radius, -d.port_length), "bore": (d.port_radius, 0.0),
         "ri": (d.inner_radius, 0.0), "ro": (d.outer_radius, zc), "h0": (d.housing_radius, zc),
         "w0": (d.housing_radius, w0), "w0o": (ro_out, w0), "w1o": (ro_out, w1), "w1": (d.housing_radius, w1),
         "hw": (d.housing_radius, zw), "hole0": (d.hole_radius, zw), "hole1": (d.hole_radius, zw + d.end_thickness),
         "ax3": (0.0, zw + d.end_thickness), "ax2": (0.0, zd), "dtop": (d.outer_radius, zd),
         "drim": (d.outer_radius, zc + x), "dri": (d.inner_radius, x), "ax1": (0.0, x)}
    seat = [("bore", "ri")] if d.inner_radius > d.port_radius * (1 + 1e-12) else []
    groups = {
        "inlet": [("in0", "in1")], "port_wall": [("in1", "bore")],
        "seat": seat + [("ri", "ro"), ("ro", "h0")],
        "housing": [("h0", "w0"), ("w0", "w0o"), ("w1o", "w1"), ("w1", "hw"), ("hw", "hole0"), ("hole0", "hole1")],
        "window": [("w0o", "w1o")], "hole": [("hole1", "ax3")],
        "axis": [("ax3", "ax2"), ("ax1", "in0")],
        "disc": [("ax2", "dtop"), ("dtop", "drim"), ("drim", "dri"), ("dri", "ax1")],
    }
    return {"points": P, "groups": groups, "cv_side": (P["bore"], (d.port_radius, x))}


def sizes(d: DiscDomain, lift: float, resolution: float) -> dict:
    """Element sizes [m]: across the film, the film's cell counts, near the gap and far away."""
    g = lift * math.sin(d.bevel_angle)
    across = max(1, int(round(resolution)))
    h_gap = g / resolution
    slant = (d.outer_radius - d.inner_radius) / math.sin(d.bevel_angle)
    along = max(2 * across, int(math.ceil(slant / (FILM_ASPECT * h_gap))))
    far = max(FAR_SIZE * d.outer_radius / resolution, h_gap)
    return {"film": g, "across": across, "along": along, "gap": h_gap, "far": far}


def _classify(mesh: MeshTri, out: dict) -> MeshTri:
    """Name the boundary facets by the outline segment they lie on; the film's entrance line
    (the CV side r = d_port/2, 0 < z < x) as the interior group ``cv_side``."""
    P, groups = out["points"], out["groups"]
    mid = mesh.p[:, mesh.facets].mean(axis=1)
    scale = float(np.abs(mesh.p).max())

    def on(a, b, pts):
        a, b = np.asarray(a)[:, None], np.asarray(b)[:, None]
        ab = b - a
        t = np.clip(((pts - a) * ab).sum(0) / (ab * ab).sum(), 0.0, 1.0)
        return np.hypot(*(pts - a - t * ab)) < 1e-9 * scale

    bf = mesh.boundary_facets()
    named = {}
    for name, segs in groups.items():
        hit = np.zeros(bf.size, dtype=bool)
        for a, b in segs:
            hit |= on(P[a], P[b], mid[:, bf])
        named[name] = bf[hit]
    a, b = out["cv_side"]
    named["cv_side"] = np.nonzero(on(a, b, mid))[0]
    return mesh.with_boundaries(named)


def valve_mesh(d: DiscDomain, lift: float, resolution: float = DEFAULT_RESOLUTION) -> MeshTri:
    """Triangle mesh [m] of the domain at ``lift`` with named boundaries (``outline``'s groups and
    the interior ``cv_side``); the film between the cones structured, the rest graded from it."""
    d.check_lift(lift)
    out = outline(d, lift)
    s = sizes(d, lift, resolution)
    with _gmsh_session() as gmsh:
        geo = gmsh.model.geo
        flat = d.inner_radius > d.port_radius * (1 + 1e-12)       # a seat land between the bore and R_i
        P = {k: geo.addPoint(r, z, 0.0) for k, (r, z) in out["points"].items() if flat or k != "ri"}
        if not flat:
            P["ri"] = P["bore"]
        P["cv_top"] = geo.addPoint(d.port_radius, lift, 0.0) if flat else P["dri"]
        line = {}

        def L(a, b):
            if (b, a) in line:
                return -line[(b, a)]
            line[(a, b)] = geo.addLine(P[a], P[b])
            return line[(a, b)]

        # film (parallelogram ri -> ro -> drim -> dri)
        film = [L("ri", "ro"), L("ro", "drim"), L("drim", "dri"), L("dri", "ri")]
        under = [L("in0", "in1"), L("in1", "bore")] + ([L("bore", "ri")] if flat else []) + \
            [-film[3], L("dri", "ax1"), L("ax1", "in0")]
        upper = [L("ro", "h0"), L("h0", "w0"), L("w0", "w0o"), L("w0o", "w1o"), L("w1o", "w1"), L("w1", "hw"),
                 L("hw", "hole0"), L("hole0", "hole1"), L("hole1", "ax3"), L("ax3", "ax2"), L("ax2", "dtop"),
                 L("dtop", "drim"), -film[1]]
        surfs = [geo.addPlaneSurface([geo.addCurveLoop(c)]) for c in (under, film, upper)]
        geo.synchronize()
        _film_transfinite(gmsh, film, surfs[1], s)
        if flat:
            gmsh.model.mesh.embed(1, [L("bore", "cv_top")], 2, surfs[0])
        corners = [P[k] for k in ("ri", "ro", "drim", "dri", "dtop", "bore", "h0", "w0", "w1")]
        _size_field(gmsh, [film[1], film[3], L("dtop", "drim"), L("ro", "h0")], corners, s)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        etypes, _, enodes = gmsh.model.mesh.getElements(2)
    xyz, t = gmsh_cells(tags, coords, etypes, enodes, 2, 3)     # gmsh type 2: 3-node triangle
    mesh = MeshTri(np.ascontiguousarray(xyz[:, :2].T), np.ascontiguousarray(t.T))
    return _classify(mesh, out)


def _film_transfinite(gmsh, film, surf, s) -> None:
    """Structured film: ``across`` cells over its width, ``along`` cells along it, graded to both ends."""
    mesh = gmsh.model.mesh
    mesh.setTransfiniteCurve(abs(film[1]), s["across"] + 1)
    mesh.setTransfiniteCurve(abs(film[3]), s["across"] + 1)
    bump = min(1.0, max(0.05, 2.0 * s["across"] / s["along"]))
    for c in (film[0], film[2]):
        mesh.setTransfiniteCurve(abs(c), s["along"] + 1, "Bump", bump)
    mesh.setTransfiniteSurface(surf, "Alternate")


def _threshold(f, dist: int, size: float, near: float, far: float) -> int:
    thr = f.add("Threshold")
    f.setNumber(thr, "InField", dist)
    f.setNumber(thr, "SizeMin", size)
    f.setNumber(thr, "SizeMax", far)
    f.setNumber(thr, "DistMin", near)
    f.setNumber(thr, "DistMax", near + (far - size) / GROWTH)
    return thr


def _size_field(gmsh, curves, corners, s) -> None:
    """Sizes growing linearly (slope GROWTH) from the gap size at the film's ends and exit walls, and
    from CORNER_REFINEMENT times it at the corners (pressure singularities), to the far size."""
    f = gmsh.model.mesh.field
    dist = f.add("Distance")
    f.setNumbers(dist, "CurvesList", [abs(c) for c in curves])
    f.setNumber(dist, "Sampling", 400)
    pts = f.add("Distance")
    f.setNumbers(pts, "PointsList", corners)
    fields = [_threshold(f, dist, s["gap"], 0.5 * s["film"], s["far"]),
              _threshold(f, pts, CORNER_REFINEMENT * s["gap"], 0.0, s["far"])]
    both = f.add("Min")
    f.setNumbers(both, "FieldsList", fields)
    f.setAsBackgroundMesh(both)
    opt = gmsh.option
    opt.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    opt.setNumber("Mesh.MeshSizeFromPoints", 0)
    opt.setNumber("Mesh.MeshSizeFromCurvature", 0)
    opt.setNumber("Mesh.Algorithm", 6)
