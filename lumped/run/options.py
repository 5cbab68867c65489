"""The options of :func:`lumped.run.simulate.simulate`, grouped: how to integrate, what to trace, how to
change the model for one run; each checked where it is built (:class:`geometry.errors.InputError` naming
the keyword, before anything is compiled or integrated).

``simulate`` takes them as objects (``solver=SolverOptions(rtol=1e-5)``, ``trace=TraceOptions(points=720)``,
``stop=StopRule.steady(1e-4)``) or as the flat keywords of its signature (``rtol=1e-5``,
``trace_points=720``, ``revolutions=3``), which :meth:`RunOptions.from_keywords` sorts into them.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field

import numpy as np

from geometry.declare import Spec, check_value
from geometry.errors import InputError
from lumped.run.revolutions import StopRule, TdcState
from lumped.solver.steppers import DEFAULT_TOLERANCES, METHODS as STEPPERS, family

METHODS = tuple(STEPPERS)
MAX_REVOLUTIONS = 100_000


def check_int(name: str, v, lo: int, hi: int) -> int:
    """``v`` as an int in [lo, hi], else InputError naming ``name``."""
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
        raise InputError(name, f"expected an integer from {lo} to {hi}, got {v!r}")
    return int(v)


def check_tolerance(name: str, v) -> float:
    """A relative or absolute tolerance in (0, 0.1] [-], else InputError naming ``name``."""
    return check_value(v, Spec(None, "-", "", bounds=(1e-14, 0.1), positive=True), name)


@dataclass(frozen=True)
class SolverOptions:
    """How the pump is integrated.

    ``method``: ``fast`` (the compiled Rodas4P/Rodas5P, default) or ``reference`` (scipy's Radau; ``BDF``,
    ``LSODA`` also accepted); ``rtol``, ``atol`` [-]: the integrator's tolerances, atol in units of each
    state's scale (None: :data:`lumped.solver.steppers.DEFAULT_TOLERANCES` of the method); ``contact_atol``
    [-]: fast path, velocity tolerance of a valve on its seat or stop in units of atol x 1 m/s (None: each
    kind's own); ``max_steps``: steps allowed per revolution (None: the stepper's default); ``accuracy_check``:
    fast path, integrate the reported revolution again tighter and tighten or warn where the answer moves
    (lumped.run.accuracy; default True).
    """

    method: str = "fast"
    rtol: float | None = None
    atol: float | None = None
    contact_atol: float | None = None
    max_steps: int | None = None
    accuracy_check: bool = True

    def __post_init__(self):
        if not isinstance(self.accuracy_check, (bool, np.bool_)):
            raise InputError("accuracy_check", f"expected True or False, got {self.accuracy_check!r}")
        if self.method not in METHODS:
            raise InputError("method", f"expected one of {', '.join(METHODS)}, got {self.method!r}")
        if self.contact_atol is not None:
            check_value(self.contact_atol, Spec(None, "-", "", bounds=(1e-6, 1e6), positive=True), "contact_atol")

    @property
    def family(self) -> str:
        """"fast" or "reference" (the scipy steppers)."""
        return family(self.method)

    def tolerances(self) -> tuple[float, float]:
        """(rtol, atol) checked, the method's defaults where None."""
        r_def, a_def = DEFAULT_TOLERANCES[self.family]
        rtol = r_def if self.rtol is None else check_tolerance("rtol", self.rtol)
        atol = a_def if self.atol is None else check_tolerance("atol", self.atol)
        if self.max_steps is not None:
            check_int("max_steps", self.max_steps, 10, 100_000_000)
        return rtol, atol


@dataclass(frozen=True)
class TraceOptions:
    """What a run keeps for its trace (PumpResult.trace).

    The last ``revolutions`` revolutions, sampled at ``points`` per revolution.
    """

    revolutions: int = 1
    points: int = 2000

    def __post_init__(self):
        check_int("trace_points", self.points, 16, 1_000_000)


@dataclass(frozen=True)
class Overrides:
    """Changes of the model for one run: ``air_content`` [-] (oil.air_content), ``circuit`` (``simplified`` or
    ``complete``), ``needle_area`` [m^2] (the complete circuit's needle valve); None: the model's."""

    air_content: float | None = None
    circuit: str | None = None
    needle_area: float | None = None

    def __post_init__(self):
        if self.circuit not in (None, "simplified", "complete"):
            raise InputError("circuit", f"expected simplified or complete, got {self.circuit!r}")


