"""3-D laminar Navier-Stokes of a reed valve: Cd, the pressure load multiplier X, the flow force, A_Q.

The fluid around the reed (:mod:`fea.fluid.reed_mesh`: port, gap, grooves, chamber up to
the stop, half domain) with the reed deflected to a tip opening x along its static shape
psi(s) (exact Euler-Bernoulli on the real grooved profile, :func:`lumped.reed.euler_bernoulli.shape`,
or a FE fidelity's). Steady flow driven by the pressure difference dP between the port's
bottom (inlet, traction -P_up n) and the chamber's open sides (outlet, P_down = 0); the
solver is :mod:`fea.fluid.ns3d` (Taylor-Hood P2-P1, Newton). Outputs per (x, dP):

- Q [m^3/s], the flow through the port (both halves);
- Re = 4 rho Q / (p_o mu), eq 3.87's definition (corrected reciprocal, docs/errata.md);
- Cd = Q / (l_o x sqrt(2 dP / rho)), eq 3.84 with the orifice area A_o = l_o x of eq 3.25;
- X = iint psi dP_face dA / (dP int psi W ds), eq 3.49, with the face load of the full
  fluid stress: the generalized force of the traction on every face of the reed for the
  virtual displacement psi(s) e_z (pressure and viscous stress; ``X_pressure`` the pressure alone);
- F [N], the net fluid force on the reed along z (the flow force with the pressure);
- from moving-wall solves (dP = 0, the reed's faces moving at psi(s) u e_z): the fluid
  displacement area A_Q = Q_port / u (eq 3.23) and f = (A_Q - A_1) / (A_2 - A_1) (eq 3.26),
  at the two signs of u (f1 closing, f2 opening).

l_o and p_o are the valve's (the model file's; for the prototype 19.4 mm and 91.2 mm, eqs
3.25, 3.86), so Cd and Re compare with eq 3.89 as the bench data were reduced.
"""

from __future__ import annotations

import resource
import sys
import time
from dataclasses import dataclass, field, replace

import numpy as np
from skfem import ElementTetP1, ElementTetP2, FacetBasis, Functional

from geometry.reed import Reed
from geometry.reed_port import face_rule

from . import ns3d
from .reed_mesh import Layers, MeshOptions, ReedSeat, fluid_mesh


@dataclass(frozen=True)
class ReedValveFlow:
    """What a reed flow solve needs besides the opening: geometry, shape, oil, orifice definitions (SI).

    ``shape``: (s [m], psi) with psi(L) = 1 (the deflected shape and the mode function);
    ``orifice_length`` l_o [m] and ``orifice_perimeter`` p_o [m] define Cd and Re (eqs 3.25,
    3.86); ``area_min`` A_1 and ``area_max`` A_2 [m^2] define f (eq 3.26); ``stiffness``
    kappa [Pa/m] (eq 3.30) sets the pressure differences worth computing (:func:`pressure_cap`);
    ``grad_div`` gamma / mu of the grad-div term (:func:`fea.fluid.ns3d.grad_div_matrix`); ``inlet_total``:
    the inlet's pressure is a total pressure (:data:`fea.fluid.ns3d.INFLOW_BETA`, :func:`flow_system`).
    """

    reed: Reed
    seat: ReedSeat
    shape: tuple[np.ndarray, np.ndarray]
    fluid: ns3d.Fluid
    orifice_length: float
    orifice_perimeter: float
    area_min: float
    area_max: float
    stiffness: float
    mesh: MeshOptions = field(default_factory=MeshOptions)
    grad_div: float = 0.0        # gamma / mu of the grad-div stabilisation (ns3d.grad_div_matrix; 0: none)
    inlet_total: bool = True     # the inlet's P a total pressure (ns3d.INFLOW_BETA), else the traction's

    def psi(self, s):
        """psi(s) on the reed (interpolated shape; 0 before the clamp, psi(L) beyond the tip)."""
        s_psi, psi = self.shape
        return np.interp(np.asarray(s, float), s_psi, psi)

    @property
    def modal_area(self) -> float:
        """int_0^L psi W ds [m^2], the denominator of eq 3.49 (the whole face)."""
        s, y, w = face_rule(self.reed)
        return float(np.sum(w * self.psi(s)))


