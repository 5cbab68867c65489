"""Mass-conservative single-cylinder piston pump (chapter 4) with disc or reed check valves.

Physics once, two integrators: :func:`evaluate` / :func:`rhs` are plain functions of
floats, the state vector and the flat parameter array of :func:`lumped.params.pack`
(no Python objects), so ``numba.njit`` can compile the very same source for a fast
path. This module's reference integrator, :func:`simulate`, drives them with scipy's
implicit ``solve_ivp`` and locates every switch of the right-hand side (valve on its
seat, on its stop, Poiseuille/orifice regime of eq 2.18) as an event: each valve's
contact state and pressure regime are fixed inside a segment (``mode``), so the
integrand is smooth there, and change only at the located crossing.

State (SI): cylinder oil mass m_cyl (eq 4.5), inlet x, u, delivery x, u, and the
cumulative masses through the inlet valve, delivery valve and piston clearance, which
make the mass balance checkable to round-off; the complete circuit adds the load-line
oil mass and the needle-valve outflow. Time 0 is top dead centre.
"""

from __future__ import annotations

import bisect
import csv
import math
import sys
import time as _time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from geometry.errors import InputError
from lumped import oil as oil_mod
from lumped.disc_valve import disc_acceleration, valve_flow
from lumped.params import (
    CIRCUITS, G_AIR, G_AP, G_BETA, G_CIRCUIT, G_CRANK, G_GAMMA, G_LEAK, G_MU, G_NACC, G_NVCDA,
    G_OMEGA, G_P0, G_PLOAD, G_PPRE, G_PTANK, G_PVAP, G_RHO0, G_ROD, G_VACC, G_VLINE, G_VTDC,
    KIND_REED, OFF_DEL, OFF_IN, V_KIND, V_POIS, V_RHOMODE, V_XSTOP, V_XTRANS, VALVES,
    PumpModel, pack, thesis_model, validate_model,
)
from lumped.reed_valve import reed_acceleration

# state indices
S_MCYL, S_XIN, S_UIN, S_XDEL, S_UDEL, S_MIN, S_MOUT, S_MLEAK, S_MLOAD, S_MNV = range(10)
N_SIMPLIFIED, N_COMPLETE = 8, 10
QUADRATURES = (S_MIN, S_MOUT, S_MLEAK, S_MNV)
# mode entries: [contact inlet, regime inlet, contact delivery, regime delivery]
SEAT, FREE, STOP = 0, 1, 2
POISEUILLE, ORIFICE = 0, 1
AUTO = -1


# ----------------------------------------------------------------- kinematics (section 4.3.1)
def piston_position(theta: float, crank: float, rod: float) -> float:
    """Piston displacement from TDC x_p [m] at crank angle theta [rad] (eq 4.1)."""
    s = math.sin(theta)
    return crank * (1.0 - math.cos(theta)) + rod - math.sqrt(rod * rod - crank * crank * s * s)


def cylinder_volume(theta: float, omega: float, area: float, crank: float, rod: float,
                    v_tdc: float) -> tuple[float, float]:
    """(V_cyl [m^3], dV_cyl/dt [m^3/s]) of the crank-slider at angle theta, speed omega (eq 4.2)."""
    s = math.sin(theta)
    c = math.cos(theta)
    root = math.sqrt(rod * rod - crank * crank * s * s)
    xp = crank * (1.0 - c) + rod - root
    vel = omega * (crank * s + crank * crank * s * c / root)
    return v_tdc + area * xp, area * vel


# ----------------------------------------------------------------- load line (complete circuit)
def load_mass(pl: float, p) -> tuple[float, float]:
    """(oil mass [kg], d mass/dP [kg/Pa]) in load line + accumulator at pressure pl (section 4.2.1).

    Oil volume = V_line + V_acc - V_gas, the nitrogen at V_gas = V_acc (P_pre/P)^(1/n)
    above its precharge (polytropic) and filling the accumulator below it.
    """
    rho0, p0, beta, gam, air = p[G_RHO0], p[G_P0], p[G_BETA], p[G_GAMMA], p[G_AIR]
    rho = oil_mod.density(pl, rho0, p0, beta, gam, air)
    drho = oil_mod.density_slope(pl, rho0, p0, beta, gam, air)
    vacc, ppre, n = p[G_VACC], p[G_PPRE], p[G_NACC]
    vol = p[G_VLINE]
    dvol = 0.0
    if pl > ppre:
        vgas = vacc * (ppre / pl) ** (1.0 / n)
        vol += vacc - vgas
        dvol = vgas / (n * pl)
    return rho * vol, drho * vol + rho * dvol


