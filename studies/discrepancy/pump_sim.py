"""valvelab's pump as the discrepancy workflow's model: run condition + effects -> one revolution.

A :class:`PumpSimulator` wraps a pump model (a shipped one or the user's model file).
Its baseline (CONTRACT.md) is :func:`lumped.model.effect_library.baseline` of that model (every
candidate effect off: its own effects dropped, air-free oil) with the air content of
run.toml when the run states it; candidate effects are applied from ``lumped.model.effect_library.LIBRARY``
(``lumped/model/effect_library.py``) with priors computed for that model.

How a revolution is computed (measured in docs/discrepancy.md, "Cost"):

- **Warm starts.** A fit simulates the same run condition hundreds of times for neighbouring
  parameter values. The workflow passes the state at top dead centre of the nearest model already
  solved (:class:`studies.discrepancy.simulations.Simulations`); from a near neighbour's two revolutions
  (WARM_REVOLUTIONS: with one, a fit on the reed read its cost 7.7 units low); from another
  model's (the one it extends, the baseline) two and more, until the delivery and the state at TDC settle
  (REVOLUTIONS). Without one, from the baseline's cycle, not the pump at rest (a squeeze film started cold at
  900 rpm creeps on its seat for seconds).
- **Tolerances.** rtol 1e-4 (FIT_RTOL), 1e-5 for a model whose fit reads the fine timing of a valve's
  motion (an effect declared ``tight_tolerance``: the squeeze film, the added mass). Against rtol 1e-7:
  0.1-0.4 um and 0.06-0.8 kPa RMS at 1e-4; the fast path's default 1e-3 left 1-60 um and 2.6-8 kPa (290 um
  on the reed with an added mass at 900 rpm), more than a gap unit of pressure (2.5 kPa), as integration
  noise the fits read as evidence. Where a squeeze film lets go is the most sensitive: at 3e-5 the fit cost
  of a delivery-valve film rippled by 30-60 units between C2 values 40 % apart and its minimum sat at a
  ninth of the truth; at 1e-5 and 1e-6 it is smooth, with its minimum at the truth (0.93 units).
- **The trace at the measurement times.** The dense output is sampled at the integrator's steps, their
  midpoints and 720 evenly spaced angles (TRACE_POINTS): linear interpolation between them is within
  0.13-0.36 kPa and 0.13 um RMS of the dense output at random angles (1,440 evenly spaced points: up to 9
  kPa with a squeeze film's pressure spike).
- **What is post-processed**: the delivery and the trace only (the pump's valve timing, impacts, losses
  and validity checks cost more than the revolution; ``studies.cli._warnings`` runs them once for the
  final model).

An integration that fails is retried: the fast path at its default tolerance, then the reference
integrator (``lumped.run.simulate.simulate``), each with a step budget (a candidate deep in an implausible corner
must fail in seconds).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import numpy as np

from lumped.run.simulate import InvariantError, check_invariants, simulate as pump_simulate
from lumped.model.effect_library import LIBRARY, baseline, resolve
from lumped.model.pump_model import PumpModel
from lumped.model.model_file import load_model

from studies.discrepancy.gap import CycleTrace
from studies.discrepancy.validation import INPUT, NUMERICS, TRUTH_RTOL   # noqa: F401 (TRUTH_RTOL: synth's tolerance)

__all__ = ["LIBRARY", "PumpSimulator", "simulate", "model_for", "fit_rtol"]

#: revolutions from a cold start (the first is the transient from the pump at rest) or from the state of a
#: model that is not a near neighbour; more, up to MAX_REVOLUTIONS, while the delivery or the state at TDC
#: still changes between the last two by more than the tolerance (lumped.run.revolutions.StopRule). One
#: revolution from the baseline's state is not enough where an effect changes the cycle's character: a
#: compliant seat with a squeeze film left 50-120 um and 27-107 kPa RMS after it (the disc sinks into the
#: seat it starts on, then hovers on the film from the second revolution on), within 0.03-0.13 um and 0.1 kPa
#: after two
REVOLUTIONS = 2
MAX_REVOLUTIONS = 4
#: the steady-state test of those (lumped.run.revolutions.cycle_change: delivery, cylinder mass, openings at TDC):
#: 1e-3 for the fits (a flow-force model's delivery still drifts by 1e-5 a revolution after the second, its
#: valves' TDC states by ~1e-4, at 1,400-2,800 steps a revolution: 8 revolutions were 5x the cost for nothing
#: the gap sees), 1e-5 for the truth (synthetic data, TRUTH_RTOL), up to 12 revolutions
STEADY_TOL = 1e-3
TRUTH_STEADY_TOL = 1e-5
TRUTH_MAX_REVOLUTIONS = 12
#: revolutions from a near neighbour's state (Simulations: the same effects within a factor 1.1). One revolution
#: from a converged neighbour is within 0.2 um and 0.85 kPa RMS of the cyclic steady state (a leak, the slowest
#: to settle; a chain of six 6 % steps on the reed within 0.15 kPa), yet inside a whole fit it was not enough: on
#: the reed with a strong fluid damping (c_f 14,740 Pa s/m, seed 1) the fit cost at c_f 10,464 and Cd 0.989 read
#: 65.3 units from the fit's warm starts where the settled cycle gives 73.0 (the truth 63.4), and the fit
#: stopped there (c_f -29 %). With two: c_f -1.3 %, the held-out cost that of the truth, 30 % more
#: simulations; a disc flow force (seed 2) named right instead of an added mass
WARM_REVOLUTIONS = 2
#: evenly spaced trace samples per revolution, besides the integrator's steps and their midpoints
TRACE_POINTS = 720
#: integrator tolerances of the fits (atol = rtol / 100, in each state's scale)
FIT_RTOL = 1e-4
TIGHT_RTOL = 1e-5
#: integrator steps allowed per revolution (tight: a squeeze film that sticks and creeps, 44-58k steps per
#: revolution, goes on to the retries in ~0.5 s)
MAX_STEPS = 100_000
MAX_STEPS_TIGHT = 20_000
#: what is tried after a failed integration: the fast path at its default tolerance (a sticking film at rtol
#: 3e-5 runs out of steps; at 1e-3 it gets through), then the reference
RETRIES = ({"rtol": 1e-3, "max_steps": 200_000}, {"method": "reference", "max_steps": 20_000})


@dataclass(frozen=True)
class PumpSimulator:
    """The workflow's simulator for one pump model (picklable: workers get a copy).

    ``rtol``: the integrator tolerance (None: FIT_RTOL, or TIGHT_RTOL for the effects that need it).
    """

    model: PumpModel
    rtol: float | None = None

    #: the workflow may pass the TDC state of a neighbouring model (``__call__(cond, effects, warm)``)
    warm_start = True
    #: it understands the ``input`` and ``numerics`` entries (validation uncertainty, model_for)
    validation = True

    @property
    def library(self):
        return LIBRARY

    @property
    def context(self) -> PumpModel:
        """What effect priors are computed for: the model itself (its geometry, oil, air content)."""
        return self.model

    def prepare(self) -> float:
        """:func:`prepare` (the workflow calls it before it forks its workers)."""
        return prepare()

    def accurate(self) -> "PumpSimulator":
        """This simulator at the truth's tolerance (synthetic data)."""
        return replace(self, rtol=TRUTH_RTOL)

    def model_for(self, cond, effects: tuple) -> PumpModel:
        """The model of a run condition: baseline, the run's stated air content, then the applied effects.

        Two entries of ``effects`` are not library effects: ``input`` (target ``pump``) moves model keys
        ({key path: value}, lumped.model.model_file.with_values; ``oil.air_content`` by its change from the
        model's own, on top of the run's stated air content) and ``numerics`` sets the tolerance (rtol), for
        the validation uncertainty (studies.discrepancy.validation)."""
        m = self.model
        inputs = {k: v for a in effects if a.name == INPUT for k, v in a.values}
        air_shift = 0.0
        if inputs:
            from lumped.model.model_file import with_values

            if "oil.air_content" in inputs:
                air_shift = inputs.pop("oil.air_content") - m.oil.air_content
            m = with_values(m, inputs) if inputs else m
        m = baseline(m)
        if cond.air_content is not None:
            air = max(0.0, float(cond.air_content) + air_shift)
            m = replace(m, oil=replace(m.oil, air_content=air))
        return m.with_effects(tuple(a for a in effects if a.name not in (INPUT, NUMERICS)))

    def __call__(self, cond, effects: tuple, warm=None) -> CycleTrace:
        """One revolution of cyclic steady state for a run condition with ``effects`` switched on.

        ``warm``: the state at TDC of a neighbouring model at the same condition, or (state, near): a near
        neighbour's (WARM_REVOLUTIONS from it), or another model's (two or more, until steady)."""
        model = self.model_for(cond, effects)
        asked = next((dict(a.values)["rtol"] for a in effects if a.name == NUMERICS), None)
        rtol = asked or self.rtol or fit_rtol(model)
        steps = MAX_STEPS_TIGHT if rtol == TIGHT_RTOL else MAX_STEPS
        state, near = (warm if isinstance(warm, tuple) else (warm, warm is not None))
        speed, load = cond.speed_rpm, cond.load_pressure_pa
        if model.circuit.kind == "complete":
            return _via_simulate(model, speed, load, rtol=rtol, max_steps=steps)
        with warnings.catch_warnings():   # scipy's finite-difference Jacobian warns on stiff contacts
            warnings.simplefilter("ignore", RuntimeWarning)
            try:
                if state is None and tuple(effects):
                    # start from the baseline's cycle, not from the pump at rest (a film started cold sticks)
                    state = revolution(self.model_for(cond, ()), speed, load, None, rtol, MAX_STEPS).state
                    near = False
                return revolution(model, speed, load, state, rtol, steps, near=near)
            except InvariantError:
                raise
            except RuntimeError as exc:
                first = exc
        for i, kw in enumerate(RETRIES):
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    if kw.get("method") == "reference":
                        return _via_simulate(model, speed, load, **kw)
                    return revolution(model, speed, load, state, max(rtol, kw["rtol"]), kw["max_steps"])
            except InvariantError:
                raise
            except RuntimeError as exc:
                if i == len(RETRIES) - 1:
                    raise RuntimeError(f"{exc} (first attempt: {first})") from exc
        raise AssertionError("unreachable")


