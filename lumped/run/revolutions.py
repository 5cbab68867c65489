"""The revolution runner: revolutions from top dead centre until a stop rule says the pump is steady.

:func:`run` advances a :class:`~lumped.solver.problem.PumpProblem` one revolution at a time with a
stepper (:mod:`lumped.solver.steppers`) and keeps, per revolution, what the result needs: the
delivery (eq 4.17 at atmospheric density), the mass balance of the running totals, the
mean load pressure, the leakage and the change of the state at TDC from the revolution
before. The complete circuit's needle valve is set here, like the experimenter's start-up
procedure (section 5.5.2). :class:`StopRule` says when to stop.

Where a run starts: today's start (:meth:`lumped.solver.problem.PumpProblem.initial_state`: the
cylinder full at the load pressure, the valves at rest on their seats), or a *warm start*,
the state at TDC a solved run ended with (:class:`TdcState`, ``PumpResult.tdc_state``),
carried over to the problem at hand by :meth:`TdcState.start`. The revolution map of these
pumps contracts hard (a valve that reseats forgets its past): from today's start the first
revolution's delivery is 3-10 % off and the second is within the integrator's noise of a
40-revolution run, so a run from a close design's state is steady after its first revolution.
The stop rule can confirm it with the second or, with ``StopRule(single=True)``, with the first
alone: the state at TDC it ends with is then compared with the state it started from
(:func:`first_change`).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field

import numpy as np

from lumped.solver.layout import BLOCK_OFFSET, G, LOAD_STATES, S_MCYL
from lumped.valves.kind import VALVE


#: the studies' steady-state tolerance. The test measures the change the *previous* revolution still
#: made; the revolution map contracts so hard (a valve that reseats forgets its past) that a change below
#: 1e-3 leaves the last revolution's delivery within 1e-4 of the cycle's (measured: docs/models.md,
#: "Numerical choices")
STEADY_TOL = 1e-3
#: the one-revolution test's tolerance as a fraction of the steady-state tolerance. It compares states only
#: (a first revolution's delivery has no predecessor), and a valve's opening at TDC changed by a fraction of
#: its gap moves the delivery by about a tenth of that, hence the margin; it stops a warm-started design after
#: one revolution as accurately as two would (docs/models.md, "Numerical choices"). The sweeps use it
#: (studies/sweeps/pump.py)
SINGLE_FRACTION = 0.2


@dataclass(frozen=True)
class StopRule:
    """When a run of the pump stops: after a number of revolutions, or at the cyclic steady state.

    Run at least ``revolutions``; with ``max_revolutions`` (> revolutions) continue until the cyclic
    steady state (relative change of the delivery and of the state at TDC between the last two
    revolutions below ``tol``, or the integrator's rtol if larger: :func:`cycle_change`) or that many.

    ``single``: a run that starts from a solved state (a warm start) may stop after its first revolution,
    when the state at TDC it ends with is within ``SINGLE_FRACTION`` x the tolerance of the state it
    started from (:func:`first_change`: the start is then a fixed point of the revolution map to that
    tolerance, and the revolution run from it is the cycle's).

    :meth:`steady` is the rule of the studies: stop as soon as the test passes (two revolutions at
    least, since the test compares two; one with ``single`` from a warm start), at most ``max_revolutions``.
    """

    revolutions: int = 5
    max_revolutions: int | None = None
    tol: float = 1e-4
    single: bool = False

    @property
    def limit(self) -> int:
        return self.max_revolutions or self.revolutions

    @classmethod
    def steady(cls, tol: float = STEADY_TOL, max_revolutions: int = 40, min_revolutions: int = 2,
               single: bool = False) -> "StopRule":
        """Until the cyclic steady-state test passes at ``tol`` (floored at the integrator's rtol), at least
        ``min_revolutions`` (>= 2), at most ``max_revolutions``; ``single``: a warm start may stop after
        its first revolution (see the class)."""
        from geometry.errors import InputError

        if isinstance(min_revolutions, bool) or not isinstance(min_revolutions, int) or min_revolutions < 2:
            raise InputError("min_revolutions", f"expected an integer >= 2 (the test compares two), got {min_revolutions!r}")
        if isinstance(max_revolutions, bool) or not isinstance(max_revolutions, int) or max_revolutions < min_revolutions:
            raise InputError("max_revolutions", f"expected an integer >= {min_revolutions}, got {max_revolutions!r}")
        if not isinstance(tol, (int, float)) or isinstance(tol, bool) or not 0.0 < tol < 0.1:
            raise InputError("steady_tol", f"expected a number in (0, 0.1), got {tol!r}")
        return cls(min_revolutions, max_revolutions, float(tol), bool(single))

    def tolerance(self, rtol: float) -> float:
        """The tolerance the steady-state test uses with an integrator at ``rtol`` (below it the change of
        a revolution is the integrator's noise, not the approach to the cycle)."""
        return max(self.tol, rtol)


@dataclass(frozen=True, eq=False)
class TdcState:
    """The state at top dead centre a run ended with: where the next revolution starts (a warm start).

    ``y``: the state (running totals zero); ``mode``: its mode; ``reference``: today's start of the
    problem it came from (:meth:`lumped.solver.problem.PumpProblem.initial_state`), by which the oil masses
    are carried over; ``gaps``: each valve's stop gap [m], by which its coordinates are;
    ``signature``: the layout and the valve kinds (a state fits only a pump with the same ones);
    ``needle_cda``: the complete circuit's tuned needle valve Cd A [m^2] (None: simplified);
    ``period``: the revolution [s]; ``memory``: the stepper's step-size memory (fast path) or None.
    """

    y: np.ndarray
    mode: np.ndarray
    reference: np.ndarray
    gaps: tuple
    signature: tuple
    needle_cda: float | None = None
    period: float = 0.0
    memory: dict | None = None

    @staticmethod
    def signature_of(problem) -> tuple:
        """What a state must share with a problem to start it: the state layout and each valve's kind."""
        from lumped.valves.kind import kind_of

        lay = problem.layout
        return (lay.dofs, lay.scalars, lay.complete,
                tuple(kind_of(problem.model.valve(pos)).name for pos in ("inlet", "delivery")))

    def fits(self, problem) -> bool:
        return self.signature == self.signature_of(problem)

    def start(self, problem, load_mass) -> tuple[np.ndarray, np.ndarray]:
        """(state, mode) to start ``problem`` from: each oil mass scaled by the ratio of the two problems'
        start values (dead volume and density at the load pressure: the same cylinder density relative to
        today's start), each valve's coordinates and rates by the ratio of the stop gaps (the same
        fraction of the stroke), the running totals zero; the mode kept where its switching functions
        hold, else decided from the state (:func:`mode_for`)."""
        ref = problem.initial_state(load_mass)
        y = self.y.copy()
        for i in _mass_states(problem.layout):
            if self.reference[i] != 0.0:
                y[i] *= ref[i] / self.reference[i]
        for v, o in enumerate(BLOCK_OFFSET):
            ratio = problem.p[o + VALVE.stop_gap] / self.gaps[v]
            if ratio != 1.0:
                y[problem.layout.positions(v)] *= ratio
                y[problem.layout.rates(v)] *= ratio
        for i in problem.layout.quadratures.values():
            y[i] = 0.0
        return y, mode_for(problem, y, self.mode)


    @property
    def layout(self):
        """The state layout (lumped.solver.layout.StateLayout) this state belongs to."""
        from lumped.solver.layout import StateLayout

        dofs, scalars, complete, _ = self.signature
        return StateLayout(dofs, complete, scalars)

    def normalized(self) -> np.ndarray:
        """The state in units of where it came from: each oil mass over today's start of its problem, each
        valve's coordinates and rates over its stop gap (what :meth:`start` carries over)."""
        lay, y = self.layout, self.y.copy()
        for i in _mass_states(lay):
            if self.reference[i] != 0.0:
                y[i] /= self.reference[i]
        for v in range(len(self.gaps)):
            y[lay.positions(v)] /= self.gaps[v]
            y[lay.rates(v)] /= self.gaps[v]
        return y

    def with_normalized(self, yn: np.ndarray) -> "TdcState":
        """This state's mode, signature and step memory with the state ``yn`` in normalized units
        (:meth:`normalized`): e.g. a prediction from several solved designs."""
        ref = np.zeros_like(self.reference)
        for i in _mass_states(self.layout):
            ref[i] = 1.0 if self.reference[i] != 0.0 else 0.0
        return TdcState(np.array(yn, dtype=float), self.mode, ref, (1.0,) * len(self.gaps), self.signature,
                        self.needle_cda, self.period, self.memory)


def _mass_states(layout) -> tuple:
    out = [S_MCYL]
    if layout.complete:
        out.append(layout.index(LOAD_STATES[0]))
    return tuple(out)


def mode_for(problem, y: np.ndarray, mode: np.ndarray | None = None) -> np.ndarray:
    """A mode for state ``y`` at TDC in which every switching function holds (>= 0): ``mode`` if it does,
    else the one :func:`lumped.solver.switching.initial_mode` decides from the state, with any switch that
    function still fires made at once (a valve at rest on a surface whose force already lets go)."""
    from lumped.solver import switching as sw
    from lumped.solver.layout import N_MODE, N_SWITCHES

    p = problem.p
    g = np.empty(N_SWITCHES + problem.layout.n_states)
    if mode is not None:
        m = np.array(mode, dtype=float)
        sw.switch_values(0.0, y, p, m, g)
        if np.all(g[:N_SWITCHES] >= 0.0):
            return m
    m = np.zeros(N_MODE)
    sw.initial_mode(0.0, y, p, m)
    for _ in range(2 * N_SWITCHES):
        sw.switch_values(0.0, y, p, m, g)
        bad = np.flatnonzero(g[:N_SWITCHES] < 0.0)
        if not len(bad):
            break
        sw.apply_switch(int(bad[0]), y, p, m)
    return m


@dataclass
class Revolution:
    """One revolution: its span (lumped.solver.steppers.Span), the state at its start, delivery [m^3 at
    atmospheric density], mass-balance error [-], mean load pressure [Pa], leakage [m^3]."""

    index: int
    span: object
    y_start: np.ndarray
    delivery: float
    mass_error: float
    mean_load_pressure: float
    leakage: float


@dataclass
class Run:
    """What :func:`run` returns: the revolutions (the last ``keep`` spans kept), whether and how
    steady, and the counts."""

    revolutions: list = field(default_factory=list)
    kept: list = field(default_factory=list)
    steady: bool = False
    change: float = math.inf
    tol: float = 0.0                      # what ``change`` was tested against (0: not tested)
    n_rhs: int = 0
    n_steps: int = 0
    n_events: int = 0
    y_end: np.ndarray | None = None       # the state and mode the last revolution ended with (the next start)
    mode_end: np.ndarray | None = None

    @property
    def last(self) -> Revolution:
        return self.revolutions[-1]

    @property
    def deliveries(self) -> tuple:
        return tuple(r.delivery for r in self.revolutions)


def tdc_change(problem, a: np.ndarray, b: np.ndarray) -> float:
    """Largest relative difference of two states at TDC: cylinder mass (per swept mass), each valve's
    opening (per stop gap), the load line's mass (per swept mass)."""
    from lumped.solver.layout import opening

    p, m_rev = problem.p, problem.m_rev
    ch = [abs(a[S_MCYL] - b[S_MCYL]) / m_rev]
    for o in BLOCK_OFFSET:
        ch.append(abs(opening(a, p, o)[0] - opening(b, p, o)[0]) / p[o + VALVE.stop_gap])
    if problem.complete:
        i = problem.layout.index(LOAD_STATES[0])
        ch.append(abs(a[i] - b[i]) / m_rev)
    return float(max(ch))


def cycle_change(problem, deliveries, states) -> float:
    """Largest relative change between the last two revolutions: delivery, cylinder mass, each valve's
    opening at TDC (per stop gap), the load line's mass (:func:`tdc_change`)."""
    d1, d0 = deliveries[-1], deliveries[-2]
    return max(abs(d1 - d0) / max(abs(d1), 1e-300), tdc_change(problem, states[-1], states[-2]))


def first_change(problem, y_start: np.ndarray, y_end: np.ndarray, delivered: float) -> float:
    """The residual of the revolution map at a start: the largest relative change of the state at TDC over
    one revolution (:func:`tdc_change`), and the cylinder's mass change over the mass delivered (at the
    cycle it is zero, and any drift adds to the delivery one to one: m_out = m_in - m_leak - dm_cyl)."""
    from lumped.run.postprocess import MASS_FLOOR

    drift = abs(y_end[S_MCYL] - y_start[S_MCYL]) / max(abs(delivered), MASS_FLOOR * problem.m_rev)
    return max(drift, tdc_change(problem, y_end, y_start))


def mean_load_pressure(problem, span, physics) -> float:
    """Time-mean load pressure over a span [Pa] (the requested one in the simplified circuit)."""
    p = problem.p
    if not problem.complete:
        return float(p[G.load_pressure])
    i = problem.layout.index(LOAD_STATES[0])
    ts = np.linspace(span.t0, span.t1, 121)
    ys, _ = span.sample(ts)
    vals = [physics.load_pressure(float(yy[i]), p)[0] for yy in ys]
    return float(np.trapezoid(vals, ts) / (span.t1 - span.t0))


def run(problem, stepper, y: np.ndarray, mode: np.ndarray, rule: StopRule, physics, *, rtol: float,
        **options) -> Run:
    """Revolutions from TDC until ``rule`` stops them.

    Parameters
    ----------
    problem : lumped.solver.problem.PumpProblem
        The packed pump.
    stepper : lumped.solver.steppers.Stepper
        What advances it a revolution at a time.
    y, mode : numpy.ndarray
        The state and mode at TDC to start from.
    rule : StopRule
        When to stop.
    physics
        The driver's pump functions (lumped.run.simulate._Physics: load pressure and mass).
    rtol : float
        The integrator's relative tolerance (the steady-state test's floor).
    **options
        ``keep`` (how many of the last spans to keep, for a trace; 0), ``progress`` (a bar on stderr),
        ``label`` (its text), ``warm`` (``y`` is a solved state: ``rule.single`` may then stop the run after
        one revolution).

    Returns
    -------
    Run
    """
    keep = options.get("keep", 0)
    out = Run()
    tdc_states = [y.copy()]
    # the needle valve's tuning (complete circuit) needs revolutions of its own: no single revolution there
    single = rule.single and options.get("warm", False) and not problem.complete
    tuning = _NeedleTuning(problem, physics, None if problem.tune_needle else 0)
    bar = _progress_bar(options.get("progress", False), rule.limit, options.get("label", ""))
    k = 0
    while k < rule.limit:
        y_start = y.copy()
        span = stepper.advance(k * problem.period, (k + 1) * problem.period, y, mode)
        y, mode = span.y_end.copy(), span.mode_end.copy()
        out.n_rhs += span.n_rhs
        out.n_steps += span.n_steps
        out.n_events += span.n_events
        rev = _revolution(problem, k, span, y_start, y, mean_load_pressure(problem, span, physics))
        tuning.update(k, rev, y_start, y)
        out.revolutions.append(rev)
        tdc_states.append(y.copy())
        _steady_test(out, problem, rule, rtol, tdc_states, k, single, tuning.settled(k))
        if keep:
            out.kept = (out.kept + [span])[-keep:]
        k += 1
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"{out.revolutions[-1].delivery * 1e6:.4f} cc/rev")
        if (k >= rule.revolutions or (single and k == 1)) and out.steady:
            break
    if bar is not None:
        bar.close()
    out.y_end, out.mode_end = y, mode
    return out


def _revolution(problem, k: int, span, y_start: np.ndarray, y: np.ndarray, pl_mean: float) -> Revolution:
    """The :class:`Revolution` k from its span and its start and end states: delivery and leakage at atmospheric
    density (eq 4.17), the mass balance of the running totals."""
    q = problem.layout.quadratures
    i_in, i_out, i_leak = q["m_in"], q["m_out"], q["m_leak"]
    d_in, d_out, d_leak = y[i_in] - y_start[i_in], y[i_out] - y_start[i_out], y[i_leak] - y_start[i_leak]
    d_cyl = y[S_MCYL] - y_start[S_MCYL]
    mass_err = abs(d_cyl - (d_in - d_out - d_leak)) / max(abs(d_in), abs(d_out), 1e-300)
    return Revolution(k, span, y_start, d_out / problem.rho0, mass_err, pl_mean, d_leak / problem.rho0)


class _NeedleTuning:
    """The complete circuit's start-up procedure, like the experimenter's needle-valve setting (section 5.5.2):
    after each revolution the needle flow is matched to the delivery at the requested mean pressure and the
    load-side mass moved to it (the cylinder and its mass balance untouched), until both hold to 2e-4; the
    needle valve is frozen from then on (``tuned_at``: the revolution count then; 0: nothing to tune)."""

    def __init__(self, problem, physics, tuned_at: int | None):
        self.problem, self.physics, self.tuned_at = problem, physics, tuned_at

    def update(self, k: int, rev: Revolution, y_start: np.ndarray, y: np.ndarray) -> None:
        if self.tuned_at is not None:
            return
        problem, p = self.problem, self.problem.p
        q = problem.layout.quadratures
        i_out, i_nv, i_load = q["m_out"], q["m_nv"], problem.layout.index(LOAD_STATES[0])
        load, pl_mean = problem.load_pressure, rev.mean_load_pressure
        d_out, d_nv = y[i_out] - y_start[i_out], y[i_nv] - y_start[i_nv]
        a_old = p[G.needle_cda]
        a_new = a_old * (d_out / d_nv) * math.sqrt((pl_mean - p[G.tank_pressure]) / (load - p[G.tank_pressure]))
        if abs(a_new / a_old - 1.0) < 2e-4 and abs(pl_mean / load - 1.0) < 2e-4:
            self.tuned_at = k + 1                                  # needle valve frozen from here on
        else:
            p[G.needle_cda] = a_new
            y[i_load] += self.physics.load_mass(load, p)[0] - self.physics.load_mass(pl_mean, p)[0]

    def settled(self, k: int) -> bool:
        """Two revolutions run with the needle valve frozen (after revolution k)."""
        return self.tuned_at is not None and k + 1 - self.tuned_at >= 2


def _steady_test(out: Run, problem, rule: StopRule, rtol: float, tdc_states: list, k: int, single: bool,
                 settled: bool) -> None:
    """After revolution k: the cyclic steady-state test (:func:`cycle_change` from the second revolution on,
    :func:`first_change` after a single warm one) into ``out.change``, ``out.tol``, ``out.steady``."""
    if k >= 1:
        out.change = cycle_change(problem, out.deliveries, tdc_states)
        out.tol = rule.tolerance(rtol)
        out.steady = out.change < out.tol and (not problem.complete or settled)
    elif single:
        i_out = problem.layout.quadratures["m_out"]
        delivered = tdc_states[-1][i_out] - tdc_states[-2][i_out]          # the mass delivered [kg]
        out.change = first_change(problem, tdc_states[0], tdc_states[-1], delivered)
        out.tol = SINGLE_FRACTION * rule.tolerance(rtol)
        out.steady = out.change < out.tol


def tdc_state(problem, done: Run, load_mass, stepper=None) -> TdcState:
    """The :class:`TdcState` a finished run ended with (``load_mass``: lumped.solver.rhs.load_mass, for the
    reference start; ``stepper``: its step-size memory is kept when it has one)."""
    y = done.y_end.copy()
    for i in problem.layout.quadratures.values():
        y[i] = 0.0
    gaps = tuple(float(problem.p[o + VALVE.stop_gap]) for o in BLOCK_OFFSET)
    memory = stepper.memory() if hasattr(stepper, "memory") else None
    return TdcState(y, done.mode_end.copy(), problem.initial_state(load_mass), gaps, TdcState.signature_of(problem),
                    float(problem.p[G.needle_cda]) if problem.complete else None, problem.period, memory)


def _progress_bar(progress: bool, total: int, desc: str):
    if not progress:
        return None
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit="rev", file=sys.stderr, leave=False)