def load_pressure(m: float, p) -> float:
    """Load pressure [Pa] holding oil mass m in the load line and accumulator (inverse of load_mass).

    The mass is increasing in P, so Newton's method is kept inside a shrinking bracket
    (bisection when a step leaves it).
    """
    rho0, p0, beta, gam, air = p[G_RHO0], p[G_P0], p[G_BETA], p[G_GAMMA], p[G_AIR]
    vline, vacc, ppre, n = p[G_VLINE], p[G_VACC], p[G_PPRE], p[G_NACC]
    m_pre = load_mass(ppre, p)[0]
    if m <= m_pre:
        return oil_mod.pressure(m / vline, rho0, p0, beta, gam, air)
    # gas law with incompressible oil as the first guess
    vgas = vacc + vline - m / rho0
    guess = ppre * (vacc / vgas) ** n if vgas > 1e-3 * vacc else ppre * 1e3 ** n
    lo, hi = ppre, 1e12
    pl = guess if lo < guess < hi else 2.0 * ppre
    for _ in range(200):
        f, df = load_mass(pl, p)
        f -= m
        if f > 0.0:
            hi = pl
        else:
            lo = pl
        new = pl - f / df
        if not (lo < new < hi):
            new = 0.5 * (lo + hi)
        if abs(new - pl) <= 1e-13 * new + 4e-16 * beta:
            return new
        pl = new
    return pl


def needle_mass_flow(pl: float, p) -> float:
    """Mass flow through the needle valve to tank [kg/s]: Cd A sqrt(2 rho |dP|) sign(dP) (complete circuit)."""
    dp = pl - p[G_PTANK]
    rho = oil_mod.density(pl, p[G_RHO0], p[G_P0], p[G_BETA], p[G_GAMMA], p[G_AIR])
    q = p[G_NVCDA] * math.sqrt(2.0 * rho * abs(dp))
    return q if dp >= 0.0 else -q


# ----------------------------------------------------------------- right-hand side
def valve_acceleration(x: float, u: float, dp: float, p_down: float, rho: float, q_o: float,
                       cd: float, aq: float, dq_ddp: float, dq_dx: float, ddp_dt: float, p, o: int,
                       contact: int, regime: int) -> float:
    """du/dt of the valve at block offset o: disc (eq 2.3) or reed (eq 3.21)."""
    if p[o + V_KIND] == KIND_REED:
        return reed_acceleration(x, u, dp, rho, p, o, contact)
    return disc_acceleration(x, u, dp, p_down, p[G_PVAP], rho, p[G_MU], q_o, cd, aq, dq_ddp, dq_dx,
                             ddp_dt, p, o, contact, regime)


