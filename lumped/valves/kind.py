"""Check-valve kinds: the kind contract, the registry, and the physics every kind shares.

A valve *kind* (disc, reed, ball, ...) is one :class:`ValveKind` entry, registered by the
module that implements it (``lumped/valves/disc.py``, ``lumped/valves/reed.py``,
``lumped/valves/ball.py``). The contract a kind fulfils is small and typed:

- its parameter class: a frozen dataclass subclassing :class:`ValveParams` whose fields
  are declared with :func:`geometry.declare.param`, and whose :meth:`ValveParams.common`
  returns the quantities every kind shares as one frozen, checked :class:`Common`;
- its acceleration: ``acceleration(x, u, f, p, o, contact, regime) -> du/dt`` of the opening
  x [m] and its rate u [m/s], with ``f`` the :class:`ValveInputs` the pump gives every kind
  (pressures, density, the orifice flow and its partials) and the flat parameter array
  ``p`` read at the kind's block offset ``o`` (floats and arrays only: numba compiles it);
  a kind with several mechanical degrees of freedom (the modal reed) adds
  ``accelerations(y, s, n, x, u, f, p, o, contact, regime, dydt)``, its n accelerations written into
  the state derivative at its rates' slots ``dydt[s + n:s + 2n]`` (its positions are ``y[s:s + n]``,
  its rates ``y[s + n:s + 2n]``), and may add their partials by
  its positions and rates, ``accelerations_jacobian(y, s, n, x, u, f, p, o, contact, regime, jac)``
  (written into the pump's Jacobian; without it lumped.solver.jacobian differences them);
- its tolerances on the fast path and the shipped model that gives its defaults.

:func:`~lumped.conformance.check_valve_kind` checks a kind against this contract.
The pump, the fast path, the effects and the command line find kinds here instead of
branching on names.

Contact state ``contact``: 0 seat (x < 0 side), 1 free, 2 stop (x > x_stop side),
-1 decide from x. The pump integrator fixes it per step and switches it only at a
located crossing (``lumped.solver.switching``), so the right-hand side is smooth in a step.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass, fields
from typing import Callable, ClassVar, NamedTuple

from geometry.declare import param
from lumped.fluid.orifice import discharge_slope, orifice_flow

#: quantities every kind packs first, at these offsets of its block (lumped.solver.layout): the fields of
#: :class:`Common`, then the bookkeeping the layout writes
COMMON = (
    "kind_id",         # registry id of the kind
    "moving_mass",     # kg (disc, ball) or kg/m^2 (reed: per unit area, eq 3.21)
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
    "cd_lift_exponent",  # k: Cd at the effective Re (x / x_stop)^k (0: independent of the opening)
    "perimeter",       # orifice perimeter of the Reynolds number [m]
    "average_density",  # 1: orifice density is the mean of both sides (section 4.3.5), 0: cylinder's
    "area_per_opening",  # A_o / x at small openings [m]
    "area_curvature",  # A_o = area_per_opening x + area_curvature x^2 (a ball in a cone) [-]
    "regime_opening",  # x of a pressure-regime switch (eq 2.18) [m]; <= 0: none
    "contact_area",    # area turning the contact force into a pressure load (disc face; reed 1)
    "flow_in_acceleration",  # 1 if the kind's acceleration reads the flow inputs (flow forces), else 0
    "orifice_start",   # scratch, not a parameter: sqrt(Re) of the last orifice solve (warm start)
    "dofs",            # mechanical degrees of freedom of the valve (its states: dofs positions, dofs rates)
    "state_start",     # index of its first state in the state vector (lumped.solver.layout)
    "tail",            # offset of its variable-length data in the flat array (0: none; lumped.solver.layout)
)
#: the offsets, as a namedtuple numba folds into constants: p[o + VALVE.stop_gap]
VALVE = collections.namedtuple("ValveBlock", COMMON)(*range(len(COMMON)))

SEAT, FREE, STOP = 0, 1, 2
POISEUILLE, ORIFICE = 0, 1
#: names of the contact states and pressure regimes (event records, reports)
CONTACT_NAMES = ("seat", "free", "stop")
REGIME_NAMES = ("poiseuille", "orifice")


class ValveInputs(NamedTuple):
    """What the pump gives a kind's acceleration at one instant (SI), besides x, u and the block.

    ``dp`` = P_up - P_down [Pa]; ``p_down`` [Pa]; ``p_vap`` the vapour pressure [Pa]; ``rho`` the
    density of the orifice equation [kg/m^3]; ``mu`` [Pa s]; ``q_o`` the orifice flow [m^3/s] and
    ``cd``, ``aq`` [m^2], ``dq_ddp`` [m^3/s/Pa], ``dq_dx`` [m^2/s] from :func:`valve_flow`;
    ``ddp_dt`` d(dp)/dt [Pa/s] (the transient flow force of eq 2.37). A kind reads what it needs.
    """

    dp: float
    p_down: float
    p_vap: float
    rho: float
    mu: float
    q_o: float
    cd: float
    aq: float
    dq_ddp: float
    dq_dx: float
    ddp_dt: float


# --------------------------------------------------------------------------- the shared quantities
@dataclass(frozen=True)
class Common:
    """The quantities every valve kind shares (SI units), checked when built.

    ``moving_mass`` [kg, or kg/m^2 per unit area]; ``stop_gap`` x_stop [m]; ``seat_k``, ``seat_c``,
    ``stop_k``, ``stop_c`` the contact stiffness and damping of eq 2.20 (N/m, N s/m; per unit area
    for the reed: Pa/m, Pa s/m); ``area_1``, ``area_2``, ``f_closing``, ``f_opening`` the fluid
    displacement area of eqs 2.42, 3.26; ``cd_inf``, ``cd_a``, ``cd_b``, ``cd_c`` the Cd(Re)
    correlation of eqs 2.47, 3.89; ``perimeter`` [m] of its Reynolds number; ``average_density``
    (section 4.3.5); ``area_per_opening`` A_o / x [m] and ``area_curvature`` [-], the orifice area
    A_o = area_per_opening x + area_curvature x^2; ``cd_lift_exponent`` k [-]: Cd(Re) is taken at
    the effective Reynolds number Re (x / x_stop)^k (0: Cd independent of the opening, eqs 2.47, 3.89); ``regime_opening`` [m] of a pressure-regime
    switch (eq 2.18; None: none); ``contact_area`` [m^2] that turns a contact force into a
    pressure load (1 for a per-unit-area kind); ``flow_in_acceleration``: the acceleration reads
    the flow inputs (then the Jacobian recomputes the flow at each perturbation).
    """

    moving_mass: float
    stop_gap: float
    seat_k: float
    seat_c: float
    stop_k: float
    stop_c: float
    area_1: float
    area_2: float
    f_closing: float
    f_opening: float
    cd_inf: float
    cd_a: float
    cd_b: float
    cd_c: float
    perimeter: float
    area_per_opening: float
    contact_area: float
    average_density: bool = False
    regime_opening: float | None = None
    flow_in_acceleration: bool = False
    area_curvature: float = 0.0
    cd_lift_exponent: float = 0.0

    #: fields that must be > 0 and those that must be >= 0
    POSITIVE: ClassVar[tuple] = ("moving_mass", "stop_gap", "seat_k", "stop_k", "perimeter", "area_per_opening",
                                 "contact_area", "cd_inf")
    NON_NEGATIVE: ClassVar[tuple] = ("seat_c", "stop_c", "area_1", "area_2", "f_closing", "f_opening",
                                     "area_curvature")

    def __post_init__(self):
        for name in _COMMON_FIELDS:
            v = getattr(self, name)
            if isinstance(v, bool) or (v is None and name == "regime_opening"):
                continue
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"Common.{name}: expected a finite number, got {v!r}")
            if name in self.POSITIVE and not v > 0:
                raise ValueError(f"Common.{name}: must be positive, got {v!r}")
            if name in self.NON_NEGATIVE and v < 0:
                raise ValueError(f"Common.{name}: must not be negative, got {v!r}")
        if self.regime_opening is not None and not self.regime_opening > 0:
            raise ValueError(f"Common.regime_opening: must be positive or None, got {self.regime_opening!r}")
        if self.area_1 > self.area_2:
            raise ValueError(f"Common.area_1 ({self.area_1:g}) exceeds area_2 ({self.area_2:g})")

    def packed(self) -> dict:
        """{COMMON name: float} as the flat array holds them."""
        out = {}
        for name in _COMMON_FIELDS:
            v = getattr(self, name)
            out[name] = (-1.0 if v is None else (1.0 if v is True else (0.0 if v is False else float(v))))
        return out


_COMMON_FIELDS = tuple(f.name for f in fields(Common))


#: the choices of a valve's ``fluid`` key (lumped.valves.fluid_forms)
FLUID_CHOICES = ("empirical", "predicted")


def fluid_param():
    """The declaration of a valve's ``fluid`` key, shared by the kinds that offer predicted fluid parameters."""
    return param("fluid", "-", 'the valve\'s fluid parameters: "empirical" (the thesis\'s correlations and '
                 'estimates, as given) or "predicted" (the compact forms the fluid references compute for this '
                 'geometry and oil, lumped.valves.fluid_forms; docs/fluid.md)', choices=FLUID_CHOICES,
                 default="empirical")