@dataclass(frozen=True)
class FlowPoint:
    """One steady solve at tip opening x [m] and pressure difference dp [Pa] (SI; see the module docstring)."""

    opening: float
    dp: float
    flow: float
    reynolds: float
    cd: float
    multiplier: float
    multiplier_pressure: float
    force: float
    dofs: int
    newton_steps: int
    seconds: float
    peak_rss_gb: float
    peclet_max: float = float("nan")       # the largest mesh Peclet number (ns3d.mesh_peclet)
    peclet_p95: float = float("nan")       # its 95th percentile over the cells


def flow_system(valve: ReedValveFlow, mesh) -> ns3d.System:
    """The Navier-Stokes system of a reed's fluid mesh (:func:`fea.fluid.ns3d.assemble`): no slip on the
    walls and the reed, the outlet stabilised against backflow, the inlet's traction a total pressure when
    ``valve.inlet_total`` (the port fed from a plenum at P_up: for an inflow U the static pressure there is
    P_up - rho U^2 / 2) and the grad-div term gamma = ``valve.grad_div`` mu."""
    return ns3d.assemble(mesh, valve.fluid, grad_div=valve.grad_div * valve.fluid.mu,
                         inflow=("inlet",) if valve.inlet_total else ())


def _peak_rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def reed_forces(system: ns3d.System, x: np.ndarray, valve: ReedValveFlow) -> tuple[float, float, float]:
    """(generalized force of the full stress, of the pressure alone, net z force) on the reed [N], both halves.

    Traction on the reed t = -sigma n with n the fluid's outward normal (pointing into the
    reed), sigma = -p I + mu (grad u + grad u^T); weighted by psi(s) for the generalized force.
    """
    mesh, n, mu = system.mesh, system.nv, system.fluid.mu
    facets = mesh.boundaries["reed"]
    fv = FacetBasis(mesh, ElementTetP2(), facets=facets)
    fq = FacetBasis(mesh, ElementTetP1(), facets=facets, quadrature=fv.quadrature)
    u = [fv.interpolate(x[a * n:(a + 1) * n]) for a in range(3)]
    p = fq.interpolate(x[3 * n:])

    def tz(w, viscous: bool):
        t = w["p"] * w.n[2]
        if viscous:
            g = [w[f"u{a}"].grad for a in range(3)]
            t = t - mu * sum((g[2][b] + g[b][2]) * w.n[b] for b in range(3))
        return t

    @Functional
    def gen(w):
        return valve.psi(w.x[0]) * tz(w, True)

    @Functional
    def gen_p(w):
        return valve.psi(w.x[0]) * tz(w, False)

    @Functional
    def net(w):
        return tz(w, True)

    kw = {"p": p, "u0": u[0], "u1": u[1], "u2": u[2]}
    return tuple(2.0 * float(f.assemble(fv, **kw)) for f in (gen, gen_p, net))


def point_outputs(system: ns3d.System, x: np.ndarray, valve: ReedValveFlow, opening: float, dp: float,
                  steps: int, seconds: float) -> FlowPoint:
    """The outputs of one steady pressure-driven solve (module docstring)."""
    rho, mu = system.fluid.rho, system.fluid.mu
    Q = -2.0 * ns3d.boundary_flux(system, x, "inlet")
    gen, gen_p, net = reed_forces(system, x, valve)
    area = valve.modal_area
    pe = ns3d.mesh_peclet(system, x)
    return FlowPoint(opening=opening, dp=dp, flow=Q, reynolds=4 * rho * Q / (valve.orifice_perimeter * mu),
                     cd=Q / (valve.orifice_length * opening * np.sqrt(2 * dp / rho)),
                     multiplier=gen / (dp * area), multiplier_pressure=gen_p / (dp * area), force=net,
                     dofs=system.ndofs, newton_steps=steps, seconds=seconds, peak_rss_gb=_peak_rss_gb(),
                     peclet_max=float(np.max(pe)), peclet_p95=float(np.percentile(pe, 95)))