def evaluate(t: float, y, p, mode):
    """Everything the pump equations give at time t [s] (t = 0 at TDC) for state y.

    Returns (dm_cyl/dt, u_in, du_in/dt, u_del, du_del/dt, mdot_in, mdot_del, mdot_leak,
    dm_load/dt, mdot_needle, P_cyl, P_load, Q_o in, Q_o del, rho_cyl): the mass balance
    of eq 4.5 with the valve mass flows of eqs 4.3-4.4, cylinder pressure from eq 4.11
    inverted by Newton (eqs 4.12-4.16), and the valve dynamics of chapters 2 and 3.
    """
    omega = p[G_OMEGA]
    vol, dvol = cylinder_volume(omega * t, omega, p[G_AP], p[G_CRANK], p[G_ROD], p[G_VTDC])
    rho0, p0, beta, gam, air = p[G_RHO0], p[G_P0], p[G_BETA], p[G_GAMMA], p[G_AIR]
    mu = p[G_MU]
    m = y[S_MCYL]
    rho_cyl = m / vol
    pc = oil_mod.pressure(rho_cyl, rho0, p0, beta, gam, air)
    pt = p[G_PTANK]
    complete = p[G_CIRCUIT] > 0.5
    pl = load_pressure(y[S_MLOAD], p) if complete else p[G_PLOAD]
    x_in, u_in, x_del, u_del = y[S_XIN], y[S_UIN], y[S_XDEL], y[S_UDEL]
    # orifice density (section 4.3.5): cylinder, or the mean of both sides of the valve
    rho_in = rho_cyl
    if p[OFF_IN + V_RHOMODE] > 0.5:
        rho_in = 0.5 * (rho_cyl + oil_mod.density(pt, rho0, p0, beta, gam, air))
    rho_del = rho_cyl
    if p[OFF_DEL + V_RHOMODE] > 0.5:
        rho_del = 0.5 * (rho_cyl + oil_mod.density(pl, rho0, p0, beta, gam, air))
    dp_in = pt - pc
    dp_del = pc - pl
    qo_in, cd_in, aq_in, dqp_in, dqx_in = valve_flow(x_in, u_in, dp_in, rho_in, mu, p, OFF_IN, mode[0])
    qo_del, cd_del, aq_del, dqp_del, dqx_del = valve_flow(x_del, u_del, dp_del, rho_del, mu, p, OFF_DEL, mode[2])
    mdot_in = rho_in * (qo_in + aq_in * u_in)          # eq 4.3
    mdot_del = rho_del * (qo_del + aq_del * u_del)     # eq 4.4
    mdot_leak = rho_cyl * p[G_LEAK] * (pc - pt)        # laminar piston leakage (eq 4.5)
    dm = mdot_in - mdot_del - mdot_leak                # eq 4.5
    # pressure rates, needed by the transient flow force (eq 2.37)
    dpc = (dm - rho_cyl * dvol) / vol / oil_mod.density_slope(pc, rho0, p0, beta, gam, air)
    dml = 0.0
    mdot_nv = 0.0
    dpl = 0.0
    if complete:
        mdot_nv = needle_mass_flow(pl, p)
        dml = mdot_del - mdot_nv
        dpl = dml / load_mass(pl, p)[1]
    a_in = valve_acceleration(x_in, u_in, dp_in, pc, rho_in, qo_in, cd_in, aq_in, dqp_in, dqx_in,
                              -dpc, p, OFF_IN, mode[0], mode[1])
    a_del = valve_acceleration(x_del, u_del, dp_del, pl, rho_del, qo_del, cd_del, aq_del, dqp_del,
                               dqx_del, dpc - dpl, p, OFF_DEL, mode[2], mode[3])
    return (dm, u_in, a_in, u_del, a_del, mdot_in, mdot_del, mdot_leak, dml, mdot_nv,
            pc, pl, qo_in, qo_del, rho_cyl)


def rhs(t: float, y, p, mode) -> np.ndarray:
    """dy/dt of the pump state (8 entries simplified, 10 complete circuit)."""
    e = evaluate(t, y, p, mode)
    if p[G_CIRCUIT] > 0.5:
        return np.array([e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7], e[8], e[9]])
    return np.array([e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7]])


def _rhs_py(t, y, p, mode):
    """rhs for the reference integrator: the state as Python floats (faster in CPython)."""
    return rhs(t, y.tolist(), p, mode)


def _make_jac(n: int, scale: np.ndarray):
    """Forward-difference Jacobian over the dynamic states; the running totals (quadratures)
    feed back into nothing, so their columns are zero and cost no evaluations."""
    dyn = [i for i in range(n) if i not in QUADRATURES]
    eps = math.sqrt(np.finfo(float).eps)

    def jac(t, y, p, mode):
        f0 = rhs(t, y.tolist(), p, mode)
        jm = np.zeros((n, n))
        for j in dyn:
            h = eps * max(abs(y[j]), scale[j])
            yy = y.tolist()
            yy[j] += h
            h = yy[j] - y[j]                      # the step actually taken
            jm[:, j] = (rhs(t, yy, p, mode) - f0) / h
        return jm
    return jac


def auto_mode(y, p) -> list:
    """Contact state and pressure regime of both valves decided from the state (mode -1 resolved)."""
    out = []
    for o, xi in ((OFF_IN, S_XIN), (OFF_DEL, S_XDEL)):
        x = y[xi]
        c = SEAT if x <= 0.0 else (STOP if x > p[o + V_XSTOP] else FREE)
        r = ORIFICE
        if p[o + V_KIND] != KIND_REED and p[o + V_POIS] > 0.5 and x < p[o + V_XTRANS]:
            r = POISEUILLE
        out += [c, r]
    return out


# ----------------------------------------------------------------- results
@dataclass(frozen=True)
class PumpTrace:
    """Time series of the last revolution(s), t = 0 at top dead centre (SI units)."""

    time: np.ndarray              # [s]
    crank_angle: np.ndarray       # [rad], 0 at TDC
    cylinder_pressure: np.ndarray # [Pa]
    load_pressure: np.ndarray     # [Pa]
    inlet_position: np.ndarray    # [m]
    delivery_position: np.ndarray # [m]
    inlet_mass_flow: np.ndarray   # [kg/s] into the cylinder
    delivery_mass_flow: np.ndarray  # [kg/s] out of the cylinder
    inlet_velocity: np.ndarray    # [m/s]
    delivery_velocity: np.ndarray # [m/s]