class ValveParams:
    """Base of every kind's parameter class (a frozen dataclass of declared fields, with ``position``).

    A kind implements :meth:`common` (the shared quantities) and :meth:`load` (from its
    model-file table); it may add packed quantities of its own (:attr:`DERIVED` names given by
    :meth:`packed_extra`), variable-length data (:meth:`tail`), more mechanical degrees of
    freedom (:meth:`dofs`), and what ``model check`` reports (:meth:`describe`).
    """

    #: keys a geometry supplies (dropped from inherited defaults when a file names another geometry)
    FROM_GEOMETRY: ClassVar[tuple] = ()
    #: the kind's own derived packed quantities (names of :meth:`packed_extra`)
    DERIVED: ClassVar[tuple] = ()

    @classmethod
    def load(cls, table: dict, where: str, position: str):  # pragma: no cover - every kind has its own
        """A valve from its complete model-file table ``valves.<position>`` (``where`` names it in errors)."""
        raise NotImplementedError

    def common(self, oil) -> Common:  # pragma: no cover - every kind has its own
        """The quantities every kind shares, for the oil ``oil``."""
        raise NotImplementedError

    def packed_extra(self, oil) -> dict:
        """The kind's own derived packed quantities {name in DERIVED: value} (default: none)."""
        return {}

    def tail(self, oil):
        """Variable-length data the kind reads at p[o + VALVE.tail] (a float array), or None."""
        return None

    def dofs(self) -> int:
        """Mechanical degrees of freedom (1: the opening x itself is the state, with its rate u)."""
        return 1

    def several(self) -> bool:
        """Whether the valve moves by its kind's ``accelerations`` (generalised coordinates, the opening
        weighted from them, data in its tail) rather than its scalar ``acceleration`` of x."""
        return self.dofs() > 1

    def natural_frequency(self) -> float:  # pragma: no cover - every kind has its own
        """Undamped natural frequency of the moving element in vacuum [rad/s]."""
        raise NotImplementedError

    def damping_ratios(self) -> dict:
        """Damping ratios of the moving element on its contacts (default: seat and stop, eq 2.23)."""
        c = self.common(None)
        crit = lambda k: 2.0 * math.sqrt(k * c.moving_mass)  # noqa: E731
        return {"seat": c.seat_c / crit(c.seat_k), "stop": c.stop_c / crit(c.stop_k)}

    def describe(self) -> dict:
        """Kind-specific quantities ``valvelab model check`` reports (default: none)."""
        return {}

    def validity(self, oil=None):
        """Where the valve's equations hold (:class:`lumped.validity.Envelope`): its rest opening [m], the
        pressure difference lifting it off its seat [Pa] and limits on what a run measures of it. The base
        gives the limits every kind shares (:func:`lumped.validity.common_limits`: contact deflections
        within the lift, eq 2.20; Reynolds numbers below Cd(Re)'s asymptote, eq 2.47); a kind returns
        ``dataclasses.replace`` of it with its rest, cracking pressure and own limits added."""
        from lumped.validity import Envelope, common_limits

        c = self.common(oil)
        return Envelope(limits=common_limits(c), stop_gap=c.stop_gap)

    def geometry_supplied(self) -> set:
        """Keys whose value equals what the valve's geometry preset or file supplies (``model show``
        prints them as comments; default: none)."""
        return set()