#: the pressure differences a reed valve sees: up to this multiple of the quasi-static kappa x
#: (eq 3.82 with X = 1: the reed held at x by its stiffness; X < 1 and the reed's inertia and
#: damping raise dP above it in the pump, by less than this factor where X > 0.1)
DP_SCALE = 10.0


def pressure_cap(valve: ReedValveFlow, opening: float) -> float:
    """Largest dP [Pa] of a sweep at tip opening ``opening`` [m]: DP_SCALE kappa x (module docstring)."""
    return DP_SCALE * valve.stiffness * opening


def _guess(history: list[tuple[float, np.ndarray]], dp: float, n3: int) -> np.ndarray:
    """Initial state at dp from the last solutions: velocity scaled by (dp / dp_last)^a, a the
    last two points' d ln|u| / d ln dp (1 in the Stokes regime, -> 1/2 with inertia); pressure by dp / dp_last."""
    dp1, x1 = history[-1]
    a = 1.0
    if len(history) > 1:
        dp0, x0 = history[-2]
        u0, u1 = np.linalg.norm(x0[:n3]), np.linalg.norm(x1[:n3])
        a = float(np.clip(np.log(u1 / u0) / np.log(dp1 / dp0), 0.5, 1.0))
    x = x1.copy()
    x[:n3] *= (dp / dp1) ** a
    x[n3:] *= dp / dp1
    return x


def _next_dp(points: list[FlowPoint], reynolds: float) -> float:
    """dP [Pa] expected to give ``reynolds`` from the last points: Re ~ dP^a with a the last
    two points' log slope (1 in the Stokes limit, the first point), 1/2 <= a <= 1."""
    last = points[-1]
    a = 1.0
    if len(points) > 1 and last.dp != points[-2].dp:
        prev = points[-2]
        a = float(np.clip(np.log(last.reynolds / prev.reynolds) / np.log(last.dp / prev.dp), 0.5, 1.0))
    return last.dp * (reynolds / last.reynolds) ** (1.0 / a)


def pressure_sweep(valve: ReedValveFlow, opening: float, reynolds=(), progress: bool = True,
                   on_point=None, dps=None, dp_max: float | None = None) -> list[FlowPoint]:
    """Steady flows at tip opening ``opening`` [m] toward increasing Reynolds numbers ``reynolds`` (eq 3.87).

    One mesh; the Stokes limit first (at dP = 1 Pa, Re -> 0), then Navier-Stokes by natural-parameter
    continuation in dP (``_continue_to``: adaptive steps from the previous solutions, Newton,
    pseudo-transient continuation where Newton fails): each aim's dP is chosen from the previous
    points to give the next Reynolds number (``_next_dp``; the Re reached is the output, within
    ~10 % of the aim). ``dps`` [Pa]: solve at these pressure differences instead (a mesh study
    compares meshes at one dP). ``on_point(point)`` is called after each solve (e.g. to save
    it), the continuation's intermediate points included. ``dp_max`` [Pa]: the largest pressure
    difference of a Reynolds-aimed sweep (the last point is solved at it when an aim needs more;
    :func:`pressure_cap`). Stops where the continuation fails (the reason on stderr).
    """
    t0 = time.perf_counter()
    fm = fluid_mesh(valve.reed, valve.seat, opening, valve.shape, valve.mesh)
    system = flow_system(valve, fm.mesh)
    unit = ns3d.traction_load(system, {"inlet": 1.0})
    x1 = ns3d.stokes(system, unit, np.zeros(len(system.fixed)))
    out = [point_outputs(system, x1, valve, opening, 1.0, 0, time.perf_counter() - t0)]
    if progress:
        print(f"reed3d x = {opening * 1e3:.3g} mm: {system.ndofs} DOFs, Stokes in {out[0].seconds:.0f} s, "
              f"X = {out[0].multiplier:.4f}", file=sys.stderr)
    if on_point is not None:
        on_point(out[0])
    run = _Continuation(system=system, valve=valve, opening=opening, unit=unit, history=[(1.0, x1)], out=out,
                        progress=progress, on_point=on_point)
    aims = [(float(d), None) for d in sorted(dps)] if dps is not None else [
        (None, float(r)) for r in sorted(reynolds)]
    for dp, re in aims:
        capped = False
        if dp is None:
            dp = _next_dp(out, re)
            if dp_max is not None and dp >= dp_max:
                if out[-1].dp >= CAP_NEAR * dp_max:
                    break                        # the last point is at the cap already
                dp, capped = dp_max, True
        if not _continue_to(run, dp) or capped:
            break
    if run.factor is not None:
        run.factor.free()
    return out


