"""The reed's 3-D flow at a prescribed flow rate: continuation in the Reynolds number through folds in dP.

With the pressure difference prescribed (:func:`fea.fluid.reed3d.pressure_sweep`) the Reynolds
number is an output and natural continuation in dP stops where the branch Re(dP) turns back
(a fold: the Jacobian at fixed dP is singular there). Here the flow rate is prescribed instead
and the inlet pressure is the unknown that enforces it: the momentum and continuity equations
with the traction -P n on the inlet, plus the flux constraint int_inlet u . n dA = -Q / 2 (half
domain), a Lagrange-multiplier ("defective") flow-rate condition that keeps the inlet's
do-nothing form, so every solution is one of the pressure-driven problem's (Heywood, Rannacher
and Turek 1996; Formaggia, Gerbeau, Nobile and Quarteroni 2002). The bordered Jacobian

    [[J, -g], [-g^T, 0]] [dx; dP] = -[R(x) - P g; -g . x - q],   g = -int_inlet n . v dA,

is regular at a fold in dP (where J alone is singular) as long as the flux varies along the
null vector, so Newton continued in Re passes it and dP(Re) shows whether the branch folds:
a maximum of dP(Re) is a fold of the dP-driven problem (Keller 1977's turning point, here
parametrised by the flow instead of the arclength).

SI units. References: J. G. Heywood, R. Rannacher and S. Turek (1996), Artificial boundaries
and flux and pressure conditions for the incompressible Navier-Stokes equations, Int. J.
Numer. Methods Fluids 22, 325-352; L. Formaggia, J.-F. Gerbeau, F. Nobile and A. Quarteroni
(2002), Numerical treatment of defective boundary conditions for the Navier-Stokes equations,
SIAM J. Numer. Anal. 40, 376-401; H. B. Keller (1977), Numerical solution of bifurcation and
nonlinear eigenvalue problems, in Applications of Bifurcation Theory, Academic Press, 359-384.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from lumped.reed.fluid import orifice_reynolds

from . import ns3d, reed3d
from .reed3d import FlowPoint, ReedValveFlow, point_outputs
from .reed_mesh import fluid_mesh


@dataclass
class FluxProblem:
    """One mesh's system with the inlet's unit traction load ``g`` (:func:`fea.fluid.ns3d.traction_load`
    at P = 1 Pa) and its free DOFs; the flux out through the inlet is -g . x."""

    system: ns3d.System
    g: np.ndarray
    free: np.ndarray

    @classmethod
    def build(cls, system: ns3d.System) -> "FluxProblem":
        g = ns3d.traction_load(system, {"inlet": 1.0})
        return cls(system=system, g=g, free=ns3d._free_dofs(system.ndofs, system.fixed))

    def residual(self, x: np.ndarray, P: float, flux: float) -> tuple[np.ndarray, float]:
        """(momentum/continuity residual on the free DOFs [N], flux residual [m^3/s]) at inlet pressure P [Pa]
        for the half domain's prescribed outflux ``flux`` [m^3/s] through the inlet (negative: inflow)."""
        R = ns3d.residual(self.system, x, P * self.g)[self.free]
        return R, float(-self.g @ x - flux)


#: damped Newton steps in a row after which a flow-rate solve is abandoned (a shorter step in Re is cheaper)
MAX_DAMPED = 2


def _weighted_norm(R: np.ndarray, c: float, weight: float) -> float:
    return float(np.hypot(np.linalg.norm(R), weight * c))


