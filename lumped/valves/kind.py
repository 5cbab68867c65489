"""Check-valve kinds: the kind contract and the registry.

A valve *kind* (disc, reed, ball, ...) is one :class:`ValveKind` entry, registered by the
module that implements it (``lumped/valves/disc.py``, ``lumped/valves/reed.py``,
``lumped/valves/ball.py``). The contract a kind fulfils is small and typed:

- its parameter class: a frozen dataclass subclassing :class:`ValveParams` whose fields
  are declared with :func:`geometry.declare.param`, and whose :meth:`ValveParams.common`
  returns the quantities every kind shares as one frozen, checked
  :class:`~lumped.valves.common.Common`;
- its acceleration: ``acceleration(x, u, f, p, o, contact, regime) -> du/dt`` of the opening
  x [m] and its rate u [m/s], with ``f`` the :class:`~lumped.valves.common.ValveInputs` the pump gives every kind
  (pressures, density, the orifice flow and its partials) and the flat parameter array
  ``p`` read at the kind's block offset ``o`` (floats and arrays only: numba compiles it);
  a kind with several mechanical degrees of freedom (the modal reed) adds
  ``accelerations(y, s, n, x, u, f, p, o, contact, regime, dydt)``, its n accelerations written into
  the state derivative at its rates' slots ``dydt[s + n:s + 2n]`` (its positions are ``y[s:s + n]``,
  its rates ``y[s + n:s + 2n]``), and may add their partials by
  its positions and rates, ``accelerations_jacobian(y, s, n, x, u, f, p, o, contact, regime, jac)``
  (written into the pump's Jacobian; without it lumped.solver.jacobian differences them);
- its tolerances on the fast path and the shipped model that gives its defaults.

:func:`register` checks what can be checked before anything runs (the parameter class, the fields the
acceleration reads are declared and packed, the default model exists) and refuses a kind with a
:class:`KindError` naming what to fix; :func:`~lumped.conformance.check_valve_kind` checks the rest by
running it. The pump, the fast path, the effects and the command line find kinds here instead of
branching on names. What every kind shares is written once: the packed block and the inputs in
:mod:`lumped.valves.common`, the contact, flow and force terms in :mod:`lumped.valves.forces` (both
re-exported here).
"""

from __future__ import annotations

import collections
import linecache
import math
from dataclasses import dataclass
from typing import Callable, ClassVar

from geometry.declare import param
from geometry.errors import InputError
# the shared data and physics, re-exported: a kind's module imports what it needs from here
from lumped.valves.common import (  # noqa: F401
    COMMON, CONTACT_NAMES, FREE, ORIFICE, POISEUILLE, REGIME_NAMES, SEAT, STOP, VALVE, Common, ValveInputs,
)
from lumped.valves.forces import (  # noqa: F401
    contact_force, contact_reaction, contact_slopes, contact_state, critical_damping, displacement_area,
    mass_flow, orifice_area, regime_of, spring_force, steady_flow_force, valve_flow,
)

#: the choices of a valve's ``fluid`` key (lumped.valves.fluid_forms)
FLUID_CHOICES = ("empirical", "predicted")