#: a sweep whose last point is within this fraction of its pressure cap stops there
CAP_NEAR = 0.9
#: Newton's tolerance in a sweep (relative velocity update; the outputs settle to ~1e-9 below it)
SWEEP_TOL = 1e-6
#: Newton steps of a continuation step before pseudo-transient continuation takes over (a full-step
#: Newton converging linearly is outside its quadratic basin)
SWEEP_NEWTON = 10
#: damped Newton steps in a row after which a continuation step goes to PTC (or is shortened)
SWEEP_DAMPED = 2
#: continuation: the largest ratio of the Reynolds numbers of two successive points at the start; it
#: grows by STEP_GROWTH (up to STEP_MAX) after a solve of at most QUICK_STEPS Newton steps and is
#: square-rooted after a failed one (at most MAX_HALVINGS times in a row); below STEP_FREE_RE the
#: flow is near Stokes and the steps are not limited. Measured on the prototype: Newton steps of 1.3x
#: in Re converge in 4 steps up to Re 16 at 1.71 mm (coarse mesh; beyond, 1.07-1.14x steps to Re 19.6),
#: steps of 3x need damping from Re ~ 3 on (0.57 mm, default mesh)
STEP_START, STEP_GROWTH, STEP_MAX, QUICK_STEPS, MAX_HALVINGS, STEP_FREE_RE = 1.5, 1.2, 2.0, 3, 4, 2.0
#: a target within this factor of the step's limit is taken whole (no sliver of a step left after it)
STEP_SLACK = 1.2


@dataclass
class _Continuation:
    """The state of one sweep's continuation (``_continue_to``)."""

    system: ns3d.System
    valve: ReedValveFlow
    opening: float
    unit: np.ndarray
    history: list                 # [(dP, state)] of the converged points
    out: list                     # their FlowPoints
    progress: bool
    on_point: object = None
    factor: object = None         # the last factorization (GMRES preconditioner of the next solve)
    ratio: float = STEP_START     # the current largest Reynolds-number ratio of a step
    pseudo_time: bool = True      # PTC as Newton's fallback (until it fails once in the sweep)


def _step_dp(run: _Continuation, dp: float) -> float:
    """The next dP [Pa] toward ``dp``: ``dp`` itself unless the Reynolds number expected there
    (Re ~ dP^a from the last two points, ``_next_dp``) exceeds the step's limit (by more than
    :data:`STEP_SLACK` in dP)."""
    last = run.out[-1]
    limit = max(run.ratio * last.reynolds, STEP_FREE_RE)
    d_limit = _next_dp(run.out, limit)
    return dp if d_limit * STEP_SLACK >= dp else d_limit


