"""Check-valve kinds: the registry, and the physics every kind shares (contact, flow).

A valve *kind* (disc, reed, ...) is one :class:`ValveKind` entry, registered by the
module that implements it (``lumped/disc_valve.py``, ``lumped/reed_valve.py``). The entry
owns the kind's parameter class (a frozen dataclass whose fields are declared with
:func:`geometry.declare.param`), its acceleration function, its regime rule and its
contact tolerance; the pump, the fast path, the effects and the command line find
kinds here instead of branching on names. Adding a kind: a module like
``lumped/disc_valve.py`` (class, physics, :func:`register`), its import in
``lumped/__init__.py``, and a shipped model file that uses it (docs/extending.md).

Every kind packs the :data:`COMMON` quantities first in its block of the flat
parameter array (``lumped.layout``), so the shared functions below (contact forces,
displacement area, orifice flow) and the pump read any kind alike. Functions here use
floats and the flat array only, so ``numba.njit`` compiles them unchanged.

Contact state ``contact``: 0 seat (x < 0 side), 1 free, 2 stop (x > x_stop side),
-1 decide from x. The pump integrator fixes it per step and switches it only at a
located crossing (``lumped.switching``), so the right-hand side is smooth in a step.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass
from typing import Callable

from lumped.orifice import orifice_flow

#: quantities every kind packs first, at these offsets of its block (lumped.layout)
COMMON = (
    "kind_id",         # registry id of the kind
    "moving_mass",     # kg (disc) or kg/m^2 (reed: per unit area, eq 3.21)
    "stop_gap",        # x_stop [m]
    "seat_k",          # seat contact stiffness, N/m or Pa/m
    "seat_c",          # seat contact damping, N s/m or Pa s/m
    "stop_k",          # stop contact stiffness
    "stop_c",          # stop contact damping
    "area_1",          # A_1 of the displacement area (eqs 2.42, 3.26) [m^2]
    "area_2",          # A_2 [m^2]
    "f_closing",       # f1 (u < 0)
    "f_opening",       # f2 (u > 0)
    "cd_inf",          # Cd(Re) correlation (eqs 2.47, 3.89)
    "cd_a",
    "cd_b",
    "cd_c",
    "perimeter",       # orifice perimeter of the Reynolds number [m]
    "average_density",  # 1: orifice density is the mean of both sides (section 4.3.5), 0: cylinder's
    "area_per_opening",  # A_o / x [m]
    "regime_opening",  # x of a pressure-regime switch (eq 2.18) [m]; <= 0: none
    "contact_area",    # area turning the contact force into a pressure load (disc face; reed 1)
    "flow_in_acceleration",  # 1 if the kind's acceleration reads the flow arguments (flow forces), else 0
    "orifice_start",   # scratch, not a parameter: sqrt(Re) of the last orifice solve (warm start)
)
#: the offsets, as a namedtuple numba folds into constants: p[o + VALVE.stop_gap]
VALVE = collections.namedtuple("ValveBlock", COMMON)(*range(len(COMMON)))

SEAT, FREE, STOP = 0, 1, 2
POISEUILLE, ORIFICE = 0, 1


# --------------------------------------------------------------------------- registry
@dataclass(frozen=True)
class ValveKind:
    """One valve kind (see the module docstring).

    ``params``: the parameter class (``position`` field, declared parameters, a
    ``load(table, where, position)`` classmethod and a ``derived(oil)`` method giving the
    packed quantities that are not plain fields); ``acceleration``: du/dt with the
    signature of :func:`lumped.disc_valve.disc_acceleration` (numba-compilable);
    ``block``: the offsets of its packed quantities (:func:`kind_block`); ``default_model``:
    the shipped model whose valves give the keys a model file leaves out for this kind;
    ``contact_position_atol``: the fast path's opening tolerance in contact, in units of atol
    x the contact deflection (lumped.steppers.tolerance_table; how closely the integrator
    follows the deflection decides when the valve lets go);
    ``free_velocity_atol``: the fast path's velocity tolerance in free flight, in units of
    atol x 1 m/s (the velocity of a free element hardly matters to the delivery);
    ``contact_velocity_atol``: the fast path's velocity tolerance in contact, in units of
    atol x 1 m/s (how still the valve sits on its seat decides when it lets go);
    ``flow_area_unit``: "N" if the contact force is a force (disc) or "Pa" (per unit area).
    """

    name: str
    params: type
    acceleration: Callable
    block: tuple
    default_model: str = ""
    contact_velocity_atol: float = 1.0
    contact_position_atol: float = 30.0
    free_velocity_atol: float = 100.0
    summary: str = ""
    id: int = -1


KINDS: dict[str, ValveKind] = {}
#: length of every valve block of the flat parameter array (a kind may use up to this many)
BLOCK_SIZE = 64


def kind_block(params: type, derived: tuple = ()) -> tuple:
    """Offsets of a kind's packed quantities: :data:`COMMON`, then every field declared
    ``packed=True`` (by field name), then the kind's ``derived`` quantities; a namedtuple
    that numba folds into constants (``p[o + DISC.spring_stiffness]``)."""
    from geometry.declare import specs

    own = [n for n, s in specs(params) if s.packed] + list(derived)
    names = COMMON + tuple(own)
    if len(set(names)) != len(names):
        raise ValueError(f"{params.__name__}: a packed name repeats a common one")
    if len(names) > BLOCK_SIZE:
        raise ValueError(f"{params.__name__}: {len(names)} packed quantities exceed BLOCK_SIZE = {BLOCK_SIZE}")
    return collections.namedtuple(f"{params.__name__}Block", names)(*range(len(names)))


def register(kind: ValveKind) -> ValveKind:
    """Add a kind to the registry (its id is its registration order)."""
    if kind.name in KINDS:
        raise ValueError(f"valve kind {kind.name!r} is registered twice")
    from dataclasses import replace

    kind = replace(kind, id=len(KINDS))
    KINDS[kind.name] = kind
    _build_dispatch()
    return kind


def kind_of(valve) -> ValveKind:
    """The registered kind of a valve parameter object."""
    for k in KINDS.values():
        if type(valve) is k.params:
            return k
    for k in KINDS.values():
        if isinstance(valve, k.params):
            return k
    raise KeyError(f"{type(valve).__name__} is not a registered valve kind")


def kind_named(name: str) -> ValveKind:
    """The kind called ``name`` (KeyError if unknown)."""
    return KINDS[name]


def _build_dispatch() -> None:
    """(Re)generate :func:`valve_acceleration`: an if-chain over the registered kinds.

    Generated (rather than written) so that a kind is one registry entry; numba compiles
    the generated function like any other (lumped.compiled), each kind's function inlined.
    """
    args = "x, u, dp, p_down, p_vap, rho, mu, q_o, cd, aq, dq_ddp, dq_dx, ddp_dt, p, o, contact, regime"
    lines = [f"def valve_acceleration({args}):",
             '    """du/dt [m/s^2] of the valve at block offset o, by its kind (generated dispatch)."""',
             "    k = p[o + VALVE.kind_id]"]
    for kind in KINDS.values():
        fname = f"_accel_{kind.name}"
        globals()[fname] = kind.acceleration
        lines.append(f"    if k == {float(kind.id)}:")
        lines.append(f"        return {fname}({args})")
    lines.append("    return math.nan")
    code = compile("\n".join(lines), __file__, "exec")
    exec(code, globals())  # noqa: S102 - generated from the registry above


def valve_acceleration(x, u, dp, p_down, p_vap, rho, mu, q_o, cd, aq, dq_ddp, dq_dx, ddp_dt, p, o, contact,
                       regime):  # replaced by _build_dispatch() as kinds register
    """du/dt of the valve at block offset o (no kind registered yet: nan)."""
    return math.nan


# --------------------------------------------------------------------------- shared physics
def contact_state(x: float, xstop: float) -> int:
    """0 seat (x < 0), 1 free, 2 stop (x > x_stop): the branch of eq 2.20."""
    if x < 0.0:
        return SEAT
    if x > xstop:
        return STOP
    return FREE


def contact_force(x: float, u: float, kseat: float, cseat: float, kstop: float, cstop: float,
                  xstop: float, contact: int) -> float:
    """Seat and stop reaction F_c (eq 2.20), in the units of k x (N for the disc, Pa for the reed)."""
    if contact < 0:
        contact = contact_state(x, xstop)
    if contact == SEAT:
        return -kseat * x - cseat * u
    if contact == STOP:
        return -kstop * (x - xstop) - cstop * u
    return 0.0


def contact_reaction(x: float, u: float, p, o: int, contact: int) -> float:
    """F_c of eq 2.20 for the valve at block offset o (N for the disc, Pa for the reed)."""
    return contact_force(x, u, p[o + VALVE.seat_k], p[o + VALVE.seat_c], p[o + VALVE.stop_k],
                         p[o + VALVE.stop_c], p[o + VALVE.stop_gap], contact)


def displacement_area(u: float, a1: float, a2: float, f1: float, f2: float, contact: int) -> float:
    """Fluid displacement area A_Q(u) [m^2] (eq 2.42; 3.26).

    While pressed into a compliant seat (contact 0) the element displaces the same volume
    going in and coming out, so the mean of the two areas is used (valvelab's choice: the
    direction-dependent A_Q would pump a net volume through a seated valve).
    """
    if contact == SEAT:
        return a1 + 0.5 * (f1 + f2) * (a2 - a1)
    if u < 0.0:
        return a1 + f1 * (a2 - a1)
    return a1 + f2 * (a2 - a1)


def valve_flow(x: float, u: float, dp: float, rho: float, mu: float, p, o: int,
               contact: int) -> tuple[float, float, float, float, float]:
    """Flow through a check valve of any kind (disc eqs 2.40-2.42, reed eqs 3.23-3.26).

    Returns (Q_o orifice [m^3/s], Cd, A_Q [m^2], dQ_o/d(dp) [m^3/s/Pa], dQ_o/dx [m^2/s]).
    The total volume flow is Q_o + A_Q u. Seated (contact 0) the orifice is shut: Q_o = 0.
    """
    if contact < 0:
        contact = contact_state(x, p[o + VALVE.stop_gap])
    aq = displacement_area(u, p[o + VALVE.area_1], p[o + VALVE.area_2], p[o + VALVE.f_closing],
                           p[o + VALVE.f_opening], contact)
    if contact == SEAT or x <= 0.0:
        return 0.0, 0.0, aq, 0.0, 0.0
    k_area = p[o + VALVE.area_per_opening]
    per = p[o + VALVE.perimeter]
    q, cd, dq_ddp, dq_da = orifice_flow(k_area * x, dp, rho, mu, per, p[o + VALVE.cd_inf], p[o + VALVE.cd_a],
                                        p[o + VALVE.cd_b], p[o + VALVE.cd_c], p[o + VALVE.orifice_start])
    # the root sqrt(Re) starts the next solve of this valve (2-3 Halley steps become ~1)
    p[o + VALVE.orifice_start] = math.sqrt(4.0 * rho * abs(q) / (mu * per))
    return q, cd, aq, dq_ddp, dq_da * k_area


def mass_flow(qo: float, aq: float, u: float, dp: float, rho: float, dq_ddp: float,
              dq_dx: float) -> tuple[float, float, float, float, float]:
    """Mass flow through a valve rho (Q_o + A_Q u) [kg/s] (eqs 4.3, 4.4) and its partials.

    From the outputs of :func:`valve_flow`; returns (mdot, d mdot/d(dp), d mdot/d rho,
    d mdot/dx, d mdot/du), each at fixed other arguments. Q_o of the orifice equation
    with Cd(Re) scales as rho^(1/w' - 1) at fixed dp, so dQ_o/d rho = (dp dQ_o/d(dp) -
    Q_o) / rho. The pump's right-hand side (lumped.pump.evaluate) and its Jacobian
    (lumped.jacobian) both take the valve mass flows from here: written once.
    """
    q = qo + aq * u
    return rho * q, rho * dq_ddp, q + (dp * dq_ddp - qo), rho * dq_dx, rho * aq


def check_discharge(cd_inf: float, a: float, b: float, c: float, where: str) -> None:
    """The Cd(Re) correlation (eqs 2.47, 3.89) must rise from 0 with a positive slope and keep s^2/Cd(s)
    increasing in s = sqrt(Re) (the orifice solve relies on it); InputError naming ``where``."""
    import numpy as np

    from geometry.errors import InputError
    from lumped.orifice import discharge_coefficient, laminar_slope

    if not laminar_slope(cd_inf, a, b, c) > 0:
        raise InputError(f"{where}.discharge.a", "Cd(Re) must rise from 0 with a positive slope (eq 2.47)")
    s = np.geomspace(1e-6, 1e4, 2000)
    cd = discharge_coefficient(s, cd_inf, a, b, c)
    if np.any(cd <= 0) or np.any(np.diff(np.log(s**2 / cd)) <= 0):
        raise InputError(f"{where}.discharge.a", "Cd(Re) must stay positive with s^2/Cd(s) increasing in "
                                                 "s = sqrt(Re) (eqs 2.47, 3.89)")


def regime_of(x: float, p, o: int) -> int:
    """Pressure regime decided from the opening: Poiseuille below the regime opening (eq 2.18)."""
    xt = p[o + VALVE.regime_opening]
    if xt > 0.0 and x < xt:
        return POISEUILLE
    return ORIFICE