def fluid_param():
    """The declaration of a valve's ``fluid`` key, shared by the kinds that offer predicted fluid parameters.

    Returns
    -------
    dataclasses.Field
        The :func:`geometry.declare.param` field ``fluid`` [-]: ``"empirical"`` (default, the thesis's
        correlations: eqs 2.48, 3.83, 3.89 and the estimated f1, f2) or ``"predicted"``.
    """
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

    # ---- contact damping (eq 2.23), derived here for every kind
    def critical_mass(self) -> tuple[float, float]:
        """(m, gamma) of the element's equation m x'' + gamma (c x' + k x) = F, against whose critical damping
        (:func:`~lumped.valves.forces.critical_damping`, eq 2.23) the damping ratios are measured.

        Returns
        -------
        tuple of float
            The moving mass [kg] (its ``moving_mass``, else that of :meth:`common`) and gamma = 1 (a rigid
            element); the reed returns its modal mass per unit area [kg/m^2] and gamma1 (eq 3.21).
        """
        m = getattr(self, "moving_mass", None)
        return (self.common(None).moving_mass if m is None else m), 1.0

    def damping_reference(self) -> tuple[float, float]:
        """(m, gamma) whose critical damping a contact left without its damping takes (default:
        :meth:`critical_mass`; the thesis disc used another mass, ``mass.contact_reference``)."""
        return self.critical_mass()

    def contact_damping(self, contact: str) -> float:
        """The damping of a contact, c_seat or c_stop (eq 2.20).

        Parameters
        ----------
        contact : str
            ``"seat"`` or ``"stop"``: the kind's ``<contact>_damping`` field (None: left out) and
            ``<contact>_stiffness`` field [N/m, or Pa/m per unit area].

        Returns
        -------
        float
            As given, else critical for :meth:`damping_reference`: 2 sqrt(gamma k m) / gamma [N s/m, or
            Pa s/m per unit area] (eq 2.23).
        """
        given = getattr(self, f"{contact}_damping", None)
        if given is not None:
            return given
        return critical_damping(getattr(self, f"{contact}_stiffness"), *self.damping_reference())

    @property
    def seat_damping_value(self) -> float:
        """c_seat [N s/m; Pa s/m per unit area]: as given, else critical (:meth:`contact_damping`, eq 2.23)."""
        return self.contact_damping("seat")

    @property
    def stop_damping_value(self) -> float:
        """c_stop [N s/m; Pa s/m per unit area]: as given, else critical (:meth:`contact_damping`, eq 2.23)."""
        return self.contact_damping("stop")

    def damping_ratios(self) -> dict:
        """Damping ratios of the moving element on its seat and stop: c / c_crit with c_crit of
        :meth:`critical_mass` (eq 2.23; a contact left without its damping has 1 unless the kind's
        :meth:`damping_reference` differs).

        Returns
        -------
        dict
            {"seat": zeta, "stop": zeta} (dimensionless).
        """
        c = self.common(None)
        m, gamma = self.critical_mass()
        return {"seat": c.seat_c / critical_damping(c.seat_k, m, gamma),
                "stop": c.stop_c / critical_damping(c.stop_k, m, gamma)}

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
    """Offsets of a kind's packed quantities: COMMON, then every field declared ``packed=True`` (by field name),
    then the kind's derived quantities (``params.DERIVED``).

    Parameters
    ----------
    params : type
        The kind's parameter class.
    derived : tuple of str, optional
        Derived names; None: ``params.DERIVED``.

    Returns
    -------
    namedtuple
        Name -> offset in the valve's block, which numba folds into constants (``p[o + DISC.spring_stiffness]``);
        ValueError when a name repeats or the block overflows BLOCK_SIZE.
    """
    from geometry.declare import specs

    derived = tuple(params.DERIVED if derived is None else derived)
    own = [n for n, s in specs(params) if s.packed] + list(derived)
    names = COMMON + tuple(own)
    if len(set(names)) != len(names):
        raise ValueError(f"{params.__name__}: a packed name repeats a common one")
    if len(names) > BLOCK_SIZE:
        raise ValueError(f"{params.__name__}: {len(names)} packed quantities exceed BLOCK_SIZE = {BLOCK_SIZE}")
    return collections.namedtuple(f"{params.__name__}Block", names)(*range(len(names)))


class KindError(InputError):
    """A valve kind that breaks the kind contract, refused by :func:`register` before anything runs.

    ``field`` names what to fix (``DiscValve.squeeze_min_gap``, ``disc.default_model``, ...), ``message`` how.
    """


def register(kind: ValveKind) -> ValveKind:
    """Add a kind to the registry (its id is its registration order) after checking its contract.

    Parameters
    ----------
    kind : ValveKind
        The kind's entry (see the module docstring).

    Returns
    -------
    ValveKind
        The registered entry, with its ``id``.

    Raises
    ------
    KindError
        Naming the field or entry to fix: a name registered twice; ``params`` not a frozen
        :class:`ValveParams` dataclass with a ``position`` field; ``block`` not ``kind_block(params)``; a
        quantity the acceleration reads (``p[o + BLOCK.name]``, in it or the functions it calls) that is no
        packed field, derived name or common quantity, in particular a declared field without
        ``packed=True``; no ``default_model``, or one that is neither shipped nor a file; a design range or
        tolerance that is not a positive interval or number.
    """
    from dataclasses import replace

    check_kind(kind)
    kind = replace(kind, id=len(KINDS), design_ranges=dict(kind.design_ranges or {}))
    KINDS[kind.name] = kind
    _build_dispatch()
    return kind


