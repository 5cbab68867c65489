"""The one layout module: where every state, mode entry, switching function, event and packed
quantity of the pump lives, generated from declarations.

``numba`` compiles functions of floats and arrays, not of dataclasses, so a resolved
:class:`~lumped.model.pump_model.PumpModel` and an operating point are packed into one float64 array
(:func:`pack`): the global block (:data:`G`: the operating point, derived pump quantities,
the bookkeeping of the state layout, the stepper's mode, tolerance table and stash, and every
Pump/Oil/Circuit field declared ``packed=True``), one block per valve (its kind's block:
:data:`lumped.valves.common.COMMON`, the kind's packed fields, its derived quantities), then the
valves' variable-length data (a modal reed's modes).

The state vector (:class:`StateLayout`) is declared, not numbered: the pump's states
(:data:`PUMP_STATES`), each valve's ``dofs`` positions then ``dofs`` rates (one DOF: the
opening x and its rate u), the load-line mass, then the running totals
(:data:`QUADRATURES`, which never feed back: the integrator solves its linear systems on
the states before them). The mode (contact state and pressure regime of each valve, the
cylinder's state) and the switching functions (seat, stop, regime of each valve; the
cylinder) are generated from :data:`VALVE_MODE`, :data:`PUMP_MODE`, :data:`VALVE_SWITCHES`
and :data:`PUMP_SWITCHES`; an event is a named record (:class:`Event`). Every other module
reads positions through the names and functions here: no index arithmetic elsewhere.
"""

from __future__ import annotations

import collections
import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from geometry.declare import specs
from lumped.fluid.oil import Oil
from lumped.model.pump import Circuit, Pump
from lumped.valves.kind import (
    BLOCK_SIZE, CONTACT_NAMES, FREE, REGIME_NAMES, VALVE, kind_of, valve_acceleration, valve_accelerations,
)

#: the valve positions, in the order of their blocks, states, mode entries and switches
POSITIONS = ("inlet", "delivery")
N_VALVES = len(POSITIONS)
#: per position: the volumes upstream and downstream of the valve (its pressure difference is up - down) and
#: the suffix of its fields in lumped.solver.rhs.Rates (x_in, mdot_del, ...)
PORTS = {"inlet": ("tank", "cylinder"), "delivery": ("cylinder", "load")}
RATES_TAG = {"inlet": "in", "delivery": "del"}

# ----------------------------------------------------------------- states (declared by name)
#: the pump's own states, first: the cylinder oil mass m_cyl [kg] (eq 4.5)
PUMP_STATES = ("m_cyl",)
#: after the valves: the oil mass in the load line and accumulator [kg] (complete circuit; constant otherwise)
LOAD_STATES = ("m_load",)
#: running totals [kg] through the inlet valve, delivery valve, piston clearance and needle valve
QUADRATURES = ("m_in", "m_out", "m_leak", "m_nv")
S_MCYL = PUMP_STATES.index("m_cyl")

# ----------------------------------------------------------------- mode and switching functions
#: per valve, the entries of the mode vector: contact SEAT/FREE/STOP; regime POISEUILLE/ORIFICE
VALVE_MODE = ("contact", "regime")
#: the pump's mode entries: the cylinder LIQUID/CAVITATING
PUMP_MODE = ("cavitation",)
#: per valve, its switching functions: seat and stop contact, the flow regime
VALVE_SWITCHES = ("seat", "stop", "regime")
#: the pump's switching functions
PUMP_SWITCHES = ("cavitation",)
LIQUID, CAVITATING = 0, 1
CAVITATION_NAMES = ("liquid", "cavitating")


def _slots(per_valve: tuple, pump: tuple, tag: str):
    names = [f"{pos}_{n}" for pos in POSITIONS for n in per_valve] + list(pump)
    return collections.namedtuple(tag, names)(*range(len(names)))