@dataclass(frozen=True)
class PumpResult:
    """Outcome of :func:`simulate`. Pairs are (inlet, delivery); angles in rad from TDC."""

    valve: str
    circuit: str
    speed_rpm: float
    load_pressure: float          # requested (mean) load pressure [Pa]
    air_content: float            # R used by eq 4.11
    delivery_per_rev: float       # [m^3/rev] at atmospheric density (eq 4.17), last revolution
    deliveries: tuple             # delivery of every revolution [m^3]
    revolutions: int              # revolutions simulated
    cyclic_steady: bool           # cycle-to-cycle change below the tolerance
    cycle_change: float           # that change (relative, delivery and state at TDC)
    cpu_seconds: float
    simulated_seconds: float
    mass_balance_error: float     # |dm_cyl - (m_in - m_out - m_leak)| / m_in over the last revolution
    peak_opening: tuple           # [m]
    opening_angle: tuple          # crank angle where the main opening starts (None: never opens)
    closing_angle: tuple          # crank angle where it ends
    stop_contacts: tuple          # number of stop impacts in the last revolution
    mean_load_pressure: float     # over the last revolution [Pa]
    leakage_per_rev: float        # piston leakage of the last revolution [m^3 at atmospheric density]
    needle_area: float | None     # complete circuit [m^2]
    rhs_evaluations: int
    events: int                   # located switches (seat, stop, regime) in all revolutions
    method: str
    rtol: float
    atol: float
    trace: PumpTrace | None = None

    @property
    def cpu_per_simulated_second(self) -> float:
        """CPU seconds per simulated second of pumping (thesis section 5.6: 23 s)."""
        return self.cpu_seconds / self.simulated_seconds


# ----------------------------------------------------------------- integrator
def _event(index: int, level: float, direction: int):
    def g(t, y, *args):
        return y[index] - level
    g.terminal = True
    g.direction = direction
    return g


#: hysteresis of the reverse crossings [m]: a mode entered exactly on its switching surface
#: must not switch back at its first step (a zero-length segment); 0.1 nm is far below
#: any opening the model resolves
HYSTERESIS = 1e-10


def _events_for(mode: list, p) -> list:
    """Terminal events leaving the current mode: (function, mode slot, old, new, level).

    Seat -> free at x = 0, free -> seat at x = -HYSTERESIS; free -> stop at x_stop,
    stop -> free at x_stop - HYSTERESIS; the same for the Poiseuille/orifice transition.
    """
    out = []
    h = HYSTERESIS
    for v, (o, xi) in enumerate(((OFF_IN, S_XIN), (OFF_DEL, S_XDEL))):
        c, r = mode[2 * v], mode[2 * v + 1]
        xstop = p[o + V_XSTOP]
        if c == SEAT:
            out.append((_event(xi, 0.0, 1), 2 * v, SEAT, FREE, 0.0))
        elif c == FREE:
            out.append((_event(xi, -h, -1), 2 * v, FREE, SEAT, -h))
            out.append((_event(xi, xstop, 1), 2 * v, FREE, STOP, xstop))
        else:
            out.append((_event(xi, xstop - h, -1), 2 * v, STOP, FREE, xstop - h))
        if p[o + V_KIND] != KIND_REED and p[o + V_POIS] > 0.5:
            xt = p[o + V_XTRANS]
            if r == POISEUILLE:
                out.append((_event(xi, xt, 1), 2 * v + 1, POISEUILLE, ORIFICE, xt))
            else:
                out.append((_event(xi, xt - h, -1), 2 * v + 1, ORIFICE, POISEUILLE, xt - h))
    return out


def _atol_vector(n: int, atol: float, p, model: PumpModel) -> np.ndarray:
    """Absolute tolerances: atol times a characteristic scale of each state."""
    m_rev = model.oil.density_atm * model.pump.displacement      # mass pumped per revolution
    sc = np.empty(n)
    sc[S_MCYL] = m_rev
    sc[S_XIN] = p[OFF_IN + V_XSTOP]
    sc[S_XDEL] = p[OFF_DEL + V_XSTOP]
    sc[S_UIN] = sc[S_UDEL] = 1.0                                  # m/s
    sc[S_MIN] = sc[S_MOUT] = sc[S_MLEAK] = m_rev
    if n == N_COMPLETE:
        sc[S_MLOAD] = sc[S_MNV] = m_rev
    return atol * sc


