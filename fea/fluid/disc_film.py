"""The disc valve's sealing film by the Reynolds FE: C1, C2 and the film's conductance for any disc.

Geometry (thesis section 2.2.2.1, Figure 2.4): the disc's bevel and the seat's cone, half
angle theta to the axis, face each other from the radius R_i to R_o. A lift x of the disc
along the axis opens a film of normal thickness h = x sin(theta) (the thesis's x' of eq 2.8)
whose walls separate at dh/dt = u sin(theta). On the cone, s = r / sin(theta) is the distance
from the apex along the surface and the circumference at s is 2 pi s sin(theta); an
axisymmetric film on the cone therefore obeys the same equation as a flat annulus of radii
R_i' = R_i / sin(theta) .. R_o' = R_o / sin(theta) (eq 2.7), with

    Q = sin(theta) Q',
    F = pi R_i^2 dP + sin^2(theta) int_annulus' (p - P_down) dA',

Q' the flat annulus's flow (its circumference is 2 pi s instead of 2 pi s sin(theta)); the axial
projection of the cone's area is sin^2(theta) dA' (eq 2.12).

The footprint is meshed as that flat annulus in two dimensions (a structured polar
triangulation, every vertex on its circle, so three meshes in the ratio 2 are nested in
size; :func:`annulus_mesh`) and solved with :func:`fea.fluid.reynolds.solve_film`. The
axisymmetric solution is exact, so the closed forms of eqs 2.14-2.15 are an independent
check of the 2-D solver (tests/test_fluid_film.py).

C1 = F_Poiseuille / (dP pi R_o^2) (eq 2.14) and C2 = -F_squeeze x^3 / u (eq 2.15).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from skfem import MeshTri

from geometry.errors import InputError

from ..convergence import GCI_STANDARD_FACTOR, gci
from .reynolds import FilmOptions, solve_film

#: radial divisions of the default mesh (level 0 of :func:`film_ladder` is half of it)
DEFAULT_DIVISIONS = 16


@dataclass(frozen=True)
class DiscFilm:
    """The film's geometry: seat radii R_i < R_o [m], bevel half angle theta [rad] (0 < theta <= pi/2)."""

    inner_radius: float
    outer_radius: float
    bevel_angle: float

    def __post_init__(self):
        if not (self.inner_radius > 0 and self.outer_radius > self.inner_radius):
            raise InputError("seat.inner_radius", f"need 0 < R_i < R_o, got R_i = {self.inner_radius!r} m, "
                             f"R_o = {self.outer_radius!r} m")
        if not 0.0 < self.bevel_angle <= math.pi / 2 + 1e-12:
            raise InputError("seat.bevel_angle", f"must lie in (0, pi/2] rad, got {self.bevel_angle!r}")

    @property
    def slant_radii(self) -> tuple[float, float]:
        """(R_i', R_o') = (R_i, R_o) / sin(theta) [m]: the flat annulus the cone's film maps to."""
        s = math.sin(self.bevel_angle)
        return self.inner_radius / s, self.outer_radius / s


@dataclass(frozen=True)
class FilmCoefficients:
    """C1 [-] (eq 2.14), C2 [N m^2 s] (eq 2.15), the film conductance K = Q x^-3 / dP [m/(Pa s)]
    (Q = K x^3 dP) and the squeeze flow split: the share of the swept volume rate A_disc u that
    enters through the inner edge (from the port), on the mesh of ``divisions`` radial cells."""

    c1: float
    c2: float
    conductance: float
    inner_share: float
    divisions: int
    dofs: int
    size: float


def annulus_mesh(r_in: float, r_out: float, divisions: int) -> MeshTri:
    """Structured triangles of the annulus r_in <= r <= r_out [m]: ``divisions`` radial cells and
    a multiple of 8 angular ones of about the same size, every vertex on its circle; boundaries
    ``inner`` and ``outer``. Doubling ``divisions`` halves every cell."""
    if divisions < 1:
        raise InputError("divisions", f"need at least one radial cell, got {divisions}")
    width = r_out - r_in
    base = max(8, 8 * math.ceil(2 * math.pi * 0.5 * (r_in + r_out) / width / 8))
    n_phi = base * divisions
    r = np.linspace(r_in, r_out, divisions + 1)
    phi = np.linspace(0.0, 2 * math.pi, n_phi, endpoint=False)
    R, P = np.meshgrid(r, phi, indexing="ij")
    pts = np.vstack([(R * np.cos(P)).ravel(), (R * np.sin(P)).ravel()])
    idx = np.arange(pts.shape[1]).reshape(divisions + 1, n_phi)
    a, b = idx[:-1], np.roll(idx[:-1], -1, axis=1)
    c, d = idx[1:], np.roll(idx[1:], -1, axis=1)
    # alternate the diagonal so the triangulation has no preferred direction
    flip = ((np.arange(divisions)[:, None] + np.arange(n_phi)[None, :]) % 2).astype(bool)
    t1 = np.where(flip[..., None], np.stack([a, b, d], -1), np.stack([a, b, c], -1))
    t2 = np.where(flip[..., None], np.stack([a, d, c], -1), np.stack([b, d, c], -1))
    tri = np.ascontiguousarray(np.vstack([t1.reshape(-1, 3), t2.reshape(-1, 3)]).T)
    mid = 0.5 * (r_in + r_out)
    return MeshTri(pts, tri).with_boundaries({"inner": lambda x: np.hypot(x[0], x[1]) < mid,
                                              "outer": lambda x: np.hypot(x[0], x[1]) > mid})


