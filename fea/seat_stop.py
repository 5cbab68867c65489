"""Seat and stop stiffness of the disc valve by 3-D static FEA (thesis section 2.4.3.2).

Each part (``geometry.seat_stop``) is meshed by gmsh (OCC: a revolved profile, the
housing's flow windows cut as boxes) into tetrahedra and solved with quadratic (P2)
elements. The thesis's load (600 N on the seat, 125 N on the stop) is spread uniformly
over the contact surface (the seating cone; the disc-rim annulus of the stop); the
stiffness is the load over the area-mean displacement of that surface along the load
(the thesis averaged four points "around the seat midpoint"), k = F / u_mean (eq 2.20),
and the contact damping is critical, c = 2 sqrt(k m) (eq 2.23).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import meshio
import numpy as np
import scipy.sparse.linalg as spla
from skfem import Basis, ElementTetP2, FacetBasis
from skfem.io.meshio import from_meshio

from lumped.valves.forces import critical_damping  # eq 2.23, written once
from geometry.seat_stop import HousingStop, SeatRing, load_housing_stop, load_seat_ring

from .mesh import _gmsh_session, gmsh_cells
from .solid import assemble

#: default tetrahedron size [m]
DEFAULT_MESH_SIZE = 1.0e-3


@dataclass(frozen=True)
class ContactStiffness:
    """k [N/m] = load / mean displacement of the loaded surface; c [N s/m] critical (eq 2.23)."""

    part: str
    load: float
    mean_displacement: float
    stiffness: float
    damping: float
    mass: float
    dofs: int
    mesh_size: float

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def _revolved_mesh(profile: list[tuple[float, float]], mesh_size: float, cut=None):
    """Tetrahedral mesh [m] of the (r, z) polygon revolved about z; ``cut(occ)`` returns tools to subtract."""
    with _gmsh_session() as gmsh:
        occ = gmsh.model.occ
        pts = [occ.addPoint(r, 0.0, z) for r, z in profile]
        lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
        surf = occ.addPlaneSurface([occ.addCurveLoop(lines)])
        vol = occ.revolve([(2, surf)], 0, 0, 0, 0, 0, 1, 2 * math.pi)
        vols = [(d, t) for d, t in vol if d == 3]
        if cut is not None:
            vols, _ = occ.cut(vols, cut(occ))
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.2 * mesh_size)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 12)
        gmsh.option.setNumber("Mesh.Algorithm3D", 1)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        etypes, _, enodes = gmsh.model.mesh.getElements(3)
    xyz, t = gmsh_cells(tags, coords, etypes, enodes, 4, 4)   # gmsh type 4: linear tetrahedron
    return from_meshio(meshio.Mesh(xyz, [("tetra", t)]))


def _facet_geometry(mesh, facets):
    """Midpoints (3, n) and unit normals (3, n; sign arbitrary) of triangular facets."""
    p = mesh.p[:, mesh.facets[:, facets]]  # (3, 3 vertices, n)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], axis=0)
    return p.mean(axis=1), n / np.linalg.norm(n, axis=0)


def _static_stiffness(mesh, material, load_facets, fixed_facets, load: float, mesh_size: float, part: str,
                      mass: float) -> ContactStiffness:
    basis = Basis(mesh, ElementTetP2(), intorder=2)  # P2 stiffness is exact at order 2 on straight tets
    K, _ = assemble(basis, material.youngs_modulus, material.poisson_ratio, material.density)
    fb = FacetBasis(mesh, ElementTetP2(), facets=load_facets, intorder=4)
    area = float(fb.dx.sum())
    # uniform axial traction -F/A e_z (toward the support), distributed consistently
    f = np.zeros(3 * basis.N)
    for a in range(len(fb.basis)):
        np.add.at(f, 3 * fb.element_dofs[a] + 2, -load / area * (np.asarray(fb.basis[a][0]) * fb.dx).sum(axis=1))
    fixed = basis.get_dofs(facets=fixed_facets).all()
    fixed = (3 * fixed[:, None] + np.arange(3)[None, :]).ravel()
    free = np.setdiff1d(np.arange(3 * basis.N), fixed)
    u = np.zeros(3 * basis.N)
    u[free] = spla.splu(K[free][:, free].tocsc(), permc_spec="MMD_AT_PLUS_A").solve(f[free])
    # area-mean axial displacement of the loaded surface
    uz = np.zeros(basis.N)
    uz[:] = u[2::3]
    mean = -float(sum((np.asarray(fb.basis[a][0]) * fb.dx).sum(axis=1) @ uz[fb.element_dofs[a]]
                      for a in range(len(fb.basis)))) / area
    k = load / mean
    return ContactStiffness(part=part, load=load, mean_displacement=mean, stiffness=k,
                            damping=critical_damping(k, mass), mass=mass, dofs=len(free), mesh_size=mesh_size)


def _contact_mass() -> float:
    """The mass the thesis used in eq 2.23 (thesis-disc's mass.contact_reference) [kg]."""
    from lumped.model.model_file import load_model

    return float(load_model("thesis-disc").inlet.contact_mass)


def seat_stiffness(seat: SeatRing | None = None, mesh_size: float | None = None) -> ContactStiffness:
    """Stiffness of the disc valve's seat ring by axisymmetric-like 3-D FEA: the thesis's 600 N spread over the
    seating cone, bottom face bonded (section 2.4.3.2).

    Parameters
    ----------
    seat : geometry.seat_stop.SeatRing, optional
        The ring (None: the thesis's).
    mesh_size : float, optional
        Element size [m].

    Returns
    -------
    ContactStiffness
        k_seat [N/m], its critical damping (eq 2.23) [N s/m], the mean displacement [m].

    References
    ----------
    Knutson (2016), section 2.4.3.2, Table 2.3 (3.02e9 N/m).
    """
    seat = seat or load_seat_ring()
    h = DEFAULT_MESH_SIZE if mesh_size is None else mesh_size
    prof = [(seat.bore_radius, 0.0), (seat.outer_radius, 0.0), (seat.outer_radius, seat.height),
            (seat.cone_outer_radius, seat.height), (seat.bore_radius, seat.bore_length)]
    mesh = _revolved_mesh(prof, h)
    bf = mesh.boundary_facets()
    mid, n = _facet_geometry(mesh, bf)
    r = np.hypot(mid[0], mid[1])
    # the cone's normal makes the angle (90 deg - theta) with the axis: |n_z| = sin(theta)
    cone = (np.abs(np.abs(n[2]) - math.sin(seat.bevel_angle)) < 0.1) & (r < seat.cone_outer_radius + 1e-9)
    bottom = (np.abs(mid[2]) < 1e-9) & (np.abs(n[2]) > 0.99)
    return _static_stiffness(mesh, seat.material, bf[cone], bf[bottom], seat.load, h, "seat", _contact_mass())


def stop_stiffness(stop: HousingStop | None = None, mesh_size: float | None = None) -> ContactStiffness:
    """Stiffness of the disc valve's housing stop by 3-D FEA: the thesis's 125 N on the disc-rim annulus of the end
    wall, base bonded (section 2.4.3.2).

    Parameters
    ----------
    stop : geometry.seat_stop.HousingStop, optional
        The housing (None: the thesis's).
    mesh_size : float, optional
        Element size [m].

    Returns
    -------
    ContactStiffness
        k_stop [N/m], its critical damping [N s/m], the mean displacement [m].

    References
    ----------
    Knutson (2016), section 2.4.3.2, Table 2.3 (1.91e6 N/m).
    """
    stop = stop or load_housing_stop()
    h = DEFAULT_MESH_SIZE if mesh_size is None else mesh_size
    Hw, t = stop.wall_height, stop.end_thickness
    prof = [(stop.inner_radius, 0.0), (stop.outer_radius, 0.0), (stop.outer_radius, Hw + t),
            (stop.hole_radius, Hw + t), (stop.hole_radius, Hw), (stop.contact_inner_radius, Hw),
            (stop.contact_outer_radius, Hw), (stop.inner_radius, Hw)]

    def windows(occ):
        tools = []
        for k in range(stop.windows):
            b = occ.addBox(stop.inner_radius - 1e-3, -stop.window_width / 2, stop.window_base,
                           stop.outer_radius - stop.inner_radius + 2e-3, stop.window_width, stop.window_height)
            occ.rotate([(3, b)], 0, 0, 0, 0, 0, 1, 2 * math.pi * (k + 0.5) / stop.windows)
            tools.append((3, b))
        return tools

    mesh = _revolved_mesh(prof, h, cut=windows if stop.windows else None)
    bf = mesh.boundary_facets()
    mid, n = _facet_geometry(mesh, bf)
    r = np.hypot(mid[0], mid[1])
    ring = ((np.abs(mid[2] - Hw) < 1e-9) & (np.abs(n[2]) > 0.99)
            & (r > stop.contact_inner_radius) & (r < stop.contact_outer_radius))
    base = (np.abs(mid[2]) < 1e-9) & (np.abs(n[2]) > 0.99)
    res = _static_stiffness(mesh, stop.material, bf[ring], bf[base], stop.load, h, "stop", _contact_mass())
    # the load pushes the end wall up (+z), away from the base: report magnitudes
    return ContactStiffness(**{**res.as_dict(), "mean_displacement": abs(res.mean_displacement),
                               "stiffness": abs(res.stiffness)})


def seat_and_stop(mesh_size: float | None = None, progress: bool = True) -> dict:
    """The seat's and the stop's stiffness and critical damping as plain dicts.

    Parameters
    ----------
    mesh_size : float, optional
        Element size [m].
    progress : bool
        Progress on stderr.

    Returns
    -------
    dict
        {"seat": ..., "stop": ...} (ContactStiffness.as_dict: N/m, N s/m, m).
    """
    out = {}
    for name, fn in (("seat", seat_stiffness), ("stop", stop_stiffness)):
        if progress:
            print(f"seat/stop FEA: {name}", file=sys.stderr, flush=True)
        out[name] = fn(mesh_size=mesh_size).as_dict()
    return out