class _Segment:
    __slots__ = ("t0", "t1", "sol", "mode")

    def __init__(self, t0, t1, sol, mode):
        self.t0, self.t1, self.sol, self.mode = t0, t1, sol, mode


def _initial_state(model: PumpModel, p, n: int) -> np.ndarray:
    """At TDC: cylinder full at load pressure, both valves at rest on their seats."""
    y = np.zeros(n)
    pl = p[G_PLOAD]
    y[S_MCYL] = model.oil.density(pl) * model.pump.dead_volume
    if n == N_COMPLETE:
        y[S_MLOAD] = load_mass(pl, p)[0]
    return y


def _check_inputs(valve, speed_rpm, load_pressure, air_content, revolutions, circuit, rtol, atol,
                  max_revolutions, trace_revolutions, method):
    if valve not in VALVES:
        raise InputError("valve", f"expected disc or reed, got {valve!r}")
    if not _finite(speed_rpm) or speed_rpm <= 0:
        raise InputError("speed_rpm", f"must be a positive finite speed in rpm, got {speed_rpm}")
    if not _finite(load_pressure) or load_pressure <= 0:
        raise InputError("load_pressure", f"must be a positive finite absolute pressure in Pa, got {load_pressure}")
    if air_content is not None and (not _finite(air_content) or not 0.0 <= air_content < 1.0):
        raise InputError("air_content", f"must be a volume fraction in [0, 1), got {air_content}")
    if isinstance(revolutions, bool) or not isinstance(revolutions, (int, np.integer)) or revolutions < 2:
        raise InputError("revolutions", f"must be an integer >= 2 (cyclic steady state compares two), got {revolutions}")
    if max_revolutions is not None and (not isinstance(max_revolutions, (int, np.integer))
                                        or max_revolutions < revolutions):
        raise InputError("max_revolutions", f"must be an integer >= revolutions, got {max_revolutions}")
    if not isinstance(trace_revolutions, (int, np.integer)) or not 1 <= trace_revolutions <= revolutions:
        raise InputError("trace_revolutions", f"must be an integer in [1, revolutions], got {trace_revolutions}")
    if circuit not in CIRCUITS:
        raise InputError("circuit", f"expected simplified or complete, got {circuit!r}")
    for name, v in (("rtol", rtol), ("atol", atol)):
        if not _finite(v) or not 0 < v < 1:
            raise InputError(name, f"must be in (0, 1), got {v}")
    if method not in ("Radau", "BDF", "LSODA"):
        raise InputError("method", f"expected Radau, BDF, LSODA or fast, got {method!r}")