def _solve(run: _Continuation, d: float) -> tuple[np.ndarray, int]:
    """The steady state at dP = d from the last solutions: Newton (up to :data:`SWEEP_DAMPED` damped
    steps in a row), then, when Newton fails, pseudo-transient continuation from the same start
    (:func:`fea.fluid.ns3d.ptc`) unless PTC failed before in this sweep (the pseudo-time flow left
    the steady branch: the steady state is unstable there or not resolved; smaller Newton steps
    along the branch are then the only way on). ModelFailure if the last method fails."""
    guess = _guess(run.history, d, 3 * run.system.nv)
    rhs = d * run.unit
    try:
        x, steps, run.factor = ns3d.newton(run.system, rhs, guess, tol=SWEEP_TOL, max_iter=SWEEP_NEWTON,
                                           factor=run.factor, progress=run.progress, max_damped=SWEEP_DAMPED)
        return x, steps
    except Exception as exc:   # noqa: BLE001 - Newton's basin missed: pseudo-time from the same start
        run.factor = getattr(exc, "factor", run.factor)
        if not run.pseudo_time:
            raise
        print(f"reed3d x = {run.opening * 1e3:.3g} mm, dP = {d:.4g} Pa: {exc}; pseudo-transient "
              f"continuation", file=sys.stderr)
    try:
        x, steps, run.factor = ns3d.ptc(run.system, rhs, guess, tol=SWEEP_TOL, factor=run.factor,
                                        progress=run.progress)
    except Exception:
        run.pseudo_time = False
        raise
    return x, steps


def _continue_to(run: _Continuation, dp: float) -> bool:
    """Reach ``dp`` [Pa] from the last converged point by natural-parameter continuation (Elman,
    Silvester and Wathen 2014, section 8.4 on continuation in the Reynolds number), with adaptive
    steps: each step goes at most to the Reynolds number ``run.ratio`` times the last (``_step_dp``),
    starts from the last solutions extrapolated (``_guess``) and is solved by ``_solve``; a
    quick solve (at most :data:`QUICK_STEPS` Newton or PTC steps) lets the next step grow, a failed one is retried with the step square-rooted (in
    log dP, at most :data:`MAX_HALVINGS` times in a row). Every converged point is kept (``run.out``,
    ``on_point``). Returns whether ``dp`` was reached."""
    halvings = 0
    while run.history[-1][0] < dp * (1 - 1e-9):
        d = _step_dp(run, dp)
        t1 = time.perf_counter()
        try:
            x, steps = _solve(run, d)
        except Exception as exc:   # noqa: BLE001 - a failed step is retried shorter or ends the sweep
            run.factor = getattr(exc, "factor", run.factor)
            print(f"reed3d x = {run.opening * 1e3:.3g} mm, dP = {d:.4g} Pa: {exc}", file=sys.stderr)
            if halvings >= MAX_HALVINGS:
                return False
            halvings += 1
            run.ratio = float(np.sqrt(run.ratio))
            continue
        halvings = 0
        if steps <= QUICK_STEPS:
            run.ratio = min(run.ratio * STEP_GROWTH, STEP_MAX)
        run.history.append((d, x))
        del run.history[:-2]                       # _guess needs the last two
        run.out.append(point_outputs(run.system, x, run.valve, run.opening, d, steps, time.perf_counter() - t1))
        if run.on_point is not None:
            run.on_point(run.out[-1])
        if run.progress:
            p = run.out[-1]
            print(f"  dP = {d:.4g} Pa: Re = {p.reynolds:.3g}, Cd = {p.cd:.4f}, X = {p.multiplier:.4f}, mesh Peclet "
                  f"{p.peclet_p95:.2g} (95 %), {p.peclet_max:.2g} (max) ({steps} steps, {p.seconds:.0f} s, "
                  f"{p.peak_rss_gb:.1f} GB)", file=sys.stderr)
    return True


@dataclass(frozen=True)
class DisplacementPoint:
    """A moving-wall solve at tip opening x [m], tip speed u [m/s] and dP = 0 (eqs 3.23, 3.26)."""

    opening: float
    speed: float
    flow: float             # Q through the port, toward downstream [m^3/s]
    area: float             # A_Q = Q / u [m^2]
    fraction: float         # f = (A_Q - A_1) / (A_2 - A_1)
    newton_steps: int
    seconds: float