#: mode slots by name: MODE.inlet_contact, MODE.delivery_regime, MODE.cavitation
MODE = _slots(VALVE_MODE, PUMP_MODE, "ModeSlots")
N_MODE = len(MODE)
#: switching functions by name: SWITCH.inlet_seat, ..., SWITCH.cavitation
SWITCH = _slots(VALVE_SWITCHES, PUMP_SWITCHES, "SwitchSlots")
N_SWITCHES = len(SWITCH)
#: per valve number v: its mode slots and switching functions (tuples numba indexes at run time)
CONTACT_SLOT = tuple(getattr(MODE, f"{pos}_contact") for pos in POSITIONS)
REGIME_SLOT = tuple(getattr(MODE, f"{pos}_regime") for pos in POSITIONS)
SEAT_SWITCH = tuple(getattr(SWITCH, f"{pos}_seat") for pos in POSITIONS)
STOP_SWITCH = tuple(getattr(SWITCH, f"{pos}_stop") for pos in POSITIONS)
REGIME_SWITCH = tuple(getattr(SWITCH, f"{pos}_regime") for pos in POSITIONS)
#: which valve a switching function belongs to (-1: the cylinder) and what it switches
SWITCH_VALVE = tuple(POSITIONS.index(n.split("_")[0]) if "_" in n else -1 for n in SWITCH._fields)
SWITCH_WHAT = tuple(n.split("_")[-1] for n in SWITCH._fields)
CAVITATION_SWITCH = SWITCH.cavitation
CAVITATION_SLOT = MODE.cavitation
#: mode value names per slot (events, reports)
_SLOT_VALUES = {"contact": CONTACT_NAMES, "regime": REGIME_NAMES, "cavitation": CAVITATION_NAMES}


# ----------------------------------------------------------------- events
class Event(NamedTuple):
    """One mode change at time ``t`` [s]: ``where`` a position or "cylinder", ``what`` "contact",
    "regime" or "cavitation", ``old``/``new`` the state names ("seat", "free", "stop";
    "poiseuille", "orifice"; "liquid", "cavitating")."""

    t: float
    where: str
    what: str
    old: str
    new: str


#: event codes of the compiled stepper: an integer per (mode slot, old, new), below EVENT_CODES
_VALUES_PER_SLOT = 3
EVENT_CODES = N_MODE * _VALUES_PER_SLOT * _VALUES_PER_SLOT


def event_code(slot: int, old: int, new: int) -> int:
    """The integer of a mode change (the compiled stepper keeps a first step per code)."""
    return (slot * _VALUES_PER_SLOT + old) * _VALUES_PER_SLOT + new


def decode(code: int) -> tuple[int, int, int]:
    """(mode slot, old, new) of an :func:`event_code`."""
    return code // (_VALUES_PER_SLOT * _VALUES_PER_SLOT), (code // _VALUES_PER_SLOT) % _VALUES_PER_SLOT, \
        code % _VALUES_PER_SLOT


def event(t: float, code: int) -> Event:
    """The named record of an event code at time t."""
    slot, old, new = decode(code)
    name = MODE._fields[slot]
    where, what = (name.split("_") if "_" in name else ("cylinder", name))
    values = _SLOT_VALUES[what]
    return Event(float(t), where, what, values[old], values[new])


# ----------------------------------------------------------------- the global block of the flat array
#: stepper bookkeeping kept in the global block: the mode, the tolerance table (atol of a valve's
#: positions and rates in each contact state) and a stash of (t, m_cyl, P_cyl) of the last rhs call
N_TOL = N_VALVES * len(CONTACT_NAMES) * 2
_DERIVED = ("omega", "load_pressure", "piston_area", "leak", "complete", "needle_cda", "rho_vapour", "rho_tank",
            "rho_load", "pressure_start", "n_states", "s_mload", "s_min", "s_mout", "s_mleak", "s_mnv",
            "stash_t", "stash_m", "stash_p")
_RESERVED = tuple(f"mode_{i}" for i in range(N_MODE)) + tuple(f"tol_{i}" for i in range(N_TOL))