# --------------------------------------------------------------------------- registry
@dataclass(frozen=True)
class ValveKind:
    """One valve kind (see the module docstring).

    ``params``: the parameter class (:class:`ValveParams`); ``acceleration``: du/dt of the
    opening (numba-compilable; see the module docstring), ``accelerations``: the several-DOF form
    (None: the kind has one); ``block``: the offsets of its packed quantities
    (:func:`kind_block`); ``accelerations_jacobian``: their partials by the valve's positions and
    rates (None: differenced); ``default_model``: the shipped model whose valves give the keys a model
    file leaves out for this kind; ``contact_position_atol``: the fast path's opening tolerance in
    contact, in units of atol x the contact deflection (lumped.solver.steppers.tolerance_table);
    ``free_velocity_atol``: the fast path's velocity tolerance in free flight, in units of atol x
    1 m/s; ``contact_velocity_atol``: the same in contact; ``design_ranges``: {model-file key of
    the valve: (low, high)} of plausible designs (a random design draws each uniformly, log-
    uniformly when ``low`` > 0 and ``high`` / ``low`` > 10; the tests and the conformance check draw
    from them); ``summary``: one line.
    """

    name: str
    params: type
    acceleration: Callable
    block: tuple
    default_model: str = ""
    accelerations: Callable | None = None
    accelerations_jacobian: Callable | None = None
    contact_velocity_atol: float = 1.0
    contact_position_atol: float = 30.0
    free_velocity_atol: float = 100.0
    design_ranges: dict = None
    summary: str = ""
    id: int = -1