def film_coefficients(film: DiscFilm, viscosity: float, divisions: int = DEFAULT_DIVISIONS,
                      order: int = 1) -> FilmCoefficients:
    """C1, C2 and the conductance of the disc's film by the Reynolds FE (module docstring).

    The film is solved once for a unit pressure difference and once for a unit wall
    velocity at a reference lift (the results scale exactly with dP, u and x^-3).

    Examples
    --------
    The thesis disc (section 2.4.2: C1 = 0.714; C2 = 7.630e-11 N m^2 s, which eq 2.15 gives with
    the viscosity at 21 C, 0.07054 Pa s: docs/errata.md):

    >>> c = film_coefficients(DiscFilm(5.24e-3, 7.5e-3, math.radians(54.0)), 0.07054, divisions=64)
    >>> print(f"C1 = {c.c1:.3f}, C2 = {c.c2:.3e} N m^2 s")
    C1 = 0.714, C2 = 7.622e-11 N m^2 s
    """
    s = math.sin(film.bevel_angle)
    r_in, r_out = film.slant_radii
    mesh = annulus_mesh(r_in, r_out, divisions)
    x_ref, u_ref, dp = 1.0e-4, 1.0e-3, 1.0
    sol = solve_film(mesh, x_ref * s, viscosity, {"inner": dp, "outer": 0.0}, wall_velocity=u_ref * s,
                     options=FilmOptions(order=order))
    a_disc = math.pi * film.outer_radius**2
    f_pois = math.pi * film.inner_radius**2 * dp + s * s * sol.force_poiseuille
    f_sq = s * s * sol.force_squeeze
    q = s * sol.flows_poiseuille["outer"]
    # squeeze: the swept volume rate of the annulus is sin^2(theta) u A' (projected); the flow out of
    # the inner edge (negative: toward the port) is what the port must supply
    swept = s * s * u_ref * sol.area
    inner = -s * sol.flows_squeeze["inner"]
    return FilmCoefficients(c1=f_pois / (dp * a_disc), c2=-f_sq * x_ref**3 / u_ref,
                            conductance=q / (dp * x_ref**3), inner_share=inner / swept, divisions=divisions,
                            dofs=sol.dofs, size=(r_out - r_in) / divisions)


def closed_form(film: DiscFilm, viscosity: float) -> dict:
    """The thesis's closed forms: C1 (eq 2.14), C2 (eq 2.15) and the conductance K of the film
    (Q = K x^3 dP, K = pi sin^4(theta) / (6 mu ln(R_o / R_i)): eq 2.11's Poiseuille part, the
    viscous log law of radial flow)."""
    from lumped.valves.disc import c1_coefficient, c2_coefficient

    ri, ro, th = film.inner_radius, film.outer_radius, film.bevel_angle
    return {"c1": c1_coefficient(ri, ro), "c2": c2_coefficient(ri, ro, th, viscosity),
            "conductance": math.pi * math.sin(th) ** 4 / (6.0 * viscosity * math.log(ro / ri))}