def _reed_velocity(system: ns3d.System, valve: ReedValveFlow, speed: float) -> np.ndarray:
    """Dirichlet values on ``system.fixed``: the reed's faces at psi(s) u e_z, every other wall at rest."""
    vals = np.zeros(system.ndofs)
    n = system.nv
    reed = system.V.get_dofs(system.mesh.boundaries["reed"]).all()
    vals[2 * n + reed] = speed * valve.psi(system.V.doflocs[0, reed])
    return vals[system.fixed]


def displacement_sweep(valve: ReedValveFlow, opening: float, speeds, progress: bool = True) -> list[DisplacementPoint]:
    """Fluid displacement area A_Q at tip opening ``opening`` [m] for tip speeds ``speeds`` [m/s] (either sign).

    The reed's faces move at psi(s) u e_z in the frozen geometry (quasi-steady), inlet and
    outlet at one pressure: the port flow Q gives A_Q = Q / u (eq 3.23). Stokes for u -> 0
    (first entry, speed 0 meaning the limit, per unit speed), then Navier-Stokes by Newton
    from the scaled Stokes field at each speed (the two signs differ through inertia only).
    """
    t0 = time.perf_counter()
    system, x1 = _moving_wall_stokes(valve, opening, 1.0)
    zero = np.zeros(system.ndofs)
    out = [_displacement(system, x1, valve, opening, 0.0, 0, time.perf_counter() - t0)]
    factor = None
    for u in speeds:
        t1 = time.perf_counter()
        try:
            x, steps, factor = ns3d.newton(system, zero, u * x1, factor=factor, progress=progress)
        except Exception as exc:   # noqa: BLE001 - reported, the sweep goes on
            print(f"reed3d x = {opening * 1e3:.3g} mm, u = {u:g} m/s: {exc}", file=sys.stderr)
            continue
        out.append(_displacement(system, x, valve, opening, u, steps, time.perf_counter() - t1))
    if factor is not None:
        factor.free()
    if progress:
        print("reed3d x = {:.3g} mm: ".format(opening * 1e3) + ", ".join(
            f"u = {p.speed:g} m/s: f = {p.fraction:.3f}" for p in out), file=sys.stderr)
    return out


def squeeze_coefficient(valve: ReedValveFlow, opening: float) -> float:
    """The squeeze ("stiction") coefficient of eq 3.51 at tip opening ``opening`` [m] from a 3-D Stokes solve [Pa s/m].

    c = -F / (u int_0^L psi W ds): F [N] the psi-weighted generalised force of the full stress on the reed
    (:func:`reed_forces`, both halves) when its faces move at a tip speed u in the frozen geometry, inlet and
    outlet at one pressure (the Stokes limit u -> 0, so c does not depend on u). The wall moves at
    (1 - floor_fraction) psi(s) u, the rate at which the gap family of :func:`fea.fluid.reed_mesh.gap_profile`
    opens, as the sealing film's squeeze solve has it (:func:`fea.fluid.reed_film.reed_film`), so the two are
    the same quantity where both hold (gap / land width << 1). Compare c = 1727 Pa s/m of eq 3.81.
    """
    system, x = _moving_wall_stokes(valve, opening, 1.0 - valve.seat.floor_fraction)
    return -reed_forces(system, x, valve)[0] / valve.modal_area


def _moving_wall_stokes(valve: ReedValveFlow, opening: float, speed: float) -> tuple[ns3d.System, np.ndarray]:
    """(system, Stokes state) at tip opening ``opening`` [m] with the reed's faces moving at psi(s) ``speed``
    [m/s], inlet and outlet at one pressure."""
    fm = fluid_mesh(valve.reed, valve.seat, opening, valve.shape, valve.mesh)
    system = flow_system(valve, fm.mesh)
    return system, ns3d.stokes(system, np.zeros(system.ndofs), _reed_velocity(system, valve, speed))


def _displacement(system, x, valve: ReedValveFlow, opening: float, speed: float, steps: int,
                  seconds: float) -> DisplacementPoint:
    Q = -2.0 * ns3d.boundary_flux(system, x, "inlet")
    area = Q / (speed if speed != 0.0 else 1.0)
    return DisplacementPoint(opening=opening, speed=speed, flow=Q, area=area,
                             fraction=(area - valve.area_min) / (valve.area_max - valve.area_min),
                             newton_steps=steps, seconds=seconds)