def prepare() -> float:
    """The fast path compiled or loaded from numba's disk cache in this process (lumped.run.simulate.
    ensure_compiled; the seconds it took the first time): called before the workflow forks its workers, which
    then inherit it instead of each loading it (0.33 s a process)."""
    from lumped.run.simulate import ensure_compiled

    return ensure_compiled()


def revolution(model: PumpModel, speed_rpm: float, load_pressure: float, warm: np.ndarray | None, rtol: float,
               max_steps: int, near: bool = False) -> CycleTrace:
    """One revolution of cyclic steady state of the fast path (Rodas4P/5P, ``lumped.solver.steppers``): from ``warm`` (a TDC
    state) WARM_REVOLUTIONS if ``near`` (a near neighbour's), else (another model's, or from the pump at rest)
    REVOLUTIONS and more until the delivery and the TDC state stop changing (at most MAX_REVOLUTIONS); the trace
    at the steps, their midpoints and TRACE_POINTS even angles. Raises InvariantError for a result that breaks
    the pump's invariants."""
    from lumped.solver import switching as sw
    from lumped.run.simulate import _physics, ensure_compiled
    from lumped.solver.layout import N_MODE
    from lumped.run.postprocess import COL, mass_balance
    from lumped.solver.problem import PumpProblem
    from lumped.run.revolutions import StopRule, run
    from lumped.solver.steppers import METHODS

    ensure_compiled()
    problem = PumpProblem.build(model, speed_rpm, load_pressure)
    stepper = METHODS["fast"](problem, rtol, rtol / 100.0, record=True, max_steps=max_steps)
    physics = _physics("fast1" if problem.layout.one_dof else "fast")
    warm_ok = warm is not None and np.shape(warm) == (problem.layout.n_states,)
    y = np.array(warm, dtype=float) if warm_ok else problem.initial_state(physics.load_mass)
    if warm_ok and near:
        rule = StopRule(WARM_REVOLUTIONS)
    elif rtol <= TRUTH_RTOL:
        rule = StopRule(REVOLUTIONS, TRUTH_MAX_REVOLUTIONS, TRUTH_STEADY_TOL)
    else:
        rule = StopRule(REVOLUTIONS, MAX_REVOLUTIONS, STEADY_TOL)
    mode = np.zeros(N_MODE)
    sw.initial_mode(0.0, y, problem.p, mode)
    done = run(problem, stepper, y, mode, rule, physics, rtol=rtol, keep=1)
    span, last = done.kept[-1], done.last
    period = problem.period
    ts = _sample_times(span, period)
    ys, modes = span.sample(ts)
    rt = physics.rates_table(ts, ys, modes, problem.p)
    _check(problem, last, mass_balance(problem, last), rt[:, COL["p_cyl"]])
    crank = 360.0 * (ts - span.t0) / period
    out = CycleTrace(crank, {"inlet": rt[:, COL["x_in"]], "delivery": rt[:, COL["x_del"]]}, float(last.delivery),
                     rt[:, COL["p_cyl"]])
    object.__setattr__(out, "state", np.array(span.y_end, dtype=float))
    object.__setattr__(out, "steps", int(done.n_steps))
    object.__setattr__(out, "revolutions", len(done.revolutions))
    object.__setattr__(out, "cycle_change", float(done.change))
    return out