def check_kind(kind: ValveKind) -> None:
    """The static kind contract (what :func:`register` refuses, see there), without registering.

    Parameters
    ----------
    kind : ValveKind

    Returns
    -------
    None
        Or KindError naming the field.
    """
    import dataclasses

    name = kind.name
    if not isinstance(name, str) or not name.isidentifier():
        raise KindError("ValveKind.name", f"expected an identifier-like name, got {name!r}")
    if name in KINDS:
        raise KindError("ValveKind.name", f"valve kind {name!r} is registered twice")
    cls = kind.params
    if not (isinstance(cls, type) and issubclass(cls, ValveParams)):
        raise KindError(f"{name}.params", f"must be a class subclassing lumped.valves.kind.ValveParams, got {cls!r}")
    if not (dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen):
        raise KindError(f"{cls.__name__}", "must be a frozen dataclass (@dataclass(frozen=True))")
    if "position" not in {f.name for f in dataclasses.fields(cls)}:
        raise KindError(f"{cls.__name__}.position", "missing: every valve parameter class has a position field")
    try:
        expected = kind_block(cls)
    except ValueError as exc:
        raise KindError(f"{cls.__name__}", str(exc)) from None
    if tuple(getattr(kind.block, "_fields", ())) != expected._fields:
        raise KindError(f"{name}.block", f"expected kind_block({cls.__name__}) (its packed fields and DERIVED names "
                        "in declaration order)")
    for attr in ("acceleration", "accelerations", "accelerations_jacobian"):
        fn = getattr(kind, attr)
        if fn is None:
            if attr == "acceleration":
                raise KindError(f"{name}.acceleration", "missing: du/dt(x, u, f, p, o, contact, regime)")
            continue
        _check_arguments(name, attr, fn)
        for reader, block_name, field, block in _block_reads(fn):
            if block is kind.block or tuple(block._fields) == expected._fields:
                if field not in expected._fields:
                    raise KindError(*_unpacked(cls, reader, block_name, field))
    _check_default_model(kind)
    _check_numbers(kind)


def _unpacked(cls: type, reader: str, block_name: str, field: str) -> tuple[str, str]:
    """(field, message) of a quantity the physics reads that the kind's block has no slot for."""
    import dataclasses

    declared = {f.name for f in dataclasses.fields(cls)}
    if field in declared:
        return (f"{cls.__name__}.{field}",
                f"{reader}() reads p[o + {block_name}.{field}], but the field is not declared packed=True: "
                f"declare it param(..., packed=True) (or add a derived quantity to DERIVED and packed_extra) so the "
                "flat array has a slot for it (docs/extending.md)")
    return (f"{cls.__name__}.{field}",
            f"{reader}() reads p[o + {block_name}.{field}], which is neither a field declared packed=True, a "
            "DERIVED name of packed_extra() nor a common quantity (lumped.valves.common.COMMON)")


#: the arguments the compiled physics calls each of a kind's functions with
_SIGNATURES = {"acceleration": "x, u, f, p, o, contact, regime",
               "accelerations": "y, s, n, x, u, f, p, o, contact, regime, dydt",
               "accelerations_jacobian": "y, s, n, x, u, f, p, o, contact, regime, jac"}


def _check_arguments(name: str, attr: str, fn) -> None:
    import inspect

    if not callable(fn):
        raise KindError(f"{name}.{attr}", f"expected a function ({_SIGNATURES[attr]}), got {fn!r}")
    n = len(_SIGNATURES[attr].split(", "))
    try:
        params = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return
    positional = [q for q in params if q.kind in (q.POSITIONAL_ONLY, q.POSITIONAL_OR_KEYWORD)]
    if len(positional) != n or any(q.kind in (q.VAR_POSITIONAL, q.VAR_KEYWORD) for q in params):
        raise KindError(f"{name}.{attr}", f"{getattr(fn, '__name__', fn)} takes ({', '.join(q.name for q in params)}); "
                        f"the compiled physics calls it with ({_SIGNATURES[attr]})")


def _is_block(obj) -> bool:
    return isinstance(obj, tuple) and hasattr(obj, "_fields") and type(obj).__name__.endswith("Block")


def _block_reads(fn, seen: set | None = None):
    """(function, block name, field, block) of every ``BLOCK.field`` a kind's function reads, in it and in the
    Python functions it calls (transitively): what its flat-array block must hold."""
    import ast
    import inspect
    import textwrap
    import types

    seen = set() if seen is None else seen
    fn = getattr(fn, "py_func", fn)                        # a numba dispatcher: its Python function
    if not isinstance(fn, types.FunctionType) or fn in seen:
        return
    seen.add(fn)
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    except (OSError, TypeError, SyntaxError):
        return
    scope = dict(fn.__globals__)
    for name, cell in zip(fn.__code__.co_freevars, fn.__closure__ or ()):
        try:
            scope[name] = cell.cell_contents          # a closure's block counts as a global's does
        except ValueError:
            pass
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and _is_block(scope.get(node.value.id)):
            yield fn.__name__, node.value.id, node.attr, scope[node.value.id]
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            yield from _block_reads(scope.get(node.func.id), seen)


def _check_default_model(kind: ValveKind) -> None:
    from pathlib import Path

    from geometry.data_files import package_names

    shipped = package_names("lumped", "models")
    dm = kind.default_model
    if not dm:
        raise KindError(f"{kind.name}.default_model", "missing: name the shipped model "
                        f"(lumped/data/models/thesis-{kind.name}.toml, its name thesis-{kind.name}) or a model file "
                        "whose valves give the keys a user's model file leaves out (docs/extending.md, file 3)")
    if not isinstance(dm, str) or (dm not in shipped and not Path(dm).is_file()):
        raise KindError(f"{kind.name}.default_model", f"{dm!r} is neither a shipped model ({', '.join(shipped)}) "
                        "nor an existing model file")