# ------------------------------------------------------------------------------ set-up
def orifice_definitions(reed: Reed, seat: ReedSeat, shape) -> tuple[float, float, float, float]:
    """(l_o [m], p_o [m], A_1 [m^2], A_2 [m^2]) of a reed over the reconstructed port (eqs 3.24-3.29, 3.86).

    C is the port's outline (its sides and tip, the edge where the sealing land begins; the
    edge across at the port's start is in the base and does not open): l_o = int_C psi ds',
    p_o = 2 int_C ds' (the orifice area's perimeter on the seat and on the reed), A_1 =
    int W_o psi ds with W_o the port's width, A_2 = int W psi ds (eq 3.29).
    """
    s_psi, psi = (np.asarray(a, float) for a in shape)
    a, end = seat.start(reed), reed.length - seat.land_width
    s = np.linspace(a, end, 4001)
    yp = np.asarray(seat.port_half_width(reed, s), dtype=float)
    ps = np.interp(s, s_psi, psi)
    ds, dy = np.diff(s), np.diff(yp)
    dl = np.hypot(ds, dy)
    mid = 0.5 * (ps[1:] + ps[:-1])
    l_o = 2.0 * float(np.sum(mid * dl))
    p_o = 2.0 * 2.0 * float(np.sum(dl))
    A1 = float(np.trapezoid(2 * yp * ps, s))
    S, _, w = face_rule(reed)
    A2 = float(np.sum(w * np.interp(S, s_psi, psi)))
    return l_o, p_o, A1, A2


def valve_flow(reed: Reed, seat: ReedSeat | None = None, fidelity: str = "analytic", fluid: ns3d.Fluid | None = None,
               definitions: tuple[float, float, float, float] | None = None,
               mesh: MeshOptions | None = None, stiffness: float | None = None) -> ReedValveFlow:
    """A :class:`ReedValveFlow` for ``reed``: its static shape from the reed ``fidelity``
    (:mod:`fea.fidelities`), the thesis oil at 22 C unless ``fluid``, and the orifice
    definitions (l_o, p_o, A_1, A_2) given or computed over the port (:func:`orifice_definitions`);
    kappa [Pa/m] given or the fidelity's."""
    from lumped.fluid.oil import thesis_oil_viscosity

    from ..fidelities import get

    seat = ReedSeat() if seat is None else seat
    seat.check(reed)
    props = get(fidelity).reed_properties(reed)
    shape = (np.asarray(props.s, float), np.asarray(props.psi, float) / float(np.interp(reed.length, props.s, props.psi)))
    if fluid is None:
        rho, mu = thesis_oil_viscosity()
        fluid = ns3d.Fluid(rho, mu)
    defs = orifice_definitions(reed, seat, shape) if definitions is None else definitions
    return ReedValveFlow(reed=reed, seat=seat, shape=shape, fluid=fluid, orifice_length=defs[0],
                         orifice_perimeter=defs[1], area_min=defs[2], area_max=defs[3],
                         stiffness=float(props.kappa if stiffness is None else stiffness),
                         mesh=MeshOptions() if mesh is None else mesh)


def prototype_valve(mesh: MeshOptions | None = None) -> ReedValveFlow:
    """The thesis's prototype reed valve with the definitions its bench data were reduced with:
    l_o = 19.4 mm, p_o = 91.2 mm, A_1 = 55.1 mm^2, A_2 = 338.4 mm^2 and the oil of the
    ``thesis-reed`` model (Table 3.13; A_2 as the model uses it, docs/errata.md), and its
    measured kappa = 7.709 MPa/m."""
    from geometry.reed_io import load_reed
    from lumped.model.model_file import load_model

    model = load_model("thesis-reed")
    v = model.inlet
    fluid = ns3d.Fluid(model.oil.density, model.oil.viscosity)
    return valve_flow(load_reed("prototype"), fluid=fluid, mesh=mesh, stiffness=v.stiffness,
                      definitions=(v.orifice_length, v.orifice_perimeter, v.area_min, v.area_max))