def _sample_times(span, period: float) -> np.ndarray:
    """Times of one revolution's trace: TRACE_POINTS even ones, the integrator's steps and their midpoints."""
    even = span.t0 + period * np.arange(TRACE_POINTS) / TRACE_POINTS
    steps = _step_times(span)
    if steps is None:
        return span.t0 + period * np.arange(4 * TRACE_POINTS) / (4 * TRACE_POINTS)
    steps = steps[(steps >= span.t0) & (steps < span.t0 + period)]
    t = np.unique(np.concatenate([even, steps, 0.5 * (steps[1:] + steps[:-1])]))
    return t[(t >= span.t0) & (t < span.t0 + period * (1.0 - 1e-12))]


def _step_times(span) -> np.ndarray | None:
    """The fast stepper's recorded step times (the dense output's knots), None for another stepper."""
    t = getattr(span.sampler, "step_times", None)
    return None if t is None else np.asarray(t, dtype=float)


def _check(problem, last, mass_error: float, p_cyl: np.ndarray) -> None:
    """The invariants of lumped.run.simulate.check_invariants on one revolution: a finite delivery within the swept
    volume, the mass balance, a finite pressure."""
    from lumped.run.simulate import DELIVERY_LIMITS, MASS_BALANCE_LIMIT

    if not (math.isfinite(last.delivery) and np.all(np.isfinite(p_cyl))):
        raise InvariantError("the integration left the model's domain (NaN)")
    if mass_error > MASS_BALANCE_LIMIT:
        raise InvariantError(f"mass balance error {mass_error:.2e} per revolution exceeds {MASS_BALANCE_LIMIT:g}")
    m = problem.model
    supercharge = m.oil.density_at(m.pump.tank_pressure) / m.oil.density
    d = last.delivery / m.pump.displacement
    lo, hi = DELIVERY_LIMITS
    if not lo <= d <= hi * supercharge:
        raise InvariantError(f"delivery {last.delivery * 1e6:.4g} cc/rev is {d:.3g} swept volumes")


