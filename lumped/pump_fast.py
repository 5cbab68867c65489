"""The fast pump simulation: the reference physics of :mod:`lumped.pump`, compiled, on Rodas4P.

Same physics, not a copy: :func:`_jit_physics` compiles the very functions of
``lumped.oil``, ``lumped.orifice``, ``lumped.disc_valve``, ``lumped.reed_valve`` and
``lumped.pump`` with ``numba.njit`` (each function's own code object, its module globals
re-pointed at the compiled siblings). The right-hand side is ``lumped.pump.evaluate``.

The compiled copies use numba's ``error_model="numpy"`` (no zero test before each float
division, about 30 % of a right-hand side call): numbers are the same; where the Python
reference would raise ZeroDivisionError the compiled code gets inf or nan, which the
integrator rejects as a failed step.

Same switches: like the reference integrator, each valve's contact state (seat, free,
stop) and pressure regime (Poiseuille, orifice; eq 2.18) are fixed inside a step and
change only at a located crossing of the same switching surfaces (x = 0, x_stop, the
transition opening), where the position is set exactly onto the surface. The crossing is
found on Rodas4P's dense output (:mod:`lumped.rodas`), the step is cut there and the
integration restarts in the new mode, so the integrand is smooth inside every step.

Same results: :func:`simulate` has the signature of :func:`lumped.pump.simulate` and
returns its :class:`~lumped.pump.PumpResult` (``method = "fast"``); revolution bookkeeping
(delivery of eq 4.17, mass balance, cyclic steady state, valve timing) reuses the
reference's own helpers. Only the simplified circuit (constant load pressure, section
4.2.2) is compiled; ``circuit="complete"`` is delegated to the reference integrator.

The compiled solver is cached on disk; the first call in a fresh environment compiles it
(about a minute, reported by :func:`compile_seconds`, never counted in ``cpu_seconds``).
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import inspect
import math
import sys
import time as _time
import types
from dataclasses import replace

import numba
import numpy as np

from geometry.errors import InputError
from lumped import pump as ref
from lumped import rodas
from lumped.params import (
    G_AIR, G_AP, G_BETA, G_CRANK, G_GAMMA, G_LEAK, G_MU, G_OMEGA, G_P0, G_PLOAD, G_PTANK, G_RHO0, G_ROD,
    G_VTDC, KIND_REED, NP, OFF_DEL, OFF_IN, V_ADISC, V_FLOW, V_KIND, V_KSEAT, V_KSTOP, V_POIS, V_RHOMODE,
    V_XSTOP, V_XTRANS, PumpModel,
    pack, thesis_model, validate_model,
)

#: modules whose functions are compiled as they are (the physics of the reference path)
PHYSICS_MODULES = ("lumped.oil", "lumped.orifice", "lumped.disc_valve", "lumped.reed_valve", "lumped.pump")
N_DYN = 5          # m_cyl, x_in, u_in, x_del, u_del feed back; the mass totals are quadratures
N_EVENTS = 6       # per valve: seat, stop, pressure regime
MODE = NP          # p[MODE:MODE + 4] holds the mode [contact in, regime in, contact del, regime del]
TOL = NP + 4       # p[TOL + 2 (3 v + c) + (0, 1)]: atol of valve v's (x, u) in contact state c
STASH = TOL + 12   # p[STASH:STASH + 3]: (t, m_cyl, P_cyl) of the last rhs call, for the Jacobian
NX = STASH + 3     # length of the extended parameter array
SEAT, FREE, STOP = ref.SEAT, ref.FREE, ref.STOP
HYSTERESIS = ref.HYSTERESIS   # [m] reverse crossings, as the reference
POISEUILLE, ORIFICE = ref.POISEUILLE, ref.ORIFICE
MAX_STEPS_PER_REV = 2_000_000
MAX_EVENTS_PER_REV = 20_000
JAC_REUSE = 1      # accepted steps per Jacobian (Rosenbrock methods want a fresh one)
# Default tolerances, chosen by the study of benchmarks/pump_tolerance_study.py (fast path
# against the reference at its defaults on the 12 validation cases, 5 revolutions, and 10
# random designs of studies.random_designs, 3 revolutions). Meaning as in lumped.pump.simulate: atol in units of each
# state's scale (stop gap, 1 m/s, mass per revolution), refined per valve and contact state
# by _tolerance_table:
#   - free flight: opening atol x stop gap; velocity FREE_VELOCITY_ATOL x atol x 1 m/s (the
#     velocity of a free valve hardly matters to the delivery; x10 looser cost 1.2x the
#     steps of the reed, with the same accuracy);
#   - in contact: velocity CONTACT_ATOL x atol x 1 m/s (disc x30: a disc pressed on its
#     seat or stop moves at um/s, and x30 saves 20 % of its steps with the same deliveries
#     and angles; the reed's lift-off angles drift by 1 deg at x100, so it keeps x1), opening
#     CONTACT_POSITION_ATOL x atol x the contact deflection P_load A / k: when a valve
#     resting on its seat or stop lets go (u ~ 0) is decided by nanometres (atol 3e-5
#     moves such lift-offs by up to 3 deg);
# rtol 1e-3, atol 1e-5: delivery within 0.021 % of the reference (worst of 22 cases), valve
# opening and closing angles within 0.25 deg; rtol 3e-3 saves 5-9 % of the steps for 0.035 %.
RTOL, ATOL = 1e-3, 1e-5
FREE_VELOCITY_ATOL = 100.0
FREE_POSITION_ATOL = 1.0     # multiplier of atol for the opening in free flight
CONTACT_ATOL = {"disc": 30.0, "reed": 1.0}  # ... for the velocity in contact, by valve kind
CONTACT_POSITION_ATOL = 30.0  # ... for the opening in contact, in units of the contact deflection


# ----------------------------------------------------------------- compile the reference physics
def _jit_physics() -> dict[str, types.ModuleType]:
    """numba-compiled mirrors of the physics modules: name -> module of dispatchers.

    Every function defined in one of PHYSICS_MODULES is wrapped (lazily: only what the
    right-hand side calls is ever compiled) with its globals copied and every reference to
    a physics function or module replaced by its compiled counterpart.
    """
    mods = {name: importlib.import_module(name) for name in PHYSICS_MODULES}
    mirrors = {name: types.ModuleType(f"{name}__jit") for name in mods}
    jitted: dict[tuple[str, str], object] = {}
    scopes = []
    for name, mod in mods.items():
        scope = dict(mod.__dict__)
        scopes.append(scope)
        for attr, fn in mod.__dict__.items():
            if isinstance(fn, types.FunctionType) and fn.__module__ == name:
                new = types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__)
                new.__qualname__ = f"{fn.__qualname__}__jit"
                new.__module__ = name
                disp = numba.njit(new, error_model="numpy")
                jitted[(name, attr)] = disp
                setattr(mirrors[name], attr, disp)
    for scope in scopes:
        for attr, v in list(scope.items()):
            if isinstance(v, types.FunctionType) and (v.__module__, v.__name__) in jitted:
                scope[attr] = jitted[(v.__module__, v.__name__)]
            elif isinstance(v, types.ModuleType) and v.__name__ in mirrors:
                scope[attr] = mirrors[v.__name__]
    return mirrors


_PHYS = _jit_physics()
_evaluate = _PHYS["lumped.pump"].evaluate
_cylinder_volume = _PHYS["lumped.pump"].cylinder_volume
_valve_acceleration = _PHYS["lumped.pump"].valve_acceleration
_valve_flow = _PHYS["lumped.disc_valve"].valve_flow
_pressure = _PHYS["lumped.oil"].pressure
_density = _PHYS["lumped.oil"].density
_density_slope = _PHYS["lumped.oil"].density_slope


# ----------------------------------------------------------------- the model as the solver sees it
@numba.njit(error_model="numpy")
def _mode(p):
    return (int(p[MODE]), int(p[MODE + 1]), int(p[MODE + 2]), int(p[MODE + 3]))


@numba.njit(error_model="numpy")
def _rhs(t, y, p, dydt):
    """dy/dt of the simplified pump (lumped.pump.evaluate) in the mode stored in p.

    Also leaves (t, m_cyl, P_cyl) in p[STASH:]: the solver forms the Jacobian right after
    evaluating f at the step start, and :func:`_jacobian` then needs no pressure inversion.
    """
    e = _evaluate(t, y, p, _mode(p))
    p[STASH] = t
    p[STASH + 1] = y[0]
    p[STASH + 2] = e[10]
    dydt[0] = e[0]
    dydt[1] = e[1]
    dydt[2] = e[2]
    dydt[3] = e[3]
    dydt[4] = e[4]
    dydt[5] = e[5]
    dydt[6] = e[6]
    dydt[7] = e[7]


@numba.njit(error_model="numpy")
def _events(t, y, p, g):
    """Switching functions of the current mode (those of lumped.pump._events_for, with its
    hysteresis on the reverse crossings); fire below 0."""
    hy = HYSTERESIS
    for v in range(2):
        o = OFF_IN if v == 0 else OFF_DEL
        x = y[1] if v == 0 else y[3]
        c = int(p[MODE + 2 * v])
        r = int(p[MODE + 2 * v + 1])
        xstop = p[o + V_XSTOP]
        if c == SEAT:
            g[3 * v] = -x            # lifts off the seat
            g[3 * v + 1] = 1.0
        elif c == FREE:
            g[3 * v] = x + hy        # lands on the seat
            g[3 * v + 1] = xstop - x  # reaches the stop
        else:
            g[3 * v] = 1.0
            g[3 * v + 1] = x - (xstop - hy)  # leaves the stop
        g[3 * v + 2] = 1.0
        if p[o + V_KIND] != KIND_REED and p[o + V_POIS] > 0.5:
            xt = p[o + V_XTRANS]
            g[3 * v + 2] = xt - x if r == POISEUILLE else x - (xt - hy)


@numba.njit(error_model="numpy")
def _retry(k, p):
    """Redo the step to a located crossing only when a valve leaves its seat or stop: in contact
    the opening is a stiff component slaved to the pressure, which the interpolant of a long
    step does not follow; in free flight it does, to the tolerance."""
    c = int(p[MODE + 2 * (k // 3)])
    kind = k % 3
    return (kind == 0 and c == SEAT) or (kind == 1 and c == STOP)


@numba.njit(error_model="numpy")
def _apply(k, t, y, p):
    """Switch the mode for event k, put the valve exactly on the surface; code = slot*100 + old*10 + new."""
    v = k // 3
    kind = k % 3
    o = OFF_IN if v == 0 else OFF_DEL
    xi = 1 if v == 0 else 3
    c = int(p[MODE + 2 * v])
    r = int(p[MODE + 2 * v + 1])
    hy = HYSTERESIS
    if kind == 0:
        slot, old, new, level = 2 * v, c, (FREE if c == SEAT else SEAT), (0.0 if c == SEAT else -hy)
    elif kind == 1:
        slot, old, new, level = 2 * v, c, (STOP if c == FREE else FREE), p[o + V_XSTOP] - (0.0 if c == FREE else hy)
    else:
        slot, old, new, level = (2 * v + 1, r, (ORIFICE if r == POISEUILLE else POISEUILLE),
                                 p[o + V_XTRANS] - (0.0 if r == POISEUILLE else hy))
    p[MODE + slot] = new
    y[xi] = level
    return slot * 100 + old * 10 + new


@numba.njit(error_model="numpy")
def _valve_partials(x, u, dp, ddp_dm, p_down, dpdown_dm, rho_v, drho_dm, mu, p, o, contact, regime,
                    hx, hu, hm, out):
    """Partials of one valve's mass flow (eqs 4.3/4.4) and acceleration by the cylinder mass m,
    its opening x and velocity u: out = (dmdot/dm, dmdot/dx, dmdot/du, da/dm, da/dx, da/du).

    The flow part is exact: valve_flow gives dQ_o/d(dp) and dQ_o/dx, and Q_o of the orifice
    equation with Cd(Re) scales as rho^(1/w' - 1) at fixed dp, so dQ_o/drho = (dp dQ_o/d(dp) - Q_o)/rho.
    The acceleration (valve_acceleration, cheap without the flow force) is differenced
    forward in x, u and in m through dp, the downstream pressure and the density.
    """
    qo, cd, aq, dq_ddp, dq_dx = _valve_flow(x, u, dp, rho_v, mu, p, o, contact)
    dq_drho = (dp * dq_ddp - qo) / rho_v
    out[0] = drho_dm * (qo + aq * u) + rho_v * (dq_ddp * ddp_dm + dq_drho * drho_dm)
    out[1] = rho_v * dq_dx
    out[2] = rho_v * aq                    # A_Q is piecewise constant in u (eq 2.42)
    a0 = _valve_acceleration(x, u, dp, p_down, rho_v, qo, cd, aq, dq_ddp, dq_dx, 0.0, p, o, contact, regime)
    am = _valve_acceleration(x, u, dp + ddp_dm * hm, p_down + dpdown_dm * hm, rho_v + drho_dm * hm, qo, cd, aq,
                             dq_ddp, dq_dx, 0.0, p, o, contact, regime)
    ax = _valve_acceleration(x + hx, u, dp, p_down, rho_v, qo, cd, aq, dq_ddp, dq_dx, 0.0, p, o, contact, regime)
    au = _valve_acceleration(x, u + hu, dp, p_down, rho_v, qo, cd, aq, dq_ddp, dq_dx, 0.0, p, o, contact, regime)
    out[3] = (am - a0) / hm
    out[4] = (ax - a0) / hx
    out[5] = (au - a0) / hu


@numba.njit(error_model="numpy")
def _jacobian(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h):
    """df/dy and df/dt of the simplified pump for the price of about one rhs call (no rhs call).

    Chain rule through the pump equations (lumped.pump.evaluate): rho_cyl = m_cyl / V(t)
    (eq 4.6), P_cyl from eq 4.11 with dP/dm = 1 / (V drho/dP), the valve mass flows of eqs
    4.3-4.4 and the piston leakage (exact partials, :func:`_valve_partials`), the valve
    accelerations by cheap forward differences of valve_acceleration alone. Time enters only
    through rho_cyl, so df/dt = df/dm_cyl * (-m_cyl V'/V). Returns -1 (plain forward
    differences of the whole rhs) when the flow force is on: its transient term couples both
    valves to dP_cyl/dt.
    """
    if p[OFF_IN + V_FLOW] > 0.5 or p[OFF_DEL + V_FLOW] > 0.5 or n_dyn != 5:
        return -1
    n = y.shape[0]
    for j in range(n):
        for i in range(n):
            jac[i, j] = 0.0
    sq = 1.4901161193847656e-08
    omega = p[G_OMEGA]
    vol, dvol = _cylinder_volume(omega * t, omega, p[G_AP], p[G_CRANK], p[G_ROD], p[G_VTDC])
    rho0, p0, beta, gam, air = p[G_RHO0], p[G_P0], p[G_BETA], p[G_GAMMA], p[G_AIR]
    m = y[0]
    rho_c = m / vol
    if p[STASH] == t and p[STASH + 1] == m:
        pc = p[STASH + 2]                      # P_cyl of f(t, y), just evaluated
    else:
        pc = _pressure(rho_c, rho0, p0, beta, gam, air)
    pc_m = 1.0 / (vol * _density_slope(pc, rho0, p0, beta, gam, air))     # dP_cyl/dm_cyl
    pt = p[G_PTANK]
    pl = p[G_PLOAD]
    hm = sq * max(abs(m), atol[0] / rtol)
    part = fp                                   # scratch (6 entries used)
    for v in range(2):
        o = OFF_IN if v == 0 else OFF_DEL
        xi = 1 + 2 * v
        rho_v = rho_c
        drho = 1.0 / vol
        if p[o + V_RHOMODE] > 0.5:               # section 4.3.5: mean of both sides of the valve
            rho_v = 0.5 * (rho_c + _density(pt if v == 0 else pl, rho0, p0, beta, gam, air))
            drho = 0.5 / vol
        if v == 0:
            dp, ddp, pd, dpd = pt - pc, -pc_m, pc, pc_m
        else:
            dp, ddp, pd, dpd = pc - pl, pc_m, pl, 0.0
        hx = sq * max(abs(y[xi]), atol[xi] / rtol)
        hu = sq * max(abs(y[xi + 1]), atol[xi + 1] / rtol)
        _valve_partials(y[xi], y[xi + 1], dp, ddp, pd, dpd, rho_v, drho, p[G_MU], p, o,
                        int(p[MODE + 2 * v]), int(p[MODE + 2 * v + 1]), hx, hu, hm, part)
        sign = 1.0 if v == 0 else -1.0          # eq 4.5: dm/dt = mdot_in - mdot_del - mdot_leak
        row = 5 + v
        jac[row, 0] = part[0]
        jac[row, xi] = part[1]
        jac[row, xi + 1] = part[2]
        jac[0, 0] += sign * part[0]
        jac[0, xi] = sign * part[1]
        jac[0, xi + 1] = sign * part[2]
        jac[xi, xi + 1] = 1.0
        jac[xi + 1, 0] = part[3]
        jac[xi + 1, xi] = part[4]
        jac[xi + 1, xi + 1] = part[5]
    # laminar piston leakage rho_cyl K (P_cyl - P_tank)
    leak_m = p[G_LEAK] * ((pc - pt) / vol + rho_c * pc_m)
    jac[7, 0] = leak_m
    jac[0, 0] -= leak_m
    dm_dt = -m * dvol / vol           # the m_cyl change with the same effect on rho_cyl as dt
    for i in range(n):
        ft[i] = jac[i, 0] * dm_dt
    return 0


@numba.njit(error_model="numpy")
def _tolerances(p, atol):
    """Valve tolerances by contact state (:func:`_tolerance_table`)."""
    for v in range(2):
        c = int(p[MODE + 2 * v])
        atol[1 + 2 * v] = p[TOL + 2 * (3 * v + c)]
        atol[2 + 2 * v] = p[TOL + 2 * (3 * v + c) + 1]


@numba.njit(error_model="numpy")
def _tag(p):
    return int(p[MODE]) + 3 * int(p[MODE + 1]) + 9 * int(p[MODE + 2]) + 27 * int(p[MODE + 3])


@numba.njit(error_model="numpy")
def _trace_rows(ts, ys, tags, p):
    """Cylinder and load pressure, inlet and delivery mass flow at sampled states."""
    out = np.empty((ts.shape[0], 4))
    q = p.copy()
    for i in range(ts.shape[0]):
        tg = tags[i]
        q[MODE] = tg % 3
        q[MODE + 1] = (tg // 3) % 3
        q[MODE + 2] = (tg // 9) % 3
        q[MODE + 3] = (tg // 27) % 3
        e = _evaluate(ts[i], ys[i], q, _mode(q))
        out[i, 0] = e[10]
        out[i, 1] = e[11]
        out[i, 2] = e[5]
        out[i, 3] = e[6]
    return out


def _source_digest() -> str:
    """Hash of every source the compiled solver depends on: a change gets a fresh cache entry."""
    h = hashlib.sha256()
    for name in (*PHYSICS_MODULES, "lumped.params", "lumped.rodas", __name__):
        h.update(inspect.getsource(sys.modules[name]).encode())
    h.update(numba.__version__.encode())
    return h.hexdigest()[:12]


DIGEST = _source_digest()


def _drop_stale_cache() -> None:
    """Remove compiled solvers of earlier physics sources from numba's cache (they never load)."""
    from pathlib import Path

    for folder in {Path(sys.modules[m].__file__).parent / "__pycache__" for m in ("lumped.rodas", *PHYSICS_MODULES)}:
        for f in folder.glob("*.nb[ic]"):
            for marker in ("__pump_", "__py_"):
                if marker in f.name and DIGEST not in f.name:
                    try:
                        f.unlink()
                    except OSError:  # another process's, or a read-only install: harmless
                        pass


_drop_stale_cache()
_solver = rodas.specialize(_rhs, f"pump_{DIGEST}", events=_events, apply=_apply, tagger=_tag, jac=_jacobian,
                           tolerances=_tolerances, retry=_retry)


def cached(func):
    """A disk-cached copy of one of this module's jitted functions, for calls from Python.

    (Inside the solver they are compiled into its own cache entry; called from Python each
    would otherwise compile the whole physics again in every new process.)
    """
    key = func.py_func.__name__
    if key not in _CACHED:
        _CACHED[key] = rodas._rebind(func, func.py_func.__globals__, f"py_{DIGEST}", cache=True)
    return _CACHED[key]


_CACHED: dict = {}
_COMPILE = {"seconds": None}


def compile_seconds() -> float:
    """Wall seconds spent compiling or loading the solver from the cache in this process."""
    _ensure_compiled()
    return _COMPILE["seconds"]


def _ensure_compiled() -> None:
    if _COMPILE["seconds"] is not None:
        return
    t0 = _time.perf_counter()
    model = thesis_model("disc")
    p = _extended(pack(model, 600.0, 2.8e6), [SEAT, ORIFICE, SEAT, ORIFICE])
    y = ref._initial_state(model, p, ref.N_SIMPLIFIED)
    out = _solver(0.0, y, np.array([1e-9]), p, 1e-6, np.full(ref.N_SIMPLIFIED, 1e-9), 1e-10, np.inf, 100,
                  N_DYN, 0.0, N_EVENTS, 100, 1)
    cached(_peaks)(out[3], out[4], out[5])         # the helpers every run calls, compiled or loaded too
    _COMPILE["seconds"] = _time.perf_counter() - t0


def _extended(p: np.ndarray, mode, tol_table=None) -> np.ndarray:
    """The packed parameters followed by the mode and the valve tolerance table."""
    q = np.zeros(NX)
    q[:NP] = p[:NP]
    q[MODE:MODE + 4] = mode
    q[TOL:TOL + 12] = 1e-9 if tol_table is None else tol_table
    return q


def _tolerance_table(atol: float, atol_v: np.ndarray, p: np.ndarray, contact_atol: float | None = None) -> np.ndarray:
    """atol of (x, u) of each valve on its seat, free, on its stop (order of p[TOL:TOL + 12]).

    Free flight: the reference's scales (atol times the stop gap; FREE_VELOCITY_ATOL times
    atol times 1 m/s). In contact the valve sits a deflection F/k into its seat or stop,
    nanometres for a rigid seat, and crosses back out of it when the pressure force lets go:
    the opening or closing time is the time x needs to cover that deflection. So x in
    contact is measured against its own scale, atol times the deflection a load-pressure
    force would cause (P_load A / k; A = the disc face, or 1 for the reed's per-area eq 3.21),
    and u against atol times 1 m/s.
    """
    table = np.empty(12)
    for v, (o, xi) in enumerate(((OFF_IN, ref.S_XIN), (OFF_DEL, ref.S_XDEL))):
        area = 1.0 if p[o + V_KIND] == KIND_REED else p[o + V_ADISC]
        for c, k in ((SEAT, p[o + V_KSEAT]), (FREE, 0.0), (STOP, p[o + V_KSTOP])):
            x_free = atol_v[xi] * FREE_POSITION_ATOL
            x_tol = x_free if k <= 0.0 else min(x_free, CONTACT_POSITION_ATOL * atol * p[G_PLOAD] * area / k)
            kind = "reed" if p[o + V_KIND] == KIND_REED else "disc"
            in_contact = CONTACT_ATOL[kind] if contact_atol is None else contact_atol
            u_tol = atol_v[xi + 1] * (FREE_VELOCITY_ATOL if c == FREE else in_contact)
            table[2 * (3 * v + c)] = x_tol
            table[2 * (3 * v + c) + 1] = u_tol
    return table


def _decode(ev_t, ev_code) -> list[tuple[float, int, int, int]]:
    """Event log as lumped.pump's (time, slot, old, new) tuples."""
    return [(float(t), int(c) // 100, (int(c) // 10) % 10, int(c) % 10) for t, c in zip(ev_t, ev_code)]


@numba.njit(error_model="numpy")
def _peaks(rec_y, rec_q2, rec_q3):
    """Largest inlet and delivery openings [m] in the recorded steps, interpolant included
    (at the quarters of every step)."""
    best = np.zeros(2)
    for j in range(2):
        xi = 1 + 2 * j
        for i in range(rec_y.shape[0]):
            best[j] = max(best[j], rec_y[i, xi])
            if i > 0:
                for s in (0.25, 0.5, 0.75):
                    v = rec_y[i - 1, xi] * (1 - s) + s * (rec_y[i, xi] + (1 - s) * (rec_q2[i, xi] + s * rec_q3[i, xi]))
                    best[j] = max(best[j], v)
    return best


@functools.lru_cache(maxsize=4)
def _thesis_model(valve: str) -> PumpModel:
    """lumped.params.thesis_model, read from its data files once per process (frozen, shareable)."""
    return thesis_model(valve)


_VALIDATED: dict = {}


def _validate(model: PumpModel) -> None:
    """lumped.params.validate_model, once per distinct (frozen, hashable) model in a process."""
    try:
        if model in _VALIDATED:
            return
    except TypeError:                 # an unhashable field: check every time
        validate_model(model)
        return
    validate_model(model)
    if len(_VALIDATED) >= 1024:
        _VALIDATED.clear()
    _VALIDATED[model] = True


# ----------------------------------------------------------------- simulate
def simulate(valve: str, speed_rpm: float, load_pressure: float, *, air_content: float | None = None,
             revolutions: int = 5, circuit: str = "simplified", params: PumpModel | None = None,
             rtol: float | None = None, atol: float | None = None, trace: bool = False, progress: bool = False,
             max_revolutions: int | None = None, steady_tol: float = 1e-4, trace_revolutions: int = 1,
             trace_points: int = 2000, method: str = "fast", contact_atol: float | None = None) -> ref.PumpResult:
    """:func:`lumped.pump.simulate` on the compiled Rodas4P path (same arguments, same result).

    Tolerances have the reference's meaning (atol in units of each state's scale; a valve's
    velocity in free flight gets FREE_VELOCITY_ATOL times atol); the defaults (RTOL 1e-3,
    ATOL 1e-5, from the tolerance study in README.md) keep the delivery within 0.02 % and
    the valve timing within 0.5 deg of the reference at its defaults (tests/test_pump_fast.py).
    Cyclic steady state is judged at the integrator's own accuracy
    (:func:`lumped.pump.steady_threshold`). ``method`` is "fast";
    the circuit "complete" runs the reference integrator (Radau) instead.

    ``contact_atol`` (fast path only) overrides CONTACT_ATOL, the velocity tolerance of a
    valve on its seat or stop in units of atol x 1 m/s: the disc default (x30) keeps
    deliveries and angles but moves lift-offs by micrometres of trace; fitting traces
    to 10 um effects (studies.pump_sim) asks for 1.
    """
    if circuit == "complete":     # None: the reference's own default tolerances
        return ref.simulate(valve, speed_rpm, load_pressure, air_content=air_content,
                            revolutions=revolutions, circuit=circuit, params=params, rtol=rtol, atol=atol,
                            trace=trace, progress=progress, max_revolutions=max_revolutions,
                            steady_tol=steady_tol, trace_revolutions=trace_revolutions,
                            trace_points=trace_points)
    rtol = RTOL if rtol is None else rtol
    atol = ATOL if atol is None else atol
    ref._check_inputs(valve, speed_rpm, load_pressure, air_content, revolutions, circuit, rtol, atol,
                      max_revolutions, trace_revolutions, "Radau")
    if method != "fast":
        raise InputError("method", f"the fast path has one method, 'fast'; got {method!r}")
    if contact_atol is not None and not (math.isfinite(contact_atol) and contact_atol > 0):
        raise InputError("contact_atol", f"must be a positive multiplier of atol, got {contact_atol}")
    _ensure_compiled()
    cpu0 = _time.process_time()
    model = params if params is not None else _thesis_model(valve)
    if params is not None and params.valve != valve:
        raise InputError("params", f"describes {params.valve} valves, not {valve}")
    if air_content is not None:
        model = replace(model, oil=replace(model.oil, air_content=float(air_content)))
    _validate(model)
    speed_rpm = float(speed_rpm)
    load_pressure = float(load_pressure)

    n = ref.N_SIMPLIFIED
    p0 = pack(model, speed_rpm, load_pressure, circuit)
    y = ref._initial_state(model, p0, n)
    atol_v = ref._atol_vector(n, atol, p0, model)
    p = _extended(p0, ref.auto_mode(y, p0), _tolerance_table(atol, atol_v, p0, contact_atol))
    omega = p[G_OMEGA]
    period = 2.0 * math.pi / omega
    rho0 = model.oil.density_atm
    limit = max_revolutions or revolutions
    deliveries, tdc_states = [], [y.copy()]
    keep = []
    nfev = n_events = 0
    h = 1e-4 * period
    steady = False
    change = math.inf
    last = None
    bar = ref._progress_bar(progress, limit, f"{valve} {speed_rpm:.0f} rpm (fast)")
    k = 0
    while k < limit:
        t0, t1 = k * period, (k + 1) * period
        y_start = y.copy()
        (status, y_stops, rec_t, rec_y, rec_q2, rec_q3, rec_tag, ev_t, ev_k, ev_code, n_steps, n_rej,
         n_rhs, h) = _solver(t0, y, np.array([t1]), p, rtol, atol_v, h, period, MAX_STEPS_PER_REV, N_DYN, t0,
                             N_EVENTS, MAX_EVENTS_PER_REV, JAC_REUSE)
        nfev += int(n_rhs)
        n_events += len(ev_t)
        if status != rodas.OK:
            raise RuntimeError(f"fast integrator failed in revolution {k + 1} "
                               f"({rodas.STATUS_TEXT[int(status)]}, t = {rec_t[-1]:.6g} s)")
        y = y_stops[-1].copy()
        d_in = y[ref.S_MIN] - y_start[ref.S_MIN]
        d_out = y[ref.S_MOUT] - y_start[ref.S_MOUT]
        d_leak = y[ref.S_MLEAK] - y_start[ref.S_MLEAK]
        d_cyl = y[ref.S_MCYL] - y_start[ref.S_MCYL]
        mass_err = abs(d_cyl - (d_in - d_out - d_leak)) / max(abs(d_in), abs(d_out), 1e-300)
        deliveries.append(d_out / rho0)                            # eq 4.17 at atmospheric density
        tdc_states.append(y.copy())
        if k >= 1:
            change = ref._cycle_change(deliveries, tdc_states, p0, model)
            steady = change < ref.steady_threshold(steady_tol, rtol)
        last = dict(events=_decode(ev_t, ev_code), mass_err=mass_err, t0=t0,
                    peak=cached(_peaks)(rec_y, rec_q2, rec_q3), leak=d_leak / rho0)
        if trace:
            keep.append((rec_t, rec_y, rec_q2, rec_q3, rec_tag))
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
    opening, closing, stops = ref._valve_timing(last["events"], last["t0"], period, tdc_states[-2], omega)
    tr = _sample_trace(keep, period, trace_points, p) if trace else None
    return ref.PumpResult(
        valve=valve, circuit=circuit, speed_rpm=speed_rpm, load_pressure=load_pressure,
        air_content=model.oil.effective_air, delivery_per_rev=deliveries[-1], deliveries=tuple(deliveries),
        revolutions=k, cyclic_steady=bool(steady), cycle_change=float(change), cpu_seconds=cpu,
        simulated_seconds=k * period, mass_balance_error=float(last["mass_err"]),
        peak_opening=(float(last["peak"][0]), float(last["peak"][1])), opening_angle=opening, closing_angle=closing,
        stop_contacts=stops, mean_load_pressure=load_pressure, leakage_per_rev=float(last["leak"]),
        needle_area=None,
        rhs_evaluations=nfev, events=n_events, method="fast", rtol=rtol, atol=atol, trace=tr,
    )


def _sample_trace(revs, period, npts, p) -> ref.PumpTrace:
    """The kept revolutions sampled at npts points each from the dense output."""
    ts, ys, tags = [], [], []
    for rec_t, rec_y, rec_q2, rec_q3, rec_tag in revs:
        t = rec_t[0] + period * np.arange(npts) / npts
        i = np.clip(np.searchsorted(rec_t, t, side="right"), 1, len(rec_t) - 1)
        ys.append(rodas.interpolate(t, rec_t, rec_y, rec_q2, rec_q3))
        ts.append(t)
        tags.append(rec_tag[i])
    t = np.concatenate(ts)
    y = np.concatenate(ys)
    e = cached(_trace_rows)(t, y, np.concatenate(tags), p)
    t_rel = t - revs[0][0][0]
    return ref.PumpTrace(time=t_rel, crank_angle=p[G_OMEGA] * t_rel, cylinder_pressure=e[:, 0],
                         load_pressure=e[:, 1], inlet_position=y[:, ref.S_XIN], delivery_position=y[:, ref.S_XDEL],
                         inlet_mass_flow=e[:, 2], delivery_mass_flow=e[:, 3],
                         inlet_velocity=y[:, ref.S_UIN], delivery_velocity=y[:, ref.S_UDEL])