def _finite(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and math.isfinite(v)


def simulate(valve: str, speed_rpm: float, load_pressure: float, *, air_content: float | None = None,
             revolutions: int = 5, circuit: str = "simplified", params: PumpModel | None = None,
             rtol: float | None = None, atol: float | None = None, trace: bool = False, progress: bool = False,
             max_revolutions: int | None = None, steady_tol: float = 1e-4, trace_revolutions: int = 1,
             trace_points: int = 2000, method: str = "Radau") -> PumpResult:
    """Simulate the pump at speed_rpm [rpm] and load_pressure [Pa, absolute] with disc or reed valves.

    ``params``: a :class:`~lumped.params.PumpModel` (None: the thesis configuration of
    ``valve``, :func:`lumped.params.thesis_model`); ``air_content`` overrides its R.
    Runs ``revolutions`` revolutions from top dead centre; with ``max_revolutions`` it
    continues until cyclic steady state is detected (relative change of the delivery
    and of the state at TDC between successive revolutions below ``steady_tol``, or below
    ``rtol`` if that is larger: :func:`steady_threshold`) or the
    maximum is reached. ``rtol``/``atol``: tolerances of the implicit integrator
    (``method``), atol in units of each state's scale (stop gap, 1 m/s, mass pumped per
    revolution); the defaults (None: 1e-6 and 1e-6) come from the convergence study in README.md.
    ``trace``: keep the last ``trace_revolutions`` revolutions sampled at
    ``trace_points`` points per revolution. Delivery per revolution is eq 4.17 at
    atmospheric density over the last revolution.

    ``method``: scipy's "Radau" (the reference, default), "BDF" or "LSODA", or "fast": the
    same physics compiled and integrated by Rodas4P, :func:`lumped.pump_fast.simulate`
    (with its own default tolerances, lumped.pump_fast.RTOL and ATOL, when rtol/atol are
    None; the complete circuit runs on Radau there).
    """
    if method == "fast":
        from lumped import pump_fast

        tol = {k: v for k, v in (("rtol", rtol), ("atol", atol)) if v is not None}
        return pump_fast.simulate(valve, speed_rpm, load_pressure, air_content=air_content,
                                  revolutions=revolutions, circuit=circuit, params=params, trace=trace,
                                  progress=progress, max_revolutions=max_revolutions, steady_tol=steady_tol,
                                  trace_revolutions=trace_revolutions, trace_points=trace_points, **tol)
    rtol = 1e-6 if rtol is None else rtol
    atol = 1e-6 if atol is None else atol
    _check_inputs(valve, speed_rpm, load_pressure, air_content, revolutions, circuit, rtol, atol,
                  max_revolutions, trace_revolutions, method)
    cpu0 = _time.process_time()
    model = params if params is not None else thesis_model(valve)
    if params is not None and params.valve != valve:
        raise InputError("params", f"describes {params.valve} valves, not {valve}")
    if air_content is not None:
        model = replace(model, oil=replace(model.oil, air_content=float(air_content)))
    validate_model(model)
    speed_rpm = float(speed_rpm)
    load_pressure = float(load_pressure)

    n = N_COMPLETE if circuit == "complete" else N_SIMPLIFIED
    tune = circuit == "complete" and model.pump.needle_area is None
    p = pack(model, speed_rpm, load_pressure, circuit)
    if tune:
        p[G_NVCDA] = _needle_cda_estimate(model, p)
    pl_list = p.tolist()                      # list indexing is the fast path for CPython floats
    omega = p[G_OMEGA]
    period = 2.0 * math.pi / omega
    atol_v = _atol_vector(n, atol, p, model)
    jac = _make_jac(n, atol_v / atol) if method != "LSODA" else None

    y = _initial_state(model, p, n)
    mode = auto_mode(y, p)
    limit = max_revolutions or revolutions
    deliveries, changes, tdc_states = [], [], [y.copy()]
    keep: list[list[_Segment]] = []
    nfev = 0
    n_events = 0
    last = None
    tuned_at = 0 if not tune else None
    bar = _progress_bar(progress, limit, f"{valve} {speed_rpm:.0f} rpm")
    rho0 = model.oil.density_atm
    k = 0
    steady = False
    change = math.inf
    while k < limit:
        t0, t1 = k * period, (k + 1) * period
        y_start = y.copy()
        segs: list[_Segment] = []
        events_rev: list[tuple[float, int, int, int]] = []
        peak = [max(y[S_XIN], 0.0), max(y[S_XDEL], 0.0)]
        pl_sum = 0.0
        t = t0
        zero_len = 0
        want_dense = trace or circuit == "complete"
        while t < t1:
            evs = _events_for(mode, pl_list)
            m_now = list(mode)
            sol = solve_ivp(_rhs_py, (t, t1), y, method=method, rtol=rtol, atol=atol_v,
                            events=[e[0] for e in evs], dense_output=want_dense,
                            args=(pl_list, m_now), jac=jac)
            nfev += sol.nfev
            if sol.status < 0:
                raise RuntimeError(f"integrator failed at t = {t:.6g} s: {sol.message}")
            peak[0] = max(peak[0], float(sol.y[S_XIN].max()))
            peak[1] = max(peak[1], float(sol.y[S_XDEL].max()))
            t_end = float(sol.t[-1])
            segs.append(_Segment(t, t_end, sol.sol, m_now))
            if sol.status == 1:
                y = sol.y[:, -1].copy()
                for (g, slot, old, new, level), te in zip(evs, sol.t_events):
                    if len(te) and te[-1] == t_end:
                        mode[slot] = new
                        y[S_XIN if slot < 2 else S_XDEL] = level   # exactly on the switching surface
                        events_rev.append((t_end, slot, old, new))
                        n_events += 1
                zero_len = zero_len + 1 if t_end - t <= 1e-12 * period else 0
                if zero_len > 50 or len(events_rev) > 20000:
                    raise RuntimeError(f"valve chatter: {len(events_rev)} switches in revolution {k + 1} "
                                       f"near t = {t_end:.6g} s; loosen the contact model or tolerances")
            else:
                y = sol.y[:, -1].copy()
            t = t_end
        # ---- revolution bookkeeping
        d_in = y[S_MIN] - y_start[S_MIN]
        d_out = y[S_MOUT] - y_start[S_MOUT]
        d_leak = y[S_MLEAK] - y_start[S_MLEAK]
        d_cyl = y[S_MCYL] - y_start[S_MCYL]
        mass_err = abs(d_cyl - (d_in - d_out - d_leak)) / max(abs(d_in), abs(d_out), 1e-300)
        deliveries.append(d_out / rho0)                          # eq 4.17 at atmospheric density
        pl_mean = _mean_load_pressure(segs, t0, t1, pl_list, circuit)
        if tune and tuned_at is None:
            # start-up procedure, like the experimenter's needle-valve setting (section 5.5.2):
            # match the needle flow to the delivery at the requested mean pressure and move
            # the load-side mass to it; the cylinder and its mass balance are not touched
            d_nv = y[S_MNV] - y_start[S_MNV]
            a_old = pl_list[G_NVCDA]
            a_new = a_old * (d_out / d_nv) * math.sqrt((pl_mean - pl_list[G_PTANK]) / (load_pressure - pl_list[G_PTANK]))
            if abs(a_new / a_old - 1.0) < 2e-4 and abs(pl_mean / load_pressure - 1.0) < 2e-4:
                tuned_at = k + 1                                  # needle valve frozen from here on
            else:
                pl_list[G_NVCDA] = a_new
                y[S_MLOAD] += load_mass(load_pressure, pl_list)[0] - load_mass(pl_mean, pl_list)[0]
        tdc_states.append(y.copy())
        if k >= 1:
            change = _cycle_change(deliveries, tdc_states, p, model)
            changes.append(change)
            settled = tuned_at is not None and k + 1 - tuned_at >= 2
            steady = change < steady_threshold(steady_tol, rtol) and (circuit == "simplified" or settled)
        last = dict(segs=segs, events=events_rev, peak=peak, mass_err=mass_err, t0=t0, t1=t1, pl_mean=pl_mean,
                    leak=d_leak / rho0)
        if trace:
            keep.append(segs)
            keep = keep[-trace_revolutions:]
        k += 1
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"{deliveries[-1] * 1e6:.4f} cc/rev")
        if k >= revolutions and steady:
            break
    if bar is not None:
        bar.close()
    cpu = _time.process_time() - cpu0

    opening, closing, stops = _valve_timing(last["events"], last["t0"], period, tdc_states[-2], omega)
    tr = _sample_trace(keep, period, trace_points, pl_list) if trace else None
    return PumpResult(
        valve=valve, circuit=circuit, speed_rpm=speed_rpm, load_pressure=load_pressure,
        air_content=model.oil.effective_air, delivery_per_rev=deliveries[-1], deliveries=tuple(deliveries),
        revolutions=k, cyclic_steady=bool(steady), cycle_change=float(change), cpu_seconds=cpu,
        simulated_seconds=k * period, mass_balance_error=float(last["mass_err"]),
        peak_opening=tuple(last["peak"]), opening_angle=opening, closing_angle=closing,
        stop_contacts=stops, mean_load_pressure=float(last["pl_mean"]), leakage_per_rev=float(last["leak"]),
        needle_area=(pl_list[G_NVCDA] / model.pump.needle_discharge) if circuit == "complete" else None,
        rhs_evaluations=int(nfev), events=int(n_events), method=method, rtol=rtol, atol=atol, trace=tr,
    )