#: simulate's flat keywords, by the option object each belongs to
_SOLVER_KEYS = ("rtol", "atol", "contact_atol", "max_steps", "accuracy_check")
_STOP_KEYS = ("revolutions", "max_revolutions", "steady_tol")
_TRACE_KEYS = {"trace_revolutions": "revolutions", "trace_points": "points"}
_OVERRIDE_KEYS = ("air_content", "circuit", "needle_area")
_RUN_KEYS = ("initial_state", "progress", "check")
KEYWORDS = (*_SOLVER_KEYS, *_STOP_KEYS, *_TRACE_KEYS, *_OVERRIDE_KEYS, *_RUN_KEYS, "solver")


@dataclass(frozen=True)
class RunOptions:
    """Every option of one :func:`~lumped.run.simulate.simulate` call, checked: ``solver``, ``stop`` (a
    :class:`~lumped.run.revolutions.StopRule`), ``trace`` (None: no trace), ``overrides``, ``initial_state``
    (a :class:`~lumped.run.revolutions.TdcState` to start from, or None), ``progress`` (a bar on stderr),
    ``check`` (raise on a result that breaks its invariants)."""

    solver: SolverOptions = field(default_factory=SolverOptions)
    stop: StopRule = field(default_factory=StopRule)
    trace: TraceOptions | None = None
    overrides: Overrides = field(default_factory=Overrides)
    initial_state: TdcState | None = None
    progress: bool = False
    check: bool = True

    @classmethod
    def from_keywords(cls, method: str, trace, stop, keywords: dict) -> "RunOptions":
        """The options of simulate's keywords (see its docstring); InputError naming a bad one, TypeError for
        an unknown one (with the closest known keyword)."""
        for k in keywords:
            if k not in KEYWORDS:
                near = difflib.get_close_matches(k, KEYWORDS, n=1)
                raise TypeError(f"simulate() got an unexpected keyword argument {k!r}"
                                + (f" (did you mean {near[0]!r}?)" if near else ""))
        overrides = Overrides(**{k: keywords[k] for k in _OVERRIDE_KEYS if k in keywords})
        solver = keywords.get("solver")
        if solver is None:
            solver = SolverOptions(method, **{k: keywords[k] for k in _SOLVER_KEYS if k in keywords})
        elif not isinstance(solver, SolverOptions):
            raise InputError("solver", f"expected a lumped.run.options.SolverOptions, got {type(solver).__name__}")
        rule = _stop_rule(stop, keywords)
        if not isinstance(trace, (bool, np.bool_, TraceOptions)):
            raise InputError("trace", f"expected True, False or a lumped.run.options.TraceOptions, got {trace!r}")
        tr = trace if isinstance(trace, TraceOptions) else None
        if tr is None:
            tr = TraceOptions(**{v: keywords[k] for k, v in _TRACE_KEYS.items() if k in keywords})
        check_int("trace_revolutions", tr.revolutions, 1, rule.revolutions)
        state = keywords.get("initial_state")
        if state is not None and not isinstance(state, TdcState):
            raise InputError("initial_state", f"expected a lumped.run.revolutions.TdcState (PumpResult.tdc_state), "
                                              f"got {type(state).__name__}")
        return cls(solver, rule, tr if isinstance(trace, TraceOptions) or trace else None, overrides, state,
                   bool(keywords.get("progress", False)), bool(keywords.get("check", True)))


def _stop_rule(stop, keywords: dict) -> StopRule:
    """The stop rule: ``stop`` as given, else of the keywords revolutions (5), max_revolutions, steady_tol (1e-4);
    each checked."""
    if stop is not None:
        if not isinstance(stop, StopRule):
            raise InputError("stop", f"expected a lumped.run.revolutions.StopRule, got {type(stop).__name__}")
        revs, max_revs, tol, single = stop.revolutions, stop.max_revolutions, stop.tol, stop.single
    else:
        revs, max_revs = keywords.get("revolutions", 5), keywords.get("max_revolutions")
        tol, single = keywords.get("steady_tol", 1e-4), False
    revs = check_int("revolutions", revs, 2, MAX_REVOLUTIONS)
    if max_revs is not None:
        check_int("max_revolutions", max_revs, revs, MAX_REVOLUTIONS)
    check_tolerance("steady_tol", tol)
    return StopRule(revs, max_revs, tol, single)
