"""The fast pump simulation: the reference physics of :mod:`lumped.pump`, compiled, on Rodas4P.

Same physics, not a copy: :func:`_jit_physics` compiles the very functions of
``lumped.oil``, ``lumped.orifice``, ``lumped.disc_valve``, ``lumped.reed_valve`` and
``lumped.pump`` with ``numba.njit`` (each function's own code object, its module globals
re-pointed at the compiled siblings). The right-hand side is ``lumped.pump.evaluate``.

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
    G_AP, G_CRANK, G_OMEGA, G_ROD, G_VTDC, KIND_REED, NP, OFF_DEL, OFF_IN, V_FLOW, V_KIND, V_POIS,
    V_XSTOP, V_XTRANS, PumpModel, pack, thesis_model, validate_model,
)

#: modules whose functions are compiled as they are (the physics of the reference path)
PHYSICS_MODULES = ("lumped.oil", "lumped.orifice", "lumped.disc_valve", "lumped.reed_valve", "lumped.pump")
N_DYN = 5          # m_cyl, x_in, u_in, x_del, u_del feed back; the mass totals are quadratures
N_EVENTS = 6       # per valve: seat, stop, pressure regime
MODE = NP          # p[MODE:MODE + 4] holds the mode [contact in, regime in, contact del, regime del]
ATOL_U = NP + 4    # p[ATOL_U:ATOL_U + 2]: velocity atol in contact, in free flight [m/s]
SEAT, FREE, STOP = ref.SEAT, ref.FREE, ref.STOP
POISEUILLE, ORIFICE = ref.POISEUILLE, ref.ORIFICE
MAX_STEPS_PER_REV = 2_000_000
MAX_EVENTS_PER_REV = 20_000
JAC_REUSE = 1      # accepted steps per Jacobian (Rosenbrock methods want a fresh one)
# Default tolerances (meaning as in lumped.pump.simulate; atol in units of each state's
# scale: stop gap, 1 m/s, mass per revolution). The valve velocity decides when a valve
# resting on its seat or stop lets go (grazing, u ~ 0), so it gets atol while a valve is in
# contact and FREE_VELOCITY_ATOL times that in free flight. Against the reference path on
# the 12 validation cases: delivery within 0.003 %, opening/closing angles within 0.16 deg
# (0.5 deg on random designs, where a reed lifts off its seat at near-zero speed).
# (atol 1e-4 everywhere: as fast, but grazing lift-offs move by up to 3 deg.)
RTOL, ATOL = 1e-4, 1e-5
FREE_VELOCITY_ATOL = 10.0


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
                disp = numba.njit(new)
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


# ----------------------------------------------------------------- the model as the solver sees it
@numba.njit
def _mode(p):
    return (int(p[MODE]), int(p[MODE + 1]), int(p[MODE + 2]), int(p[MODE + 3]))


@numba.njit
def _rhs(t, y, p, dydt):
    """dy/dt of the simplified pump (lumped.pump.evaluate) in the mode stored in p."""
    e = _evaluate(t, y, p, _mode(p))
    dydt[0] = e[0]
    dydt[1] = e[1]
    dydt[2] = e[2]
    dydt[3] = e[3]
    dydt[4] = e[4]
    dydt[5] = e[5]
    dydt[6] = e[6]
    dydt[7] = e[7]


@numba.njit
def _events(t, y, p, g):
    """Switching functions of the current mode (those of lumped.pump._events_for); fire below 0."""
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
            g[3 * v] = x             # lands on the seat
            g[3 * v + 1] = xstop - x  # reaches the stop
        else:
            g[3 * v] = 1.0
            g[3 * v + 1] = x - xstop  # leaves the stop
        g[3 * v + 2] = 1.0
        if p[o + V_KIND] != KIND_REED and p[o + V_POIS] > 0.5:
            xt = p[o + V_XTRANS]
            g[3 * v + 2] = xt - x if r == POISEUILLE else x - xt


@numba.njit
def _apply(k, t, y, p):
    """Switch the mode for event k, put the valve exactly on the surface; code = slot*100 + old*10 + new."""
    v = k // 3
    kind = k % 3
    o = OFF_IN if v == 0 else OFF_DEL
    xi = 1 if v == 0 else 3
    c = int(p[MODE + 2 * v])
    r = int(p[MODE + 2 * v + 1])
    if kind == 0:
        slot, old, new, level = 2 * v, c, (FREE if c == SEAT else SEAT), 0.0
    elif kind == 1:
        slot, old, new, level = 2 * v, c, (STOP if c == FREE else FREE), p[o + V_XSTOP]
    else:
        slot, old, new, level = 2 * v + 1, r, (ORIFICE if r == POISEUILLE else POISEUILLE), p[o + V_XTRANS]
    p[MODE + slot] = new
    y[xi] = level
    return slot * 100 + old * 10 + new


@numba.njit
def _jacobian(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h):
    """df/dy and df/dt of the simplified pump from 3 rhs calls instead of 6 (exact structure).

    With the flow force off (its transient term couples the valves through dP_cyl/dt),
    eq 4.5 makes row 0 = row 5 - row 6 - row 7, the inlet valve (x_in, u_in) reaches only
    rows 0, 1, 2, 5 and the delivery valve only rows 0, 3, 4, 6. So x_in and x_del are
    perturbed together (rows 2, 5 and 4, 6 tell them apart), then u_in and u_del, then
    m_cyl alone. Time enters only through rho_cyl = m_cyl / V(t) (eq 4.6), so
    df/dt = df/dm_cyl * (-m_cyl V'/V) needs no call at all. Returns -1 (plain forward
    differences) when the flow force is on.
    """
    if p[OFF_IN + V_FLOW] > 0.5 or p[OFF_DEL + V_FLOW] > 0.5 or n_dyn != 5:
        return -1
    n = y.shape[0]
    sq = 1.4901161193847656e-08
    for j in range(n):
        for i in range(n):
            jac[i, j] = 0.0
    # m_cyl
    yp[:] = y
    yp[0] = y[0] + sq * max(abs(y[0]), atol[0] / rtol)
    d = yp[0] - y[0]
    _rhs(t, yp, p, fp)
    for i in range(n):
        jac[i, 0] = (fp[i] - f0[i]) / d
    # (x_in, x_del) together, then (u_in, u_del)
    for a in (1, 2):
        b = a + 2
        yp[:] = y
        yp[a] = y[a] + sq * max(abs(y[a]), atol[a] / rtol)
        yp[b] = y[b] + sq * max(abs(y[b]), atol[b] / rtol)
        da = yp[a] - y[a]
        db = yp[b] - y[b]
        _rhs(t, yp, p, fp)
        jac[1, a] = (fp[1] - f0[1]) / da
        jac[2, a] = (fp[2] - f0[2]) / da
        jac[5, a] = (fp[5] - f0[5]) / da
        jac[0, a] = jac[5, a]
        jac[3, b] = (fp[3] - f0[3]) / db
        jac[4, b] = (fp[4] - f0[4]) / db
        jac[6, b] = (fp[6] - f0[6]) / db
        jac[0, b] = -jac[6, b]
    vol, dvol = _cylinder_volume(p[G_OMEGA] * t, p[G_OMEGA], p[G_AP], p[G_CRANK], p[G_ROD], p[G_VTDC])
    dm_dt = -y[0] * dvol / vol        # the m_cyl change with the same effect on rho_cyl as dt
    for i in range(n):
        ft[i] = jac[i, 0] * dm_dt
    return 3


@numba.njit
def _tolerances(p, atol):
    """Velocity tolerance by contact state: tight while a valve touches its seat or stop (it
    decides when a grazing valve lets go), looser in free flight."""
    for v in range(2):
        c = int(p[MODE + 2 * v])
        atol[2 + 2 * v] = p[ATOL_U] if c != FREE else p[ATOL_U + 1]


@numba.njit
def _tag(p):
    return int(p[MODE]) + 3 * int(p[MODE + 1]) + 9 * int(p[MODE + 2]) + 27 * int(p[MODE + 3])


@numba.njit
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
                           tolerances=_tolerances)


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
    _solver(0.0, y, np.array([1e-9]), p, 1e-6, np.full(ref.N_SIMPLIFIED, 1e-9), 1e-10, np.inf, 100,
            N_DYN, 0.0, N_EVENTS, 100, 1)
    _COMPILE["seconds"] = _time.perf_counter() - t0


def _extended(p: np.ndarray, mode, atol_u=(1e-9, 1e-9)) -> np.ndarray:
    q = np.zeros(NP + 6)
    q[:NP] = p[:NP]
    q[MODE:MODE + 4] = mode
    q[ATOL_U:ATOL_U + 2] = atol_u
    return q


def _decode(ev_t, ev_code) -> list[tuple[float, int, int, int]]:
    """Event log as lumped.pump's (time, slot, old, new) tuples."""
    return [(float(t), int(c) // 100, (int(c) // 10) % 10, int(c) % 10) for t, c in zip(ev_t, ev_code)]


def _peaks(rec_y, rec_q2, rec_q3) -> tuple[float, float]:
    """Largest inlet and delivery openings [m] in the recorded steps, interpolant included."""
    best = [0.0, 0.0]
    for j, xi in enumerate((ref.S_XIN, ref.S_XDEL)):
        y0, y1 = rec_y[:-1, xi], rec_y[1:, xi]
        q2, q3 = rec_q2[1:, xi], rec_q3[1:, xi]
        vals = [rec_y[:, xi]]
        for s in (0.25, 0.5, 0.75):
            vals.append(y0 * (1 - s) + s * (y1 + (1 - s) * (q2 + s * q3)))
        best[j] = max(0.0, float(max(v.max() for v in vals)))
    return best[0], best[1]


# ----------------------------------------------------------------- simulate
def simulate(valve: str, speed_rpm: float, load_pressure: float, *, air_content: float | None = None,
             revolutions: int = 5, circuit: str = "simplified", params: PumpModel | None = None,
             rtol: float = RTOL, atol: float = ATOL, trace: bool = False, progress: bool = False,
             max_revolutions: int | None = None, steady_tol: float = 1e-4, trace_revolutions: int = 1,
             trace_points: int = 2000, method: str = "fast") -> ref.PumpResult:
    """:func:`lumped.pump.simulate` on the compiled Rodas4P path (same arguments, same result).

    Tolerances have the reference's meaning (atol in units of each state's scale; a valve's
    velocity in free flight gets FREE_VELOCITY_ATOL times atol); the defaults (rtol 1e-4,
    atol 1e-5) keep the delivery within 0.003 % and the valve timing within 0.5 deg of
    the reference at its defaults (tests/test_pump_fast.py). ``method`` is "fast"; the circuit
    "complete" runs the reference integrator (Radau) instead.
    """
    if circuit == "complete":
        return ref.simulate(valve, speed_rpm, load_pressure, air_content=air_content,
                            revolutions=revolutions, circuit=circuit, params=params, rtol=rtol, atol=atol,
                            trace=trace, progress=progress, max_revolutions=max_revolutions,
                            steady_tol=steady_tol, trace_revolutions=trace_revolutions,
                            trace_points=trace_points)
    ref._check_inputs(valve, speed_rpm, load_pressure, air_content, revolutions, circuit, rtol, atol,
                      max_revolutions, trace_revolutions, "Radau")
    if method != "fast":
        raise InputError("method", f"the fast path has one method, 'fast'; got {method!r}")
    _ensure_compiled()
    cpu0 = _time.process_time()
    model = params if params is not None else thesis_model(valve)
    if params is not None and params.valve != valve:
        raise InputError("params", f"describes {params.valve} valves, not {valve}")
    if air_content is not None:
        model = replace(model, oil=replace(model.oil, air_content=float(air_content)))
    validate_model(model)
    speed_rpm = float(speed_rpm)
    load_pressure = float(load_pressure)

    n = ref.N_SIMPLIFIED
    p0 = pack(model, speed_rpm, load_pressure, circuit)
    y = ref._initial_state(model, p0, n)
    atol_v = ref._atol_vector(n, atol, p0, model)
    p = _extended(p0, ref.auto_mode(y, p0), (atol_v[ref.S_UIN], atol_v[ref.S_UIN] * FREE_VELOCITY_ATOL))
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
            steady = change < steady_tol
        last = dict(events=_decode(ev_t, ev_code), mass_err=mass_err, t0=t0,
                    peak=_peaks(rec_y, rec_q2, rec_q3), leak=d_leak / rho0)
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
        peak_opening=tuple(last["peak"]), opening_angle=opening, closing_angle=closing,
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