def film_ladder(film: DiscFilm, viscosity: float, divisions: int = DEFAULT_DIVISIONS, order: int = 1) -> dict:
    """C1, C2 and K on three meshes (divisions/2, divisions, 2 divisions) with their GCI.

    Returns ``{"levels": [FilmCoefficients coarse..fine], "gci": {name: GCI}}``; the GCI's
    ``u_fine`` is the band of the finest value, ``extrapolated`` Richardson's limit.
    """
    if divisions < 2 or divisions % 2:
        raise InputError("divisions", f"the ladder halves the mesh: give an even number >= 2, got {divisions}")
    levels = [film_coefficients(film, viscosity, n, order) for n in (divisions // 2, divisions, 2 * divisions)]
    sizes = [lv.size for lv in reversed(levels)]
    out = {}
    for name in ("c1", "c2", "conductance", "inner_share"):
        out[name] = gci([getattr(lv, name) for lv in reversed(levels)], sizes=sizes)
    return {"levels": levels, "gci": out}


# ------------------------------------------------------------------ the thin_film fidelity


def _film_point(valve, film: DiscFilm, c: FilmCoefficients, lift: float, reynolds: float) -> dict:
    """The outputs of one mesh: Q from Re (eq 2.46), dP = Q / (K x^3), Cd (eq 2.44), the force C1 dP A_disc."""
    v = valve.params
    q = valve.flow_of(reynolds)
    dp = q / (c.conductance * lift**3)
    a_disc = math.pi * film.outer_radius**2
    a_port = math.pi * v.port_diameter**2 / 4
    # displacement: the port feeds the face inside R_i and the film's inner share (linear: f1 = f2)
    a_q = math.pi * film.inner_radius**2 + c.inner_share * (a_disc - math.pi * film.inner_radius**2)
    return {"flow": q, "dp": dp, "cd": q / (valve.orifice_area(lift) * math.sqrt(2 * dp / valve.density)),
            "force": c.c1 * dp * a_disc, "force_coefficient": c.c1, "C1": c.c1, "C2": c.c2,
            "A_Q": a_q, "f": (a_q - a_port) / (a_disc - a_port),
            "c_visc": c.c2 / (lift**3 * valve.viscosity * 2 * film.outer_radius)}


def thin_film_point(valve, lift: float, reynolds: float, options=None):
    """The ``thin_film`` fidelity of a disc valve at (lift [m], Re): the Reynolds FE of its sealing film.

    The film is the whole flow path (no inertia, no port or housing): valid while the lift is
    small against the seat width (x sin^2(theta) / (R_o - R_i) < eps0, eq 2.18). ``options``:
    ``divisions`` (radial cells, default :data:`DEFAULT_DIVISIONS`), ``gci`` (True: the ladder
    divisions/2, divisions, 2 divisions gives ``u_num``), ``squeeze`` and ``displacement`` (add
    ``film`` {C1, C2, F4} and ``displacement`` {f1, f2, A_Q_closing, A_Q_opening, c_visc}).
    """
    from .point import FlowPoint, check_lift, check_reynolds, check_valve

    opts = dict(options or {})
    valve = check_valve(valve)
    if valve.kind != "disc":
        raise InputError("valve", f"this thin_film fidelity models the disc's conical film; the "
                         f"{valve.kind} valve's film is meshed by its own module")
    lift, reynolds = check_lift(valve, lift), check_reynolds(reynolds)
    v = valve.params
    film = DiscFilm(v.inner_radius, v.outer_radius, v.bevel_angle)
    n = int(opts.get("divisions", DEFAULT_DIVISIONS))
    t0 = time.process_time()
    if opts.get("gci"):
        ladder = film_ladder(film, valve.viscosity, n)
        outs = [_film_point(valve, film, c, lift, reynolds) for c in ladder["levels"]]
        sizes = [c.size for c in reversed(ladder["levels"])]
        u_num = {k: gci([o[k] for o in reversed(outs)], sizes=sizes).band(1) / GCI_STANDARD_FACTOR
                 for k in ("dp", "cd", "force", "C1", "C2", "f")}
        out, dofs = outs[1], ladder["levels"][1].dofs
    else:
        c = film_coefficients(film, valve.viscosity, n)
        out, u_num, dofs = _film_point(valve, film, c, lift, reynolds), {}, c.dofs
    extra = {"mesh": {"dofs": dofs, "size": (film.slant_radii[1] - film.slant_radii[0]) / n, "divisions": n},
             "regime_parameter": lift * math.sin(film.bevel_angle) ** 2 / (film.outer_radius - film.inner_radius),
             "cpu_seconds": time.process_time() - t0}
    if opts.get("squeeze"):
        extra["film"] = {"C1": out["C1"], "C2": out["C2"], "F4": None}
    if opts.get("displacement"):
        extra["displacement"] = {"f1": out["f"], "f2": out["f"], "A_Q_closing": out["A_Q"], "A_Q_opening": out["A_Q"],
                                 "c_visc": out["c_visc"]}
    return FlowPoint(lift=lift, reynolds=reynolds, flow=out["flow"], dp=out["dp"], cd=out["cd"], force=out["force"],
                     force_coefficient=out["force_coefficient"], flow_force=None,
                     u_num={k: u_num[k] for k in ("dp", "cd", "force") if k in u_num}, extra=extra)