KINDS: dict[str, ValveKind] = {}
#: inlined where called in the compiled physics (lumped.solver.compiled): the dispatch is a few compares, and
#: inlined the ValveInputs it passes on stay in registers
INLINE = ("valve_acceleration", "valve_accelerations", "valve_accelerations_jacobian")
#: length of every valve block of the flat parameter array (a kind may use up to this many)
BLOCK_SIZE = 96


def kind_block(params: type, derived: tuple | None = None) -> tuple:
    """Offsets of a kind's packed quantities: :data:`COMMON`, then every field declared
    ``packed=True`` (by field name), then the kind's derived quantities (``params.DERIVED``); a
    namedtuple that numba folds into constants (``p[o + DISC.spring_stiffness]``)."""
    from geometry.declare import specs

    derived = tuple(params.DERIVED if derived is None else derived)
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
    if not (isinstance(kind.params, type) and issubclass(kind.params, ValveParams)):
        raise TypeError(f"valve kind {kind.name!r}: params must subclass lumped.valves.kind.ValveParams")
    from dataclasses import replace

    kind = replace(kind, id=len(KINDS), design_ranges=dict(kind.design_ranges or {}))
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


def kind_names() -> tuple[str, ...]:
    """Every registered kind's name, in registration order (command-line choices, tests)."""
    return tuple(KINDS)