def _check_numbers(kind: ValveKind) -> None:
    for attr in ("contact_velocity_atol", "contact_position_atol", "free_velocity_atol"):
        v = getattr(kind, attr)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
            raise KindError(f"{kind.name}.{attr}", f"expected a positive number (units of atol), got {v!r}")
    ranges = kind.design_ranges or {}
    if not isinstance(ranges, dict):
        raise KindError(f"{kind.name}.design_ranges", f"expected {{model-file key: (low, high)}}, got {ranges!r}")
    for key, rng in ranges.items():
        ok = isinstance(key, str) and isinstance(rng, (tuple, list)) and len(rng) == 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in rng)
        if not ok or not rng[0] < rng[1]:
            raise KindError(f"{kind.name}.design_ranges.{key}", f"expected (low, high) with low < high, got {rng!r}")


def kind_of(valve) -> ValveKind:
    """The registered kind of a valve parameter object.

    Parameters
    ----------
    valve : ValveParams

    Returns
    -------
    ValveKind
        KeyError if its class is not registered.
    """
    for k in KINDS.values():
        if type(valve) is k.params:
            return k
    for k in KINDS.values():
        if isinstance(valve, k.params):
            return k
    raise KeyError(f"{type(valve).__name__} is not a registered valve kind")


def kind_named(name: str) -> ValveKind:
    """The kind called ``name``.

    Parameters
    ----------
    name : str

    Returns
    -------
    ValveKind
        KeyError if unknown.
    """
    return KINDS[name]


def kind_names() -> tuple[str, ...]:
    """Every registered kind's name, in registration order (command-line choices, tests).

    Returns
    -------
    tuple of str
    """
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
    source = "\n".join(lines)
    # compiled under a name that says what it is (numba's and Python's tracebacks print it), its text kept in
    # linecache so that a traceback or numba's error shows the generated line
    filename = f"<valvelab generated dispatch over the valve kinds {', '.join(KINDS)} (lumped.valves.kind)>"
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    code = compile(source, filename, "exec")
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
    """du/dt of the valve at block offset o: the registered kinds' accelerations, dispatched on the kind code
    (replaced as kinds register).

    Parameters
    ----------
    x, u : float
        Opening [m] and its rate [m/s].
    f : lumped.valves.common.ValveInputs
        What the pump gives the valve.
    p : array of float
        The flat parameter array; ``o`` the valve's block offset.
    contact, regime : int
        The valve's mode.
    o : int
        Block offset.

    Returns
    -------
    float
        du/dt [m/s^2]; nan while no kind is registered.
    """
    return math.nan


def valve_accelerations(y, s, n, x, u, f, p, o, contact, regime, dydt):  # replaced by _build_dispatch()
    """The accelerations of a several-DOF valve, dispatched on the kind code (replaced as kinds register).

    Parameters
    ----------
    y : array of float
        The pump's state.
    s, n : int
        First state, number of coordinates.
    x, u : float
        Opening [m] and its rate [m/s].
    f : lumped.valves.common.ValveInputs
        What the pump gives the valve.
    p : array of float
        The flat parameter array; ``o`` the valve's block offset.
    contact, regime : int
        The valve's mode.
    o : int
        Block offset.
    dydt : array of float
        Written: q'' [m/s^2] at dydt[s + n:s + 2n].

    Returns
    -------
    None
    """
    for j in range(n):
        dydt[s + n + j] = math.nan


def valve_accelerations_jacobian(y, s, n, x, u, f, p, o, contact, regime, jac):  # replaced by _build_dispatch()
    """The partials of a several-DOF valve's accelerations into the pump's Jacobian, dispatched on the kind code
    (replaced as kinds register).

    Parameters
    ----------
    y, s, n, x, u, f, p, o, contact, regime
        As :func:`valve_accelerations`.
    jac : array of float
        Written: the valve's rows.

    Returns
    -------
    bool
        Whether the kind wrote them (False: none registered).
    """
    return False


def check_discharge(cd_inf: float, a: float, b: float, c: float, where: str) -> None:
    """Check the Cd(Re) correlation (eqs 2.47, 3.89): it rises from 0 with a positive slope and keeps s^2/Cd(s)
    increasing in s = sqrt(Re), which the orifice solve relies on.

    Parameters
    ----------
    cd_inf, a, b, c : float
        The correlation's coefficients (lumped.fluid.orifice).
    where : str
        The valve's key; errors name ``where.discharge.a``.

    Returns
    -------
    None
        Or InputError.

    References
    ----------
    Knutson (2016), eqs 2.47, 3.89.
    """
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
