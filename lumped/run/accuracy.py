"""The fast path's answer checked a posteriori: the reported revolution integrated again, tighter.

At its default tolerance (rtol 1e-3) the fast path resolves the thesis pumps' events to a fraction of a degree,
but not every design's: a ball pump whose inlet opens on a slow pressure decay opened 7 deg late against the
reference (tests/test_pump_fast.py). So after a fast run the revolution it reports is integrated once more from
the same state at top dead centre with both tolerances divided by :data:`TIGHTEN` and the two compared on what
the outputs depend on: each valve's opening and closing angle, its peak opening and the delivery. Within half the
limits (:data:`ANGLE_LIMIT`, :data:`DELIVERY_LIMIT`, :data:`PEAK_LIMIT`) the run's answer stands. Beyond, the
tighter revolution is the answer and is itself checked against one tighter still, up to :data:`MAX_LEVELS`
times; a difference still beyond the limits at the tightest level is reported as a ``numerical_accuracy``
warning (:mod:`lumped.validity`) with the estimated error (the last difference), not passed off as a result.

The difference of two levels estimates the coarser one's error (the finer is ~10x more accurate for a method of
order 4-5 on smooth stretches; an event moved by a tolerance is what this catches). Measured on random designs
of every kind and effect: ``benchmarks/fast_accuracy_study.py``, docs/performance.md ("The fast path's accuracy
check").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: tolerances divided by this for each tighter level
TIGHTEN = 10.0
#: the most levels tried beyond the run's own (rtol 1e-3 -> 1e-4 -> 1e-5)
MAX_LEVELS = 2
#: the limits a reported answer must meet: an opening or closing angle [rad]
ANGLE_LIMIT = math.radians(0.5)
#: ... the delivery [-, relative to it]
DELIVERY_LIMIT = 5e-4
#: ... a valve's peak opening [-, relative to its stop gap]
PEAK_LIMIT = 0.01
#: a delivery below this fraction of the swept volume is compared on it instead (lumped.run.postprocess.MASS_FLOOR)
DELIVERY_FLOOR = 1e-2
#: a level is accepted when its difference from the next is below this fraction of the limits
MARGIN = 0.5


@dataclass(frozen=True)
class Difference:
    """How two integrations of one revolution differ: the largest event angle difference [rad] (inf: an event in
    one and not the other), the relative delivery difference [-], the largest peak opening difference relative to
    the valve's stop gap [-]."""

    angle: float
    delivery: float
    peak: float

    def within(self, fraction: float = 1.0) -> bool:
        """Every difference within ``fraction`` of its limit."""
        return (self.angle <= fraction * ANGLE_LIMIT and self.delivery <= fraction * DELIVERY_LIMIT
                and self.peak <= fraction * PEAK_LIMIT)

    def describe(self) -> str:
        """The differences in words (degrees, percent)."""
        angle = "an event present in one and not the other" if math.isinf(self.angle) else \
            f"event angles by {math.degrees(self.angle):.2g} deg"
        return (f"{angle}, the delivery by {100 * self.delivery:.2g} %, peak openings by "
                f"{100 * self.peak:.2g} % of the lift")


def _angle_gap(a, b) -> float:
    if (a is None) != (b is None):
        return math.inf
    if a is None:
        return 0.0
    d = abs(a - b) % (2 * math.pi)
    return min(d, 2 * math.pi - d)


def outputs(problem, rev) -> tuple:
    """(angles [rad], peak openings [m], delivery [m^3]) of one revolution (lumped.run.revolutions.Revolution)."""
    from lumped.run import postprocess as post

    openings, closings, _ = post.valve_timing(rev.span, problem, rev.y_start)
    return tuple(openings) + tuple(closings), tuple(float(p) for p in rev.span.peaks), rev.delivery