def _if_chain(name: str, args: str, doc: str, attr: str, prefix: str, call: list[str], default: list[str]) -> list[str]:
    """Source lines of ``def name(args)``: for each registered kind with a function ``attr``, ``if k == id:``
    then ``call`` (``{f}``: that function, bound in this module's globals as prefix + kind name; ``{a}``: the
    arguments); else ``default``."""
    lines = [f"def {name}({args}):", f'    """{doc}"""', "    k = p[o + VALVE.kind_id]"]
    for kind in KINDS.values():
        fn = getattr(kind, attr)
        if fn is None:
            continue
        fname = f"{prefix}{kind.name}"
        globals()[fname] = fn
        lines += [f"    if k == {float(kind.id)}:", *(f"        {c.format(f=fname, a=args)}" for c in call)]
    return [*lines, *(f"    {d}" for d in default), ""]


def _build_dispatch() -> None:
    """(Re)generate :func:`valve_acceleration`, :func:`valve_accelerations` and
    :func:`valve_accelerations_jacobian`: if-chains over the kinds.

    Generated (rather than written) so that a kind is one registry entry; numba compiles
    the generated functions like any other (lumped.solver.compiled), each kind's function inlined.
    """
    one = "x, u, f, p, o, contact, regime"
    many = "y, s, n, x, u, f, p, o, contact, regime, dydt"
    jac = "y, s, n, x, u, f, p, o, contact, regime, jac"
    lines = [
        *_if_chain("valve_acceleration", one, "du/dt [m/s^2] of the opening of the one-DOF valve at block offset o, "
                   "by its kind (generated).", "acceleration", "_accel_", ["return {f}({a})"], ["return math.nan"]),
        *_if_chain("valve_accelerations", many, "The n accelerations [m/s^2] of a several-DOF valve into "
                   "dydt[s + n:s + 2n] (generated dispatch).", "accelerations", "_accels_", ["{f}({a})", "return"],
                   ["for j in range(n):", "    dydt[s + n + j] = math.nan"]),
        *_if_chain("valve_accelerations_jacobian", jac, "The partials of a several-DOF valve's accelerations by its "
                   "states into jac; False: the kind has none (generated dispatch).", "accelerations_jacobian",
                   "_accels_jac_", ["{f}({a})", "return True"], ["return False"]),
    ]
    code = compile("\n".join(lines), __file__, "exec")
    old = {name: globals()[name] for name in ("valve_acceleration", "valve_accelerations",
                                                "valve_accelerations_jacobian")}
    exec(code, globals())  # noqa: S102 - generated from the registry above
    # modules that imported the dispatchers by name (lumped.solver.layout, lumped.solver.jacobian) still hold the ones built
    # before this kind registered, which the reference path would call: point them at the new ones
    import sys

    for mod in list(sys.modules.values()):
        scope = getattr(mod, "__dict__", None)
        if scope is None or not getattr(mod, "__name__", "").startswith("lumped."):
            continue
        for name, fn in old.items():
            if scope.get(name) is fn:
                scope[name] = globals()[name]


def valve_acceleration(x, u, f, p, o, contact, regime):  # replaced by _build_dispatch() as kinds register
    """du/dt of the valve at block offset o (no kind registered yet: nan)."""
    return math.nan


def valve_accelerations(y, s, n, x, u, f, p, o, contact, regime, dydt):  # replaced by _build_dispatch()
    """The accelerations of a several-DOF valve (no kind registered yet: nan)."""
    for j in range(n):
        dydt[s + n + j] = math.nan


def valve_accelerations_jacobian(y, s, n, x, u, f, p, o, contact, regime, jac):  # replaced by _build_dispatch()
    """The partials of a several-DOF valve's accelerations (no kind registered yet: none)."""
    return False


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