# ------------------------------------------------------------------------------ mesh study
#: tip speed of the ``3d`` point's moving-wall solves [m/s] (as the compact forms')
DISPLACEMENT_SPEED = 0.1
#: the three meshes of the GCI (plan sizes and layers refined together; the medium one is the default)
STUDY_MESHES = (
    MeshOptions(1.0e-3, 3.5e-3, Layers(port=1, gap=2, reed=1, above=1)),
    MeshOptions(),
    MeshOptions(0.5e-3, 1.8e-3, Layers(port=2, gap=3, reed=1, above=3)),
)
#: outputs a mesh study estimates u_num for
STUDY_OUTPUTS = ("cd", "multiplier", "force")


def mesh_study(valve: ReedValveFlow, opening: float, dps, meshes=STUDY_MESHES, progress: bool = True) -> dict:
    """u_num of Cd, X and F at tip opening ``opening`` [m] and pressure differences ``dps`` [Pa]
    by the GCI of three meshes (:func:`fea.convergence.gci`, Celik et al. 2008; h = N^(-1/3)
    from the cell counts). Returns {dp: {output: GCI}} with the Stokes limit under dP = 1 Pa,
    and the meshes' DOFs, cells, seconds and peak memory."""
    from ..convergence import gci

    runs, cells = [], []
    for opts in meshes:
        v = replace(valve, mesh=opts)
        pts = pressure_sweep(v, opening, dps=dps, progress=progress)
        runs.append({p.dp: p for p in pts})
        cells.append(fluid_mesh(v.reed, v.seat, opening, v.shape, opts).cells)
    out: dict = {"cells": cells, "dofs": [next(iter(r.values())).dofs for r in runs],
                 "seconds": [sum(p.seconds for p in r.values()) for r in runs],
                 "peak_rss_gb": [max(p.peak_rss_gb for p in r.values()) for r in runs]}
    for dp in runs[0]:
        if all(dp in r for r in runs):
            vals = {k: [getattr(r[dp], k) for r in runs[::-1]] for k in STUDY_OUTPUTS}   # fine to coarse
            out[dp] = {k: gci(v, cells=cells[::-1], dim=3) for k, v in vals.items()}
    return out


#: options of the ``3d`` fidelity's point (``valvelab flow`` flags)
POINT_OPTIONS = ("squeeze", "displacement", "gci", "progress", "keep_solution")
#: the Reynolds number a point reaches may differ from the aim by this fraction (the sweep aims
#: by extrapolating Re(dP) from the previous points; the reached value is the point's)
REYNOLDS_SLACK = 0.15


def point_flow(valve) -> ReedValveFlow:
    """The :class:`ReedValveFlow` of a :class:`fea.fluid.point.FluidValve` of the reed kind: the reed
    its model names for the fluid references (``fluid_reed``), the model's oil, l_o, p_o, A_1, A_2, kappa.
    InputError naming the valve's ``geometry`` when the model names no reed."""
    v = valve.params
    reed = v.fluid_reed(f"valves.{valve.position}")
    return valve_flow(reed, fluid=ns3d.Fluid(valve.density, valve.viscosity), stiffness=v.stiffness,
                      definitions=(v.orifice_length, v.orifice_perimeter, v.area_min, v.area_max))


def check_point_options(options) -> dict:
    """The options the ``3d`` point takes; InputError naming the flag of one it does not."""
    from geometry.errors import InputError

    opts = dict(options or {})
    for key, val in opts.items():
        if key not in POINT_OPTIONS and val not in (None, False):
            flag = "--" + key.replace("_", "-")
            raise InputError(flag, "the 3d fidelity's mesh is fixed (the default of its mesh study; --gci runs "
                             "the study's three meshes)" if key in ("resolution", "divisions") else
                             "not an option of the 3d fidelity")
    return opts