def flux_newton(prob: FluxProblem, flux: float, x0: np.ndarray, P0: float, tol: float = 1e-6,
                max_iter: int = 10, factor: ns3d.Factor | None = None,
                progress: bool = False) -> tuple[np.ndarray, float, int, ns3d.Factor]:
    """Steady Navier-Stokes with the inlet's flux prescribed (module docstring): Newton on (x, P) from (x0, P0).

    ``flux`` [m^3/s]: int_inlet u . n dA of the half domain (negative: into the domain). The bordered
    corrections are solved as :func:`fea.fluid.ns3d.newton`'s (GMRES preconditioned by the last
    factorization, else a new LU), damped by backtracking on the residual norm with the flux residual
    weighted to the momentum's scale (|g| P / |flux|). Stops when the largest velocity update is below
    ``tol`` of the largest velocity after a full step. Returns (state, P [Pa], steps, factorization);
    ModelFailure (``.factor`` set) after ``max_iter`` steps or :data:`MAX_DAMPED` damped steps in a row.
    """
    sys_, free, g = prob.system, prob.free, prob.g
    n3 = 3 * sys_.nv
    gf = g[free]
    vel = np.flatnonzero(free < n3)
    weight = np.linalg.norm(gf) * abs(P0) / abs(flux)
    x, P, damped, kry, change = x0.copy(), float(P0), 0, 0, np.inf
    R, c = prob.residual(x, P, flux)
    for it in range(1, max_iter + 1):
        t0 = time.perf_counter()
        Jb = bordered_jacobian(prob, x)
        factor = ns3d._refresh(factor, kry)
        d, factor, kry = ns3d._newton_step(Jb, np.append(R, c), factor)
        r0 = _weighted_norm(R, c, weight)
        for step in (1.0, 0.5, 0.25, 0.125):
            xt = x.copy()
            xt[free] += step * d[:-1]
            Pt = P + step * d[-1]
            R, c = prob.residual(xt, Pt, flux)        # the accepted trial's is the next step's residual
            if _weighted_norm(R, c, weight) <= (1 - 1e-4 * step) * r0:
                break
        x, P = xt, Pt
        change = step * np.max(np.abs(d[:-1][vel])) / max(np.max(np.abs(x[:n3])), 1e-300)
        if progress:
            print(f"  flux newton {it}: |du|/|u| = {change:.2e}, dP = {P:.6g} Pa, step {step:g}, {kry} GMRES "
                  f"steps ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
        if change < tol and step == 1.0:
            return ns3d.fill_orphans(sys_, x), P, it, factor
        damped = damped + 1 if step < 1.0 else 0
        if damped >= MAX_DAMPED:
            raise ns3d._failure(f"flow-rate Newton: {damped} damped steps in a row (last update {change:.2e})", factor)
    raise ns3d._failure(f"flow-rate Newton did not converge in {max_iter} steps (last update {change:.2e})", factor)


def flux_ptc(prob: FluxProblem, flux: float, x0: np.ndarray, P0: float, tol: float = 1e-6,
             max_iter: int = 60, progress: bool = False) -> tuple[np.ndarray, float, int, ns3d.Factor]:
    """Steady flow at the prescribed flux by pseudo-transient continuation from (x0, P0): which steady
    flow the time-dependent one settles to (where two exist, the stable one the start leads to).

    Backward-Euler steps in pseudo-time of the bordered system (:func:`flux_newton`'s),
    (M_b / dt + J_b) d = -R_b, M_b the velocity mass (zero on the pressures and on P), the flux met at
    every step; dt by switched evolution relaxation from :data:`fea.fluid.ns3d.PTC_CFL0` as
    :func:`fea.fluid.ns3d.ptc` (Kelley and Keyes 1998), with a new factorization when dt changed by more
    than :data:`fea.fluid.ns3d.PTC_REFACTOR`. Converged: largest velocity update below ``tol`` of the
    largest velocity with dt at least :data:`fea.fluid.ns3d.PTC_STEADY` dt_0. Returns (state, P [Pa],
    steps, factorization); ModelFailure as :func:`fea.fluid.ns3d.ptc`'s (diverged, no progress, too many steps).
    """
    sys_, free, n3 = prob.system, prob.free, 3 * prob.system.nv
    _, vel, M, dt0 = ns3d._ptc_start(sys_, x0 if np.any(x0[:n3]) else _stokes_scale(prob, flux))
    Mb = _bordered_mass(M)
    x, P, dt, dt_f, factor, kry, since = x0.copy(), float(P0), dt0, np.inf, None, 0, 0
    weight = np.linalg.norm(prob.g[free]) * max(abs(P0), 1.0) / abs(flux)
    r0 = None             # the residual after the first step (the flux met) is the scale: from rest only c is not 0
    R, c = prob.residual(x, P, flux)
    for it in range(1, max_iter + 1):
        factor = ns3d._ptc_current(factor, dt, dt_f, dt0)
        old = ns3d._refresh(factor, kry)
        d, factor, kry = ns3d._newton_step((bordered_jacobian(prob, x) + Mb / dt).tocsr(), np.append(R, c), old)
        dt_f = dt if factor is not old else dt_f
        x[free] += d[:-1]
        P += d[-1]
        change = float(np.max(np.abs(d[:-1][vel])) / max(np.max(np.abs(x[:n3])), 1e-300))
        R, c = prob.residual(x, P, flux)
        r_new = _weighted_norm(R, c, weight)
        if r0 is None:
            r = r0 = best = r_new
        if progress:
            print(f"  flux ptc {it}: |R|/|R0| = {r_new / r0:.2e}, |du|/|u| = {change:.2e}, dP = {P:.6g} Pa, "
                  f"dt = {dt:.2e} s, {kry} GMRES steps", file=sys.stderr)
        if change < tol and dt >= ns3d.PTC_STEADY * dt0:
            return ns3d.fill_orphans(sys_, x), P, it, factor
        best, since = ns3d._ptc_progress(r_new, r0, best, since, factor)
        dt = ns3d._ptc_next_dt(dt, r, r_new)
        r = r_new
    raise ns3d._failure(f"flow-rate PTC did not converge in {max_iter} steps", factor)


def _stokes_scale(prob: FluxProblem, flux: float) -> np.ndarray:
    """A state whose largest velocity is the mean inlet speed at ``flux`` (sets dt_0 for a start from rest):
    the inlet's area is sum |g_i| (the P2 functions' integrals over a face are those of a partition of unity,
    the vertex ones zero)."""
    x = np.zeros(prob.system.ndofs)
    area = float(np.sum(np.abs(prob.g))) or 1.0
    x[0] = abs(flux) / area
    return x


#: continuation in Re: the first step's ratio Re_(k+1) / Re_k, its growth after a solve of at most
#: QUICK Newton steps, its largest value; a failed step's ratio is square-rooted (MAX_CUTS times in a row)
RATIO_START, RATIO_GROWTH, RATIO_MAX, QUICK, MAX_CUTS = 1.3, 1.2, 1.6, 4, 4
#: a sweep ends when a failed step's ratio square-rooted falls below this (steps of a few per cent in Re
#: that fail in turn: the branch is near a singular point, measured on the prototype, docs/fluid.md)
RATIO_MIN = 1.05


def _flux_of(valve: ReedValveFlow, reynolds: float) -> float:
    """The half domain's inlet outflux [m^3/s] at Reynolds number ``reynolds``: eq 3.87
    (:func:`lumped.reed.fluid.orifice_reynolds`, linear in Q) inverted, half the flow, into the domain."""
    per_flow = float(orifice_reynolds(1.0, valve.fluid.rho, valve.orifice_perimeter, valve.fluid.mu))
    return -0.5 * reynolds / per_flow


def _predict(history: list, re: float) -> tuple[np.ndarray, float]:
    """(state, P) at ``re`` extrapolated linearly in Re from the last two converged (Re, x, P) (the first
    by scaling in proportion: the Stokes limit)."""
    r1, x1, P1 = history[-1]
    if len(history) < 2:
        return x1 * (re / r1), P1 * (re / r1)
    r0, x0, P0 = history[-2]
    t = (re - r1) / (r1 - r0)
    return x1 + t * (x1 - x0), P1 + t * (P1 - P0)


def _capped(history: list, re: float, dp_max: float | None) -> float:
    """``re``, or less: the Reynolds number expected at ``dp_max`` [Pa] (Re ~ dP^a, a the last two points'
    log slope, 1 from the Stokes limit) when ``re`` is expected beyond it."""
    if dp_max is None:
        return re
    r1, _, P1 = history[-1]
    a = 1.0
    if len(history) > 1 and history[-2][2] != P1:
        r0, _, P0 = history[-2]
        a = float(np.clip(np.log(r1 / r0) / np.log(P1 / P0), 0.3, 1.0))
    return min(re, r1 * (dp_max / P1) ** a)


def flow_sweep(valve: ReedValveFlow, opening: float, reynolds, progress: bool = True, on_point=None,
               max_cuts: int = MAX_CUTS, dp_max: float | None = None, on_state=None) -> list[FlowPoint]:
    """Steady flows at tip opening ``opening`` [m] at the Reynolds numbers ``reynolds`` (eq 3.87) with the flow
    rate prescribed (module docstring): the Stokes limit, then Newton (:func:`flux_newton`) continued in Re
    from the last two solutions with adaptive steps (ratio :data:`RATIO_START` growing to :data:`RATIO_MAX`,
    the failed step's square-rooted after a failure, the sweep ended below :data:`RATIO_MIN`). Every
    converged point is returned (the intermediate ones included; ``on_point(point)`` after each) with its
    dP an output; stops where a step fails ``max_cuts`` times
    in a row (the reason on stderr), or at ``dp_max`` [Pa] (the aim lowered to the Re expected there,
    ``_capped``; the sweep ends at the first point within :data:`fea.fluid.reed3d.CAP_NEAR` of it, as
    :func:`fea.fluid.reed3d.pressure_sweep`). ``on_state(problem, x, P, point)`` after each Navier-Stokes
    point, with its state (e.g. for :func:`spectrum`)."""
    t0 = time.perf_counter()
    prob = flux_problem(valve, opening)
    xs = ns3d.stokes(prob.system, prob.g, np.zeros(len(prob.system.fixed)))
    stokes = point_outputs(prob.system, xs, valve, opening, 1.0, 0, time.perf_counter() - t0)
    out = [stokes]
    if on_point is not None:
        on_point(stokes)
    if progress:
        print(f"reed_flux x = {opening * 1e3:.3g} mm: {prob.system.ndofs} DOFs, Stokes in {stokes.seconds:.0f} s",
              file=sys.stderr)
    history = [(stokes.reynolds, xs, 1.0)]
    factor, ratio, cuts = None, RATIO_START, 0
    for aim in sorted(float(r) for r in reynolds):
        while history[-1][0] < aim * (1 - 1e-9):
            if dp_max is not None and history[-1][2] >= reed3d.CAP_NEAR * dp_max:
                _free(factor)
                return out
            aim = _capped(history, aim, dp_max)
            re = min(aim, history[-1][0] * ratio) if len(history) > 1 else aim
            re = aim if re * 1.15 >= aim and not cuts else re      # no sliver left (but not after a failure)
            t1 = time.perf_counter()
            try:
                x, P = _predict(history, re)
                x, P, steps, factor = flux_newton(prob, _flux_of(valve, re), x, P, factor=factor, progress=progress)
            except Exception as exc:   # noqa: BLE001 - a failed step is retried shorter or ends the sweep
                _free(getattr(exc, "factor", factor))    # of a state off the branch: a misleading preconditioner
                factor = None
                print(f"reed_flux x = {opening * 1e3:.3g} mm, Re = {re:.4g}: {exc}", file=sys.stderr)
                cuts += 1
                ratio = float(np.sqrt(re / history[-1][0]))        # the failed step's ratio, square-rooted
                if cuts > max_cuts or len(history) < 2 or ratio < RATIO_MIN:
                    _free(factor)
                    return out
                continue
            cuts = 0
            ratio = min(ratio * RATIO_GROWTH, RATIO_MAX) if steps <= QUICK else ratio
            history = history[-1:] + [(re, x, P)]
            p = point_outputs(prob.system, x, valve, opening, P, steps, time.perf_counter() - t1)
            out.append(p)
            if on_point is not None:
                on_point(p)
            if on_state is not None:
                on_state(prob, x, P, p)
            _say_point(progress, p)
    _free(factor)
    return out


def flux_problem(valve: ReedValveFlow, opening: float) -> FluxProblem:
    """The flow-rate problem of the reed's fluid mesh at tip opening ``opening`` [m] (:func:`fea.fluid.reed3d.flow_system`)."""
    return FluxProblem.build(reed3d.flow_system(valve, fluid_mesh(valve.reed, valve.seat, opening, valve.shape,
                                                                   valve.mesh).mesh))


def _say_point(progress: bool, p: FlowPoint) -> None:
    if progress:
        print(f"  Re = {p.reynolds:.4g}: dP = {p.dp:.5g} Pa, Cd = {p.cd:.4f}, X = {p.multiplier:.4f}, mesh Peclet "
              f"{p.peclet_p95:.2g} / {p.peclet_max:.2g} ({p.newton_steps} steps, {p.seconds:.0f} s, "
              f"{p.peak_rss_gb:.1f} GB)", file=sys.stderr)


def bordered_jacobian(prob: FluxProblem, x: np.ndarray) -> sp.csr_matrix:
    """The bordered Jacobian [[J, -g], [-g^T, 0]] of :func:`flux_newton` at state ``x`` (free DOFs and P)."""
    n3, free = 3 * prob.system.nv, prob.free
    J = ns3d._saddle(prob.system, ns3d._velocity_block(prob.system, x[:n3], True))[free][:, free]
    gf = prob.g[free]
    return sp.bmat([[J, -gf[:, None]], [-gf[None, :], None]], format="csr")


def spectrum(prob: FluxProblem, x: np.ndarray, k: int = 6) -> np.ndarray:
    """The ``k`` eigenvalues lambda [1/s] nearest zero of J_b v = lambda M_b v at the converged state ``x``.

    J_b the bordered Jacobian (:func:`bordered_jacobian`), M_b the fluid's velocity mass (rho, zero on
    the pressures and on P): the linearised flow at the prescribed flow rate, M_b dv/dt = -J_b v, evolves
    as exp(-lambda t). A real lambda through zero along a branch is a fold (the branch turns back in
    Re) or a steady bifurcation (a second branch), Re(lambda) < 0 an unstable steady flow, a complex
    pair crossing Re(lambda) = 0 a Hopf bifurcation (Keller 1977; Cliffe, Spence and Tavener 2000,
    Acta Numerica 9, 39-131). ARPACK shift-invert at sigma = 0 with one direct factorization of J_b.
    """
    import scipy.sparse.linalg as sla

    Jb = bordered_jacobian(prob, x)
    Mb = _bordered_mass(ns3d.velocity_mass(prob.system)[prob.free][:, prob.free])
    lu = ns3d.Factor(Jb)
    try:
        op = sla.LinearOperator(Jb.shape, matvec=lu.solve, dtype=float)
        vals = sla.eigs(Jb, k=k, M=Mb, sigma=0.0, OPinv=op, which="LM", return_eigenvectors=False,
                        ncv=max(4 * k, 24), tol=1e-8)
    finally:
        lu.free()
    return vals[np.argsort(np.abs(vals))]


def _bordered_mass(M: sp.csr_matrix) -> sp.csr_matrix:
    """The mass M_b of the bordered system: the velocity mass ``M`` on the free DOFs, zero on the inlet pressure P."""
    return sp.block_diag([M, sp.csr_matrix((1, 1))], format="csr")


def _free(factor) -> None:
    if factor is not None:
        factor.free()


# ------------------------------------------------------------------------------ the 3d fidelity's point
def reed_point(valve, lift: float, reynolds: float, options=None):
    """The ``3d`` fluid fidelity's point (:mod:`fea.fluid`): a reed valve (a
    :class:`fea.fluid.point.FluidValve` whose model names the reed's geometry, or ``flow.geometry``)
    at tip opening ``lift`` [m], aiming at ``reynolds`` (eq 3.87) from the Stokes limit on the default mesh.

    The flow rate is prescribed (:func:`fea.fluid.reed_flux.flow_sweep`, continued in Re from the
    Stokes limit) and dP is the output; ModelFailure when the continuation stops short of the aim
    (by more than :data:`fea.fluid.reed3d.REYNOLDS_SLACK`). Options:
    ``squeeze`` adds ``film`` (the sealing film at ``lift``: ``C1`` = X in the Poiseuille regime,
    ``F4``, ``C2`` = c_sq x^3 [Pa s m^2] and ``c_squeeze`` [Pa s/m], eq 3.21's units);
    ``displacement`` adds f1, f2 and A_Q at tip speeds -+:data:`fea.fluid.reed3d.DISPLACEMENT_SPEED`; ``gci`` runs the
    three meshes of :data:`fea.fluid.reed3d.STUDY_MESHES` at the point's dP and fills ``u_num`` (GCI32 / 1.15).
    """
    from geometry.errors import ModelFailure

    from ..convergence import GCI_STANDARD_FACTOR
    from .point import FlowPoint, check_lift, check_reynolds

    lift, reynolds = check_lift(valve, lift), check_reynolds(reynolds)
    opts = reed3d.check_point_options(options)
    flow = reed3d.point_flow(valve)
    progress = bool(opts.get("progress", True))
    t0 = time.process_time()
    pts = flow_sweep(flow, lift, (reynolds,), progress=progress)
    p = pts[-1]
    if len(pts) < 2 or abs(p.reynolds / reynolds - 1.0) > reed3d.REYNOLDS_SLACK:
        raise ModelFailure(f"3-D flow at x = {lift * 1e3:.4g} mm: the continuation did not reach Re = {reynolds:g} "
                           f"(last converged Re = {p.reynolds:.3g}); see the messages above")
    extra = {"multiplier_pressure": p.multiplier_pressure, "reynolds_aimed": reynolds,
             "mesh": {"dofs": int(p.dofs), "size": flow.mesh.size_min, "size_max": flow.mesh.size_max},
             "seconds": p.seconds, "peak_rss_gb": p.peak_rss_gb,
             "mesh_peclet": {"p95": p.peclet_p95, "max": p.peclet_max}}
    if opts.get("squeeze"):
        from .reed_film import reed_film

        film = reed_film(flow, lift)
        extra["film"] = {"C1": film.multiplier, "C2": film.squeeze_coefficient * lift**3, "F4": film.base_fraction,
                         "c_squeeze": film.squeeze_coefficient, "leakage": film.flow}
    if opts.get("displacement"):
        speed = reed3d.DISPLACEMENT_SPEED
        moving = reed3d.displacement_sweep(flow, lift, (-speed, speed), progress=progress)
        by = {m.speed: m for m in moving}
        close, open_ = by.get(-reed3d.DISPLACEMENT_SPEED), by.get(reed3d.DISPLACEMENT_SPEED)
        extra["displacement"] = {"f1": close.fraction if close else None, "f2": open_.fraction if open_ else None,
                                 "A_Q_closing": close.area if close else None,
                                 "A_Q_opening": open_.area if open_ else None}
    u_num = {}
    if opts.get("gci"):
        study = reed3d.mesh_study(flow, lift, (p.dp,), progress=progress)
        band = study.get(p.dp, {})
        u_num = {"cd" if k == "cd" else ("pressure_load_multiplier" if k == "multiplier" else k):
                 float(g.u_coarse / GCI_STANDARD_FACTOR) for k, g in band.items()}
        extra["mesh_study"] = {"dofs": study["dofs"], "seconds": study["seconds"], "peak_rss_gb": study["peak_rss_gb"]}
    extra["cpu_seconds"] = time.process_time() - t0
    return FlowPoint(lift=lift, reynolds=p.reynolds, flow=p.flow, dp=p.dp, cd=float(p.cd), force=p.force,
                     force_coefficient=p.force / (p.dp * flow.reed.face_area), pressure_load_multiplier=p.multiplier,
                     u_num=u_num, extra=extra)