def _progress_bar(progress: bool, total: int, desc: str):
    if not progress:
        return None
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit="rev", file=sys.stderr, leave=False)


def steady_threshold(steady_tol: float, rtol: float) -> float:
    """Cycle change below which a revolution counts as cyclic steady: steady_tol, but never
    below the integrator's rtol (a converged cycle still changes by its integration noise:
    1e-4..6e-4 between revolutions at rtol 1e-3, 1e-8 at 1e-6)."""
    return max(steady_tol, rtol)


def _cycle_change(deliveries, states, p, model) -> float:
    """Largest relative change between the last two revolutions: delivery and state at TDC."""
    d1, d0 = deliveries[-1], deliveries[-2]
    a, b = states[-1], states[-2]
    m_rev = model.oil.density_atm * model.pump.displacement
    ch = [abs(d1 - d0) / max(abs(d1), 1e-300),
          abs(a[S_MCYL] - b[S_MCYL]) / m_rev,
          abs(a[S_XIN] - b[S_XIN]) / p[OFF_IN + V_XSTOP],
          abs(a[S_XDEL] - b[S_XDEL]) / p[OFF_DEL + V_XSTOP]]
    if len(a) == N_COMPLETE:
        ch.append(abs(a[S_MLOAD] - b[S_MLOAD]) / m_rev)
    return float(max(ch))


def _mean_load_pressure(segs, t0, t1, p, circuit) -> float:
    if circuit != "complete":
        return p[G_PLOAD]
    ts = np.linspace(t0, t1, 121)
    vals = []
    for t in ts:
        seg = _find_segment(segs, t)
        vals.append(load_pressure(seg.sol(t)[S_MLOAD], p))
    return float(np.trapezoid(vals, ts) / (t1 - t0))