def contact_slopes(x: float, p, o: int, contact: int) -> tuple[float, float]:
    """(dF_c/dx, dF_c/du) of :func:`contact_reaction` (eq 2.20) in a contact state (units of k and c)."""
    if contact < 0:
        contact = contact_state(x, p[o + VALVE.stop_gap])
    if contact == SEAT:
        return -p[o + VALVE.seat_k], -p[o + VALVE.seat_c]
    if contact == STOP:
        return -p[o + VALVE.stop_k], -p[o + VALVE.stop_c]
    return 0.0, 0.0


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
    """Flow through a check valve of any kind (disc eqs 2.40-2.42, reed eqs 3.23-3.26, ball lumped.valves.ball).

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
    k2 = p[o + VALVE.area_curvature]
    per = p[o + VALVE.perimeter]
    lift_k = p[o + VALVE.cd_lift_exponent]
    if lift_k != 0.0:
        # Re_eff = Re (x / x_stop)^k: the same law with the perimeter p (x_stop / x)^k
        per = per * (p[o + VALVE.stop_gap] / x) ** lift_k
    area = k_area * x + k2 * x * x
    q, cd, dq_ddp, dq_da = orifice_flow(area, dp, rho, mu, per, p[o + VALVE.cd_inf],
                                        p[o + VALVE.cd_a], p[o + VALVE.cd_b], p[o + VALVE.cd_c],
                                        p[o + VALVE.orifice_start])
    # the root sqrt(Re) starts the next solve of this valve (2-3 Halley steps become ~1)
    s = math.sqrt(4.0 * rho * abs(q) / (mu * per))
    p[o + VALVE.orifice_start] = s
    dq_dx = dq_da * (k_area + 2.0 * k2 * x)
    if lift_k != 0.0 and cd > 0.0:
        # the perimeter's share: dQ/dp_er = -dQ/dA A Cd'(s) s / (2 p_er Cd) (implicit in s^2 = 4 rho |Q| /
        # (mu p_er), Q = Cd(s) A V), with dp_er/dx = -k p_er / x
        slope = discharge_slope(s, p[o + VALVE.cd_inf], p[o + VALVE.cd_a], p[o + VALVE.cd_b], p[o + VALVE.cd_c])
        dq_dx += dq_da * area * slope * s * lift_k / (2.0 * cd * x)
    return q, cd, aq, dq_ddp, dq_dx


def mass_flow(qo: float, aq: float, u: float, dp: float, rho: float, dq_ddp: float,
              dq_dx: float) -> tuple[float, float, float, float, float]:
    """Mass flow through a valve rho (Q_o + A_Q u) [kg/s] (eqs 4.3, 4.4) and its partials.

    From the outputs of :func:`valve_flow`; returns (mdot, d mdot/d(dp), d mdot/d rho,
    d mdot/dx, d mdot/du), each at fixed other arguments. Q_o of the orifice equation
    with Cd(Re) scales as rho^(1/w' - 1) at fixed dp, so dQ_o/d rho = (dp dQ_o/d(dp) -
    Q_o) / rho. The pump's right-hand side (lumped.solver.rhs.evaluate) and its Jacobian
    (lumped.solver.jacobian) both take the valve mass flows from here: written once.
    """
    q = qo + aq * u
    return rho * q, rho * dq_ddp, q + (dp * dq_ddp - qo), rho * dq_dx, rho * aq


def check_discharge(cd_inf: float, a: float, b: float, c: float, where: str) -> None:
    """The Cd(Re) correlation (eqs 2.47, 3.89) must rise from 0 with a positive slope and keep s^2/Cd(s)
    increasing in s = sqrt(Re) (the orifice solve relies on it); InputError naming ``where``."""
    import numpy as np

    from geometry.errors import InputError
    from lumped.fluid.orifice import discharge_coefficient, laminar_slope

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