def _global_block():
    """Offsets of the pump-wide quantities: the derived ones and the bookkeeping, then the packed
    fields of Pump, Oil and Circuit (by field name)."""
    packed = [n for cls in (Pump, Oil, Circuit) for n, s in specs(cls) if s.packed]
    names = _DERIVED + _RESERVED + tuple(packed)
    assert len(set(names)) == len(names), names
    return collections.namedtuple("GlobalBlock", names)(*range(len(names)))


#: the global block's named slots in the packed parameters (the operating point, derived pump quantities)
G = _global_block()
NG = 96                                   # length of the global block
assert len(G) <= NG
#: the first entry of the mode and of the tolerance table in the global block
MODE_AT = G.mode_0
TOL_AT = G.tol_0
#: block offset of each valve (by valve number), and by name
BLOCK_OFFSET = tuple(NG + v * BLOCK_SIZE for v in range(N_VALVES))
OFF_IN, OFF_DEL = BLOCK_OFFSET
NP = NG + N_VALVES * BLOCK_SIZE           # length of the fixed part of the packed array


def mode_of(p):
    """The mode stored in the packed array (a view: the compiled stepper switches it in place)."""
    return p[MODE_AT:MODE_AT + N_MODE]


def tol_slot(v: int, contact: int) -> int:
    """Index in the packed array of the position tolerance of valve v in a contact state (the rate's follows)."""
    return TOL_AT + (v * len(CONTACT_NAMES) + contact) * 2


def mode_tag(mode) -> int:
    """The mode as one integer (base 3), recorded per step by the compiled stepper."""
    t = 0
    for i in range(N_MODE):
        t = t * 3 + int(mode[N_MODE - 1 - i])
    return t


# ----------------------------------------------------------------- per-valve states (compiled code)
#: helpers the compiled physics inlines (lumped.solver.compiled): a few loads each, called in every rhs
INLINE = ("mode_of", "state_start", "dofs", "is_scalar", "opening", "opening_weight", "valve_rates", "accel_index",
          "position_index", "load_index", "n_states", "quadrature_indices", "set_opening", "limit_rate",
          "write_rates")
#: True in the one-DOF flavour of the compiled physics (lumped.solver.compiled.physics(one_dof=True)), for pumps
#: whose valves have one DOF each: numba folds the constant, so the several-DOF paths (their loops and
#: calls) are not compiled into the hot path
ONE_DOF_ONLY = False
#: True in the compiled physics (lumped.solver.compiled): loops there; numpy in the Python reference, where an FE
#: reed's ~100 states would make element-wise Python loops a large share of a reference run. The loop form
#: comes first, under ``if COMPILED:``: with the numpy form first, under ``if not COMPILED:``, the compiled
#: stepper failed at its first step (numba 0.68; not chased further)
COMPILED = False