def difference(problem, a, b) -> Difference:
    """How revolutions ``a`` and ``b`` (the same revolution, integrated twice) differ (:class:`Difference`)."""
    from lumped.model.pump_model import POSITIONS

    angles_a, peaks_a, d_a = outputs(problem, a)
    angles_b, peaks_b, d_b = outputs(problem, b)
    gaps = [problem.model.valve(pos).common(problem.model.oil).stop_gap for pos in POSITIONS]
    angle = max((_angle_gap(x, y) for x, y in zip(angles_a, angles_b)), default=0.0)
    peak = max(abs(x - y) / g for x, y, g in zip(peaks_a, peaks_b, gaps))
    if any(a is None for a in angles_a[:2] + angles_b[:2]):
        # a valve that never opens: the delivery is nothing by construction (lumped.validity.pump_warnings)
        return Difference(angle, 0.0, peak)
    scale = max(abs(d_b), DELIVERY_FLOOR * problem.model.pump.displacement)   # a pump that barely delivers
    return Difference(angle, abs(d_a - d_b) / scale, peak)


def again(problem, stepper_class, rev, mode, physics, rtol: float, atol: float, options: dict):
    """Revolution ``rev`` integrated again from its state at TDC (and ``mode``) at ``rtol``, ``atol``: the
    :class:`lumped.run.revolutions.Run` of that one revolution."""
    from lumped.run.revolutions import StopRule, run

    stepper = stepper_class(problem, rtol, atol, record=True, **options)
    t0 = rev.index * problem.period
    y, m = rev.y_start.copy(), mode.copy()
    one = run(problem, _Shifted(stepper, t0), y, m, StopRule(revolutions=1), physics, rtol=rtol)
    one.last.index = rev.index
    return one


class _Shifted:
    """A stepper seen from a revolution's own start time (the crank angle is periodic, the time is not)."""

    def __init__(self, stepper, t0: float):
        self.stepper, self.t0 = stepper, t0

    def advance(self, t0, t1, y, mode):
        return self.stepper.advance(self.t0 + t0, self.t0 + t1, y, mode)


@dataclass
class Outcome:
    """What :func:`check` found: ``level`` the tightening of the reported revolution (0: the run's own, 1: rtol
    / TIGHTEN, ...), its ``rtol``, the last :class:`Difference` (of the reported level against the next, or of
    the last two levels), whether it is within the limits (``resolved``), the extra steps spent."""

    level: int
    rtol: float
    difference: Difference
    resolved: bool
    extra_steps: int


def check(problem, done, stepper_class, physics, rtol: float, atol: float, options: dict) -> Outcome:
    """The a-posteriori check of a fast run's reported revolution (the module docstring): the revolution at the
    run's tolerances is accepted when one at tolerances :data:`TIGHTEN` times tighter differs from it by less than
    :data:`MARGIN` of the limits; otherwise the tighter one is tried the same way, up to :data:`MAX_LEVELS`.

    Parameters
    ----------
    problem : lumped.solver.problem.PumpProblem
    done : lumped.run.revolutions.Run
        The finished run; its last revolution (and kept span, end state) is replaced by the level reported.
    stepper_class
        The fast stepper's class (``Stepper(problem, rtol, atol, **options)``).
    physics
        The driver's pump functions.
    rtol, atol : float
        The run's tolerances.
    options : dict
        The stepper's other options (``contact_atol``, ``max_steps``).

    Returns
    -------
    Outcome
    """
    from lumped.run.revolutions import mode_for

    last = done.last
    before = done.revolutions[-2].span.mode_end if len(done.revolutions) > 1 else None
    mode = mode_for(problem, last.y_start, before)
    current, extra, diff = last, 0, None
    for level in range(1, MAX_LEVELS + 1):
        r, a = rtol / TIGHTEN ** level, atol / TIGHTEN ** level
        finer = again(problem, stepper_class, last, mode, physics, r, a, options)
        extra += finer.n_steps
        diff = difference(problem, current, finer.last)
        if diff.within(MARGIN):
            return Outcome(level - 1, rtol / TIGHTEN ** (level - 1), diff, True, extra)
        current = finer.last                    # the coarser level is rejected: the finer one is the answer
        done.revolutions[-1] = current
        if done.kept:
            done.kept[-1] = current.span
        done.y_end, done.mode_end = finer.y_end, finer.mode_end
    return Outcome(MAX_LEVELS, rtol / TIGHTEN ** MAX_LEVELS, diff, diff.within(1.0), extra)