def _via_simulate(model: PumpModel, speed: float, load: float, **kw) -> CycleTrace:
    """lumped.run.simulate.simulate (the reference integrator, or a complete circuit): 2 revolutions from rest, the
    trace at 4 x TRACE_POINTS even angles."""
    kw = {k: v for k, v in kw.items() if k in ("method", "rtol", "max_steps")}
    if kw.get("method") == "reference":
        kw.pop("rtol", None)
    res = pump_simulate(model, speed, load, revolutions=REVOLUTIONS, max_revolutions=None if
                        model.circuit.kind != "complete" else 20, trace=True, trace_points=4 * TRACE_POINTS,
                        check=False, **kw)
    check_invariants(res, resolve(model))
    tr = res.trace.fold()
    return CycleTrace(tr.crank_deg, {"inlet": np.asarray(tr.inlet_position), "delivery": np.asarray(tr.delivery_position)},
                      float(res.delivery_per_rev), np.asarray(tr.cylinder_pressure))


def fit_rtol(model: PumpModel) -> float:
    """The integrator tolerance a fit simulates ``model`` at: TIGHT_RTOL where an effect declared
    ``tight_tolerance`` is applied or a valve carries a squeeze film of its own, else FIT_RTOL."""
    return TIGHT_RTOL if _needs_smooth(model) else FIT_RTOL


def _needs_smooth(model: PumpModel) -> bool:
    """Whether ``model`` is simulated at TIGHT_RTOL: an effect declared ``tight_tolerance`` applied, or a
    valve that carries a squeeze film of its own (lumped.valves.disc: C2 > 0, effects applied)."""
    if any(a.name in LIBRARY and LIBRARY[a.name].tight_tolerance for a in model.effects):
        return True
    m = resolve(model)
    return any(getattr(m.valve(v), "squeeze_c2", 0.0) > 0.0 for v in ("inlet", "delivery"))


def for_valve_type(valve_type: str) -> PumpSimulator:
    """The simulator of the shipped thesis model of a valve type ("disc" -> thesis-disc)."""
    return PumpSimulator(load_model(valve_type))


def simulate(cond, effects: tuple, warm=None) -> CycleTrace:
    """The module protocol (``simulate(condition, effects)``): the thesis model of the run's valve type."""
    return for_valve_type(cond.valve_type)(cond, effects, warm)


simulate.warm_start = True
simulate.prepare = prepare


def model_for(cond, effects: tuple) -> PumpModel:
    """The model of a run condition under the thesis model of its valve type."""
    return for_valve_type(cond.valve_type).model_for(cond, effects)