def state_start(p, o: int) -> int:
    """Index of the first state (position) of the valve at block offset o (in the one-DOF flavour a
    constant of the one-DOF layout: numba folds it where o is one)."""
    if ONE_DOF_ONLY:
        return ONE_DOF_STARTS[(o - NG) // BLOCK_SIZE]
    return int(p[o + VALVE.state_start])


def dofs(p, o: int) -> int:
    """Mechanical degrees of freedom of the valve at block offset o."""
    if ONE_DOF_ONLY:
        return 1
    return int(p[o + VALVE.dofs])


def is_scalar(p, o: int) -> bool:
    """Whether the valve at block offset o is a scalar one: its opening x and rate u are its two states and
    its kind's ``acceleration`` moves it (a valve with a tail, e.g. a modal reed even of one mode, has its
    kind's ``accelerations`` and its opening weighted from its states)."""
    if ONE_DOF_ONLY:
        return True
    return p[o + VALVE.tail] == 0.0


def opening(y, p, o: int) -> tuple[float, float]:
    """(x, u): the valve's opening [m] and its rate [m/s] from its states (one DOF: the states
    themselves; several: the opening weights its kind packed at the start of its tail)."""
    s = state_start(p, o)
    if is_scalar(p, o):
        return y[s], y[s + 1]
    return multi_opening(y, p, o, s, dofs(p, o))


def multi_opening(y, p, o: int, s: int, n: int) -> tuple[float, float]:
    """:func:`opening` of a valve with n > 1 DOFs: its positions and rates weighted."""
    w = int(p[o + VALVE.tail])
    if COMPILED:
        x = 0.0
        u = 0.0
        for j in range(n):
            x += p[w + j] * y[s + j]
            u += p[w + j] * y[s + n + j]
        return x, u
    e = np.asarray(p[w:w + n])
    return float(e @ np.asarray(y[s:s + n])), float(e @ np.asarray(y[s + n:s + 2 * n]))


def opening_weight(p, o: int, j: int) -> float:
    """dx/dq_j: the weight of the valve's j-th position in its opening (1 for a one-DOF valve)."""
    if is_scalar(p, o):
        return 1.0
    return p[int(p[o + VALVE.tail]) + j]


def set_opening(y, p, o: int, level: float) -> None:
    """Put the valve's opening exactly at ``level`` [m] (one DOF: the state itself; several: along
    the opening weights, the least change of the positions)."""
    s = state_start(p, o)
    if is_scalar(p, o):
        y[s] = level
        return
    multi_set_opening(y, p, o, s, dofs(p, o), level)


def multi_set_opening(y, p, o: int, s: int, n: int, level: float) -> None:
    """:func:`set_opening` of a valve with n > 1 DOFs."""
    w = int(p[o + VALVE.tail])
    x = 0.0
    ww = 0.0
    for j in range(n):
        x += p[w + j] * y[s + j]
        ww += p[w + j] * p[w + j]
    for j in range(n):
        y[s + j] += (level - x) * p[w + j] / ww


def limit_rate(y, p, o: int, sign: float) -> None:
    """Make the valve's opening rate u no smaller (sign > 0) or no larger (sign < 0) than 0 (a valve
    leaving a contact does not move into it)."""
    s = state_start(p, o)
    if is_scalar(p, o):
        y[s + 1] = max(y[s + 1], 0.0) if sign > 0 else min(y[s + 1], 0.0)
        return
    multi_limit_rate(y, p, o, s, dofs(p, o), sign)


def multi_limit_rate(y, p, o: int, s: int, n: int, sign: float) -> None:
    """:func:`limit_rate` of a valve with n > 1 DOFs."""
    w = int(p[o + VALVE.tail])
    u = 0.0
    ww = 0.0
    for j in range(n):
        u += p[w + j] * y[s + n + j]
        ww += p[w + j] * p[w + j]
    if u * sign < 0.0:
        for j in range(n):
            y[s + n + j] -= u * p[w + j] / ww


def position_index(p, o: int, j: int) -> int:
    """Index of the valve's j-th position."""
    return state_start(p, o) + j


def valve_rates(y, x: float, u: float, f, p, o: int, contact: int, regime: int, dydt) -> float:
    """The acceleration of the valve's opening d^2x/dt^2 [m/s^2] (its kind's, lumped.valves.kind); a valve of
    several DOFs writes its state derivatives into dydt here, one of one DOF in :func:`write_rates`
    (after the other valve's: the stores would make the compiled code reload the packed parameters)."""
    if is_scalar(p, o):
        return valve_acceleration(x, u, f, p, o, contact, regime)
    return multi_rates(y, x, u, f, p, o, contact, regime, dydt, state_start(p, o), dofs(p, o))


def write_rates(dydt, p, o: int, u: float, a: float) -> None:
    """d(x)/dt = u, du/dt = a of a one-DOF valve (a several-DOF valve has written its own)."""
    if is_scalar(p, o):
        s = state_start(p, o)
        dydt[s] = u
        dydt[s + 1] = a


def multi_rates(y, x: float, u: float, f, p, o: int, contact: int, regime: int, dydt, s: int, n: int) -> float:
    """:func:`valve_rates` of a valve with n > 1 DOFs."""
    w = int(p[o + VALVE.tail])
    if COMPILED:
        for j in range(n):
            dydt[s + j] = y[s + n + j]
        valve_accelerations(y, s, n, x, u, f, p, o, contact, regime, dydt)
        a = 0.0
        for j in range(n):
            a += p[w + j] * dydt[s + n + j]
        return a
    dydt[s:s + n] = y[s + n:s + 2 * n]
    valve_accelerations(y, s, n, x, u, f, p, o, contact, regime, dydt)
    return float(np.asarray(p[w:w + n]) @ np.asarray(dydt[s + n:s + 2 * n]))


def accel_index(p, o: int, j: int) -> int:
    """Index of the rate of the valve's j-th DOF (where its acceleration is written)."""
    return state_start(p, o) + dofs(p, o) + j


def valve_tolerances(p, mode, atol) -> None:
    """Each valve's absolute tolerances (positions, rates) from the table in p for its contact state; a
    valve of several DOFs on the fast path has its opening first (a modal reed: lumped.reed.structure.coordinates):
    a contact holds that one, so the other positions keep the free flight's tolerance."""
    for v in range(N_VALVES):
        o = BLOCK_OFFSET[v]
        i = tol_slot(v, int(mode[CONTACT_SLOT[v]]))
        free = tol_slot(v, FREE)
        for j in range(dofs(p, o)):
            atol[position_index(p, o, j)] = p[i if j == 0 else free]
            atol[accel_index(p, o, j)] = p[i + 1]


def load_index(p) -> int:
    """Index of the load-line mass."""
    if ONE_DOF_ONLY:
        return ONE_DOF_LOAD
    return int(p[G.s_mload])


def n_states(p) -> int:
    """Length of the state vector."""
    if ONE_DOF_ONLY:
        return ONE_DOF_N
    return int(p[G.n_states])


def quadrature_indices(p) -> tuple[int, int, int, int]:
    """Indices of the running totals (m_in, m_out, m_leak, m_nv)."""
    if ONE_DOF_ONLY:
        return ONE_DOF_QUADRATURES
    return int(p[G.s_min]), int(p[G.s_mout]), int(p[G.s_mleak]), int(p[G.s_mnv])


# ----------------------------------------------------------------- the state layout (Python side)
@dataclass(frozen=True)
class StateLayout:
    """The state vector of one pump: the pump's states, each valve's ``dofs`` positions and rates,
    the load line, the running totals; ``complete``: the load line is a state that moves."""

    dofs: tuple[int, ...]
    complete: bool = False
    scalar: tuple[bool, ...] | None = None     # per valve: opening and rate are its states (None: dofs == 1)

    @property
    def scalars(self) -> tuple[bool, ...]:
        return tuple(n == 1 for n in self.dofs) if self.scalar is None else self.scalar

    @property
    def names(self) -> tuple[str, ...]:
        return _state_names(self.dofs, self.scalars)

    def index(self, name: str) -> int:
        return _state_index(self.dofs, self.scalars)[name]

    @property
    def one_dof(self) -> bool:
        """Every valve is a scalar one (the compiled physics has a flavour for that: lumped.solver.compiled)."""
        return all(self.scalars)

    @property
    def n_states(self) -> int:
        return len(PUMP_STATES) + 2 * sum(self.dofs) + len(LOAD_STATES) + len(QUADRATURES)

    @property
    def n_dyn(self) -> int:
        """States that feed back (the integrator's linear systems): up to the load line when it moves."""
        return len(PUMP_STATES) + 2 * sum(self.dofs) + (len(LOAD_STATES) if self.complete else 0)

    def valve_start(self, v: int) -> int:
        return len(PUMP_STATES) + 2 * sum(self.dofs[:v])

    def positions(self, v: int) -> slice:
        s = self.valve_start(v)
        return slice(s, s + self.dofs[v])

    def rates(self, v: int) -> slice:
        s = self.valve_start(v) + self.dofs[v]
        return slice(s, s + self.dofs[v])

    @property
    def quadratures(self) -> dict:
        return {n: self.index(n) for n in QUADRATURES}

    def write(self, p: np.ndarray) -> None:
        """Record the layout in the packed array (what the compiled code reads)."""
        p[G.n_states] = self.n_states
        for n in LOAD_STATES + QUADRATURES:
            p[getattr(G, "s_" + n.replace("_", ""))] = self.index(n)
        for v, o in enumerate(BLOCK_OFFSET):
            p[o + VALVE.dofs] = self.dofs[v]
            p[o + VALVE.state_start] = self.valve_start(v)

    # ---- arrays of states (rows: samples) -> per-valve signals
    def openings(self, ys: np.ndarray, p: np.ndarray, v: int) -> tuple[np.ndarray, np.ndarray]:
        """(x, u) of valve v [m, m/s] for states ys (rows: samples)."""
        pos, rate = ys[:, self.positions(v)], ys[:, self.rates(v)]
        if self.scalars[v]:
            return pos[:, 0], rate[:, 0]
        o = BLOCK_OFFSET[v]
        w = p[int(p[o + VALVE.tail]):int(p[o + VALVE.tail]) + self.dofs[v]]
        return pos @ w, rate @ w

    def scales(self, p: np.ndarray, m_rev: float) -> np.ndarray:
        """Characteristic scale of each state: mass per revolution; a valve's stop gap and 1 m/s."""
        sc = np.ones(self.n_states)
        sc[S_MCYL] = m_rev
        for v, o in enumerate(BLOCK_OFFSET):
            sc[self.positions(v)] = p[o + VALVE.stop_gap]
            sc[self.rates(v)] = 1.0
        sc[self.index(LOAD_STATES[0])] = m_rev
        for q in QUADRATURES:
            sc[self.index(q)] = m_rev
        return sc


@functools.lru_cache(maxsize=None)
def _state_names(dofs: tuple, scalars: tuple) -> tuple[str, ...]:
    out = list(PUMP_STATES)
    for pos, n, scalar in zip(POSITIONS, dofs, scalars):
        if scalar:
            out += [f"{pos}.x", f"{pos}.u"]
        else:
            out += [f"{pos}.q{j + 1}" for j in range(n)] + [f"{pos}.qdot{j + 1}" for j in range(n)]
    return tuple(out) + LOAD_STATES + QUADRATURES


@functools.lru_cache(maxsize=None)
def _state_index(dofs: tuple, scalars: tuple) -> dict:
    return {n: i for i, n in enumerate(_state_names(dofs, scalars))}


#: the layout of a pump whose valves have one DOF each: the constants of the one-DOF flavour of the
#: compiled physics (ONE_DOF_ONLY)
ONE_DOF = StateLayout((1,) * N_VALVES)
ONE_DOF_STARTS = tuple(ONE_DOF.valve_start(v) for v in range(N_VALVES))
ONE_DOF_LOAD = ONE_DOF.index(LOAD_STATES[0])
ONE_DOF_N = ONE_DOF.n_states
ONE_DOF_QUADRATURES = tuple(ONE_DOF.index(q) for q in QUADRATURES)


def layout_of(model, complete: bool) -> StateLayout:
    """The state layout of a resolved model (each valve's DOFs from its parameters)."""
    valves = [model.valve(pos) for pos in POSITIONS]
    return StateLayout(tuple(v.dofs() for v in valves), complete, tuple(not v.several() for v in valves))


# ----------------------------------------------------------------- packing
def _number(v) -> float:
    return (1.0 if v else 0.0) if isinstance(v, bool) else float(v)


@functools.lru_cache(maxsize=None)
def _block_items(block) -> tuple:
    """(name, offset) of a kind's block but the layout's bookkeeping (written by StateLayout.write)."""
    return tuple((n, i) for n, i in block._asdict().items() if n not in ("dofs", "state_start", "tail"))


@functools.lru_cache(maxsize=None)
def _packed_fields(cls) -> tuple:
    """(field name, index in the packed array) of a component class's packed fields."""
    return tuple((n, getattr(G, n)) for n, s in specs(cls) if s.packed)


def pack_valve(valve, oil, out: np.ndarray, offset: int) -> np.ndarray | None:
    """Write a valve's block (COMMON, packed fields, derived quantities) at ``offset``; returns its
    variable-length data (or None), which :func:`pack` appends."""
    try:
        idx, vals, tail = _valve_block(valve, oil)     # a sweep packs the same valve and oil again and again
    except TypeError:                                # an unhashable valve (a plug-in kind): packed afresh
        idx, vals, tail = _valve_block.__wrapped__(valve, oil)
    out[offset + idx] = vals
    return None if tail is None else tail.copy()


@functools.lru_cache(maxsize=256)
def _valve_block(valve, oil) -> tuple:
    """(offsets, values, tail) of a valve's block: a pure function of the (frozen) valve and oil."""
    kind = kind_of(valve)
    values = valve.common(oil).packed()
    values.update(valve.packed_extra(oil))
    values["kind_id"] = float(kind.id)
    values["orifice_start"] = 0.0          # scratch of the orifice solve, not a parameter
    idx, vals = [], []
    for name, i in _block_items(kind.block):
        if name in values:
            v = _number(values[name])
        elif getattr(valve, name, None) is not None:
            v = _number(getattr(valve, name))
        else:
            raise KeyError(f"{type(valve).__name__} gives no {name!r} (a {'common' if name in VALVE._fields else 'derived'} "
                           "packed quantity)")
        idx.append(i)
        vals.append(v)
    tail = valve.tail(oil)
    return np.array(idx, dtype=int), np.array(vals), None if tail is None else np.asarray(tail, dtype=float)


def pack(model, speed_rpm: float, load_pressure: float, circuit: str | None = None,
         needle_area: float | None = None) -> np.ndarray:
    """Flat float64 parameter array of the right-hand side (``lumped.solver.rhs.evaluate``).

    ``model`` is resolved first (its effects applied). ``circuit`` overrides the model's
    circuit kind; ``needle_area`` its needle valve area (complete circuit; None and no
    area in the model: 0, the driver tunes it).
    """
    from lumped.model.effect_library import resolve   # the model layer sits above the layout

    m = resolve(model)
    p = np.zeros(NP)
    pump, oil, circ = m.pump, m.oil, m.circuit
    for comp in (pump, oil, circ):
        for n, i in _packed_fields(type(comp)):
            p[i] = _number(getattr(comp, n))
    p[G.omega] = speed_rpm * 2.0 * math.pi / 60.0
    p[G.load_pressure] = load_pressure
    p[G.piston_area] = pump.piston_area
    p[G.leak] = pump.leakage_coefficient(oil.viscosity)
    complete = (circuit or circ.kind) == "complete"
    p[G.complete] = 1.0 if complete else 0.0
    area = circ.needle_area if needle_area is None else needle_area
    p[G.needle_cda] = 0.0 if area is None else circ.needle_discharge * area
    # liquid density at the vapour pressure: the cylinder cavitates below it (0: never, the air
    # of eq 4.11 expands without bound as P -> 0)
    cavitates = oil.vapour_pressure > 0.0 or oil.air_content <= 0.0
    p[G.rho_vapour] = oil.density_at(oil.vapour_pressure) if cavitates else 0.0
    p[G.rho_tank] = oil.density_at(pump.tank_pressure)       # constant: packed, not recomputed per call
    p[G.rho_load] = oil.density_at(load_pressure)
    p[G.pressure_start] = 0.0           # scratch of the cylinder pressure inversion, not a parameter
    tails = []
    for pos, o in zip(POSITIONS, BLOCK_OFFSET):
        tail = pack_valve(m.valve(pos), oil, p, o)
        if tail is not None and len(tail):
            p[o + VALVE.tail] = NP + sum(len(t) for t in tails)
            tails.append(np.asarray(tail, dtype=float))
    layout_of(m, complete).write(p)
    return np.concatenate([p] + tails) if tails else p
