"""The ``axisymmetric`` fluid fidelity: laminar Navier-Stokes through the disc valve (port, gap, housing).

Per operating point (lift x [m], Reynolds number Re of eq 2.46) on the mesh of
:mod:`fea.fluid.valve_mesh` (domain and assumptions there), solved by
:func:`fea.fluid.navier_stokes.solve_flow`:

- steady flow: the port's inlet carries the developed (parabolic) profile of Q = Re mu p /
  (4 rho) (eq 2.46), the housing's window slot and end-wall hole are outlets at the downstream
  pressure (0). dP is the area-mean pressure over the inlet (the port's length L, Table 2.3,
  is part of the valve, as the thesis's control volume L + x of eq 2.31);
  Cd = Q / (A_o sqrt(2 dP / rho)) (eq 2.44, A_o of eq 2.40, so it compares with eq 2.48);
  the force F [N] of the fluid on the disc (pressure and viscous, all faces) and its force
  coefficient F / (dP A_disc) (the C1 of eq 2.13 in the thin-film limit, 1 in eq 2.18's
  orifice regime);
- steady flow force (eqs 2.29-2.36): the thesis's control volume is the port cylinder of
  length L + x; with the computed field, F_flow,s = M_in - M_out, M_in = int rho u_z^2 dA over
  the inlet, M_out = int rho u_z u_r dA over the cylinder's side r = d_port / 2, 0 < z < x
  (the axial momentum leaving with the jet). The effective jet angle solves eq 2.36 for theta:
  cos(theta_jet) = (rho Q^2 / A_port - F_flow,s) / (rho Q^2 / A_o), so that eq 2.36 with it
  returns the computed flow force (None where |cos| > 1: no angle reproduces it);
- moving disc (quasi-steady: the disc's surface moves at +-u in the frozen geometry):
  with the inlet at the steady point's pressure (a pressure inlet), A_Q = (Q(u) - Q(0)) / u
  for the flow entering through the port, closing (u < 0) and opening (u > 0), and f1, f2 of
  eq 2.42 with A_1 = A_port, A_2 = A_disc; from a Stokes solve at zero pressure difference the
  viscous drag coefficient of eq 2.28, c_visc = -F / (mu u d_disc), at that lift;
- ``u_num``: the GCI (Celik et al. 2008, :func:`fea.convergence.gci`) over three meshes of
  resolution n/2, n, 2n; the value reported is the middle one's, its band GCI32 / 1.15
  (ASME V&V 20, as :func:`fea.convergence.gci_study`).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, replace

from geometry.errors import InputError

from ..convergence import GCI_STANDARD_FACTOR, gci
from .navier_stokes import FlowBCs, FlowSolution, solve_flow
from .point import FlowPoint, FluidValve, check_lift, check_reynolds, check_valve
from .valve_mesh import DEFAULT_RESOLUTION, DiscDomain, disc_domain, valve_mesh

#: disc speed of the moving-wall solves [m/s] (the order of the pump's disc speeds: a 1 mm stroke
#: in a few milliseconds)
DISC_SPEED = 0.1
#: the steady outputs that get a GCI
STEADY = ("dp", "cd", "force", "force_coefficient", "flow_force", "jet_angle")
#: the moving-wall outputs
MOVING = ("f1", "f2", "A_Q_closing", "A_Q_opening", "c_visc", "C2")
#: walls of the domain (no slip, at rest)
WALLS = ("port_wall", "seat", "housing")


@dataclass(frozen=True)
class AxiOptions:
    """``resolution``: cells across the film (mesh refinement, :mod:`fea.fluid.valve_mesh`);
    ``gci``: run the three-mesh ladder for ``u_num``; ``moving``: the moving-wall solves (f1, f2,
    c_visc, C2); ``disc_speed`` [m/s]; ``progress`` on stderr; ``keep_solution``: the default mesh's
    steady :class:`~fea.fluid.navier_stokes.FlowSolution` in the point's ``extra["solution"]``
    (for a plot; not JSON)."""

    resolution: float = DEFAULT_RESOLUTION
    gci: bool = False
    moving: bool = False
    disc_speed: float = DISC_SPEED
    progress: bool = False
    keep_solution: bool = False

    @classmethod
    def of(cls, options) -> "AxiOptions":
        if isinstance(options, cls):
            return options
        opts = dict(options or {})
        moving = bool(opts.pop("displacement", False)) | bool(opts.pop("squeeze", False)) | bool(opts.pop("moving", False))
        known = {k: opts[k] for k in ("resolution", "gci", "disc_speed", "progress", "keep_solution") if k in opts}
        return cls(moving=moving, **known)


def _bcs(d: DiscDomain, inlet, disc_speed: float = 0.0) -> FlowBCs:
    """Walls at rest, the disc at (0, disc_speed), outlets at 0; ``inlet`` a flow [m^3/s] (parabolic
    profile) or ("pressure", p [Pa])."""
    velocity = {w: (0.0, 0.0) for w in WALLS}
    velocity["disc"] = (0.0, disc_speed)
    pressure = {"window": 0.0, "hole": 0.0}
    if isinstance(inlet, tuple):
        pressure["inlet"] = inlet[1]
    else:
        v_mean = inlet / (math.pi * d.port_radius**2)
        velocity["inlet"] = lambda r, z: (0.0 * r, 2.0 * v_mean * (1.0 - (r / d.port_radius) ** 2))
    return FlowBCs(axis=("axis",), velocity=velocity, pressure=pressure)


def _scales(valve: FluidValve, d: DiscDomain, lift: float, q: float) -> tuple[float, float]:
    """(length, velocity) of the dimensionless system: the gap's hydraulic diameter 2 x sin(theta)
    and the jet velocity Q / A_o, so that Re_l is the Re of eq 2.46 (the continuation's measure)."""
    return 2.0 * lift * math.sin(d.bevel_angle), max(q, 1e-12) / valve.orifice_area(lift)


def steady(valve: FluidValve, d: DiscDomain, mesh, lift: float, reynolds: float,
           initial: FlowSolution | None = None) -> tuple[dict, FlowSolution]:
    """The steady outputs (module docstring) at (lift, Re) on ``mesh``, and the solution."""
    v = valve.params
    q = valve.flow_of(reynolds)
    length, speed = _scales(valve, d, lift, q)
    if initial is not None:       # a point at another Re: its field scaled to this flow starts Newton
        ratio = q / -initial.flow("inlet")
        initial = replace(initial, u=initial.u * ratio, p=initial.p * ratio)
    sol = solve_flow(mesh, _bcs(d, q), valve.density, valve.viscosity, length, speed, initial=initial)
    dp = sol.mean_pressure("inlet")
    a_o, a_port, rho = valve.orifice_area(lift), v.port_area, valve.density
    force = sol.forces["disc"]
    m_in = sol.facet_integral("inlet", lambda ur, uz, r, z: rho * uz * uz)
    m_out = sol.facet_integral("cv_side", lambda ur, uz, r, z: rho * uz * ur)
    flow_force = m_in - m_out
    cos_jet = (rho * q * q / a_port - flow_force) / (rho * q * q / a_o)
    out = {"flow": q, "dp": dp, "cd": q / (a_o * math.sqrt(2.0 * dp / rho)), "force": force,
           "force_coefficient": force / (dp * v.disc_area), "flow_force": flow_force,
           "jet_angle": math.acos(cos_jet) if abs(cos_jet) <= 1.0 else None,
           "continuity": abs(sol.flow("window") + sol.flow("hole") - q) / q}
    return out, sol


def moving(valve: FluidValve, d: DiscDomain, mesh, lift: float, dp: float, base: FlowSolution,
           disc_speed: float) -> dict:
    """A_Q closing/opening, f1, f2 (eq 2.42) at the pressure difference ``dp``, and c_visc (eq 2.28)
    and the squeeze coefficient C2 = -dF x^3 / u (eq 2.13) from Stokes solves at zero dP."""
    v = valve.params
    length, speed = _scales(valve, d, lift, valve.flow_of(1.0))
    rho, mu = valve.density, valve.viscosity

    def inflow(u):
        s = solve_flow(mesh, _bcs(d, ("pressure", dp), u), rho, mu, length, speed, initial=base)
        return -s.flow("inlet")

    q0, qo, qc = inflow(0.0), inflow(disc_speed), inflow(-disc_speed)
    a1, a2 = v.port_area, v.disc_area
    aq_open, aq_close = (qo - q0) / disc_speed, (qc - q0) / -disc_speed
    drag = solve_flow(mesh, _bcs(d, ("pressure", 0.0), disc_speed), 0.0, mu, length, speed).forces["disc"]
    return {"A_Q_closing": aq_close, "A_Q_opening": aq_open, "f1": (aq_close - a1) / (a2 - a1),
            "f2": (aq_open - a1) / (a2 - a1), "c_visc": -drag / (mu * disc_speed * 2.0 * v.outer_radius),
            "C2": -drag * lift**3 / disc_speed}


def solve_point(valve: FluidValve, d: DiscDomain, lift: float, reynolds: float, resolution: float,
                opts: AxiOptions) -> dict:
    """Every output at one (lift, Re) on the mesh of ``resolution``, with DOFs and seconds."""
    t0 = time.process_time()
    mesh = valve_mesh(d, lift, resolution)
    out, sol = steady(valve, d, mesh, lift, reynolds)
    if opts.moving:
        out.update(moving(valve, d, mesh, lift, out["dp"], sol, opts.disc_speed))
    out.update(dofs=sol.dofs, newton=sol.newton, cpu_seconds=time.process_time() - t0, solution=sol)
    return out


def ladder_u(outs: list[dict], resolutions: list[float], names) -> dict:
    """{name: standard u_num} of the middle mesh from three meshes (coarse..fine), GCI32 / 1.15."""
    sizes = [1.0 / r for r in reversed(resolutions)]
    u = {}
    for k in names:
        vals = [o.get(k) for o in reversed(outs)]
        if any(x is None for x in vals):
            continue
        u[k] = float(gci(vals, sizes=sizes).band(1) / GCI_STANDARD_FACTOR)
    return u


def axisymmetric_point(valve: FluidValve, lift: float, reynolds: float, options=None) -> FlowPoint:
    """The ``axisymmetric`` fidelity at (lift [m], Re) of a disc valve (module docstring)."""
    valve = check_valve(valve)
    if valve.kind != "disc":
        raise InputError("valve", f"the axisymmetric model is the disc valve's; the {valve.kind} valve "
                         "is not axisymmetric")
    opts = AxiOptions.of(options)
    lift, reynolds = check_lift(valve, lift), check_reynolds(reynolds)
    d = disc_domain(valve.params)
    n = opts.resolution
    levels = [n / 2, n, 2 * n] if opts.gci else [n]
    outs = []
    for r in levels:
        if opts.progress:
            print(f"axisymmetric: lift {lift * 1e3:.4g} mm, Re {reynolds:g}, resolution {r:g}", file=sys.stderr,
                  flush=True)
        outs.append(solve_point(valve, d, lift, reynolds, r, opts))
    out = outs[levels.index(n)]
    u_num = ladder_u(outs, levels, STEADY + (MOVING if opts.moving else ())) if opts.gci else {}
    extra = {"jet_angle": out["jet_angle"], "mesh": {"dofs": out["dofs"], "resolution": n,
                                                     "size": lift * math.sin(d.bevel_angle) / n},
             "cpu_seconds": sum(o["cpu_seconds"] for o in outs), "continuity_error": out["continuity"]}
    if opts.moving:
        extra["displacement"] = {k: out[k] for k in ("f1", "f2", "A_Q_closing", "A_Q_opening", "c_visc")}
        extra["film"] = {"C1": out["force_coefficient"], "C2": out["C2"], "F4": None}
    if opts.gci:
        extra["u_num_all"] = u_num
    if opts.keep_solution:
        extra["solution"] = out["solution"]
    return FlowPoint(lift=lift, reynolds=reynolds, flow=out["flow"], dp=out["dp"], cd=out["cd"], force=out["force"],
                     force_coefficient=out["force_coefficient"], flow_force=out["flow_force"],
                     u_num={k: u_num[k] for k in ("dp", "cd", "force", "force_coefficient", "flow_force") if k in u_num},
                     extra=extra)


def with_resolution(options, resolution: float) -> AxiOptions:
    """``options`` at another mesh resolution."""
    return replace(AxiOptions.of(options), resolution=resolution)