def _needle_cda_estimate(model: PumpModel, p) -> float:
    """First guess of Cd A of the needle valve: pass 85 % of the ideal delivery at the load pressure."""
    pl, pt = p[G_PLOAD], p[G_PTANK]
    oil = model.oil
    ideal = model.pump.displacement - (oil.density(pl) / oil.density(pt) - 1.0) * model.pump.dead_volume
    mdot = 0.85 * ideal * oil.density_atm * p[G_OMEGA] / (2 * math.pi)
    return mdot / math.sqrt(2.0 * oil.density(pl) * (pl - pt))


def _find_segment(segs, t):
    starts = [s.t0 for s in segs]
    i = max(0, bisect.bisect_right(starts, t) - 1)
    return segs[i]


def _valve_timing(events, t0, period, y_start, omega):
    """Crank angles of the main opening and closing of each valve and stop contacts in a revolution."""
    opening, closing, stops = [], [], []
    for v, xi in enumerate((S_XIN, S_XDEL)):
        ev = [(t, new) for (t, slot, old, new) in events if slot == 2 * v]
        stops.append(sum(1 for _, new in ev if new == STOP))
        # open intervals [start, end) of x > 0 within the periodic revolution
        was_open = y_start[xi] > 0.0
        intervals, start = [], (t0 if was_open else None)
        for t, new in ev:
            if new == FREE and start is None:
                start = t
            elif new == SEAT and start is not None:
                intervals.append((start, t))
                start = None
        if start is not None:
            intervals.append((start, t0 + period))
        if not intervals:
            opening.append(None)
            closing.append(None)
            continue
        # join an interval running into the end with one starting the revolution (periodicity)
        if len(intervals) > 1 and intervals[0][0] == t0 and intervals[-1][1] == t0 + period:
            first = intervals.pop(0)
            a, b = intervals.pop()
            intervals.append((a, b + (first[1] - first[0])))
        a, b = max(intervals, key=lambda iv: iv[1] - iv[0])
        opening.append(float(((a - t0) * omega) % (2 * math.pi)))
        closing.append(float(((b - t0) * omega) % (2 * math.pi)))
    return tuple(opening), tuple(closing), tuple(stops)


def _sample_trace(revs, period, npts, p) -> PumpTrace:
    rows = []
    for segs in revs:
        t0 = segs[0].t0
        for i in range(npts):
            t = t0 + period * i / npts
            seg = _find_segment(segs, t)
            y = seg.sol(t)
            e = evaluate(t, y, p, seg.mode)
            rows.append((t, y[S_XIN], y[S_XDEL], e[10], e[11], e[5], e[6], y[S_UIN], y[S_UDEL]))
    a = np.array(rows)
    t = a[:, 0] - revs[0][0].t0
    return PumpTrace(time=t, crank_angle=p[G_OMEGA] * t, cylinder_pressure=a[:, 3], load_pressure=a[:, 4],
                     inlet_position=a[:, 1], delivery_position=a[:, 2], inlet_mass_flow=a[:, 5],
                     delivery_mass_flow=a[:, 6], inlet_velocity=a[:, 7], delivery_velocity=a[:, 8])


# ----------------------------------------------------------------- output
TRACE_COLUMNS = ("time_s", "valve_position_m", "cylinder_pressure_pa", "load_pressure_pa",
                 "inlet_position_m", "delivery_position_m")


def write_trace_csv(result: PumpResult, path, measured_valve: str = "delivery", force: bool = False,
                    field: str = "--trace") -> Path:
    """Write the trace with CONTRACT's measured-trace columns (valve_position_m = ``measured_valve``).

    Refuses to overwrite an existing file unless ``force``.
    """
    from studies.outputs import check_new_file

    if result.trace is None:
        raise ValueError("the result holds no trace; simulate(..., trace=True)")
    if measured_valve not in ("inlet", "delivery"):
        raise InputError("measured_valve", f"expected inlet or delivery, got {measured_valve!r}")
    out = check_new_file(path, field, force)
    tr = result.trace
    pos = tr.inlet_position if measured_valve == "inlet" else tr.delivery_position
    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(TRACE_COLUMNS)
        for row in zip(tr.time, pos, tr.cylinder_pressure, tr.load_pressure, tr.inlet_position,
                       tr.delivery_position):
            w.writerow([f"{v:.9g}" for v in row])
    return out
