"""The revolution runner: revolutions from top dead centre until a stop rule says the pump is steady.

:func:`run` advances a :class:`~lumped.problem.PumpProblem` one revolution at a time with a
stepper (:mod:`lumped.steppers`) and keeps, per revolution, what the result needs: the
delivery (eq 4.17 at atmospheric density), the mass balance of the running totals, the
mean load pressure, the leakage and the change of the state at TDC from the revolution
before. The complete circuit's needle valve is set here, like the experimenter's start-up
procedure (section 5.5.2). :class:`StopRule` says when to stop.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field

import numpy as np

from lumped.layout import BLOCK_OFFSET, G, LOAD_STATES, S_MCYL
from lumped.valve import VALVE


@dataclass(frozen=True)
class StopRule:
    """Run at least ``revolutions``; with ``max_revolutions`` (> revolutions) continue until the cyclic
    steady state (relative change of the delivery and of the state at TDC between the last two
    revolutions below ``tol``, or the integrator's rtol if larger) or that many."""

    revolutions: int = 5
    max_revolutions: int | None = None
    tol: float = 1e-4

    @property
    def limit(self) -> int:
        return self.max_revolutions or self.revolutions


@dataclass
class Revolution:
    """One revolution: its span (lumped.steppers.Span), the state at its start, delivery [m^3 at
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
    n_rhs: int = 0
    n_steps: int = 0
    n_events: int = 0

    @property
    def last(self) -> Revolution:
        return self.revolutions[-1]

    @property
    def deliveries(self) -> tuple:
        return tuple(r.delivery for r in self.revolutions)


def cycle_change(problem, deliveries, states) -> float:
    """Largest relative change between the last two revolutions: delivery, cylinder mass, each valve's
    opening at TDC (per stop gap), the load line's mass."""
    from lumped.layout import opening

    p, m_rev = problem.p, problem.m_rev
    d1, d0 = deliveries[-1], deliveries[-2]
    a, b = states[-1], states[-2]
    ch = [abs(d1 - d0) / max(abs(d1), 1e-300), abs(a[S_MCYL] - b[S_MCYL]) / m_rev]
    for o in BLOCK_OFFSET:
        ch.append(abs(opening(a, p, o)[0] - opening(b, p, o)[0]) / p[o + VALVE.stop_gap])
    if problem.complete:
        i = problem.layout.index(LOAD_STATES[0])
        ch.append(abs(a[i] - b[i]) / m_rev)
    return float(max(ch))


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
        keep: int = 0, progress: bool = False, label: str = "") -> Run:
    """Revolutions from TDC (state ``y``, mode ``mode``) until ``rule`` stops them; the last ``keep``
    spans are kept for a trace."""
    lay, p = problem.layout, problem.p
    q = lay.quadratures
    i_in, i_out, i_leak, i_nv = q["m_in"], q["m_out"], q["m_leak"], q["m_nv"]
    i_load = lay.index(LOAD_STATES[0])
    period, rho0, load = problem.period, problem.rho0, problem.load_pressure
    out = Run()
    tdc_states = [y.copy()]
    tuned_at = None if problem.tune_needle else 0
    bar = _progress_bar(progress, rule.limit, label)
    k = 0
    while k < rule.limit:
        y_start = y.copy()
        span = stepper.advance(k * period, (k + 1) * period, y, mode)
        y, mode = span.y_end.copy(), span.mode_end.copy()
        out.n_rhs += span.n_rhs
        out.n_steps += span.n_steps
        out.n_events += span.n_events
        d_in, d_out, d_leak = y[i_in] - y_start[i_in], y[i_out] - y_start[i_out], y[i_leak] - y_start[i_leak]
        d_cyl = y[S_MCYL] - y_start[S_MCYL]
        mass_err = abs(d_cyl - (d_in - d_out - d_leak)) / max(abs(d_in), abs(d_out), 1e-300)
        pl_mean = mean_load_pressure(problem, span, physics)
        if tuned_at is None:
            # start-up procedure, like the experimenter's needle-valve setting (section 5.5.2):
            # match the needle flow to the delivery at the requested mean pressure and move
            # the load-side mass to it; the cylinder and its mass balance are not touched
            d_nv = y[i_nv] - y_start[i_nv]
            a_old = p[G.needle_cda]
            a_new = a_old * (d_out / d_nv) * math.sqrt((pl_mean - p[G.tank_pressure]) / (load - p[G.tank_pressure]))
            if abs(a_new / a_old - 1.0) < 2e-4 and abs(pl_mean / load - 1.0) < 2e-4:
                tuned_at = k + 1                                  # needle valve frozen from here on
            else:
                p[G.needle_cda] = a_new
                y[i_load] += physics.load_mass(load, p)[0] - physics.load_mass(pl_mean, p)[0]
        out.revolutions.append(Revolution(k, span, y_start, d_out / rho0, mass_err, pl_mean, d_leak / rho0))
        tdc_states.append(y.copy())
        if k >= 1:
            out.change = cycle_change(problem, out.deliveries, tdc_states)
            settled = tuned_at is not None and k + 1 - tuned_at >= 2
            out.steady = out.change < max(rule.tol, rtol) and (not problem.complete or settled)
        if keep:
            out.kept = (out.kept + [span])[-keep:]
        k += 1
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"{out.revolutions[-1].delivery * 1e6:.4f} cc/rev")
        if k >= rule.revolutions and out.steady:
            break
    if bar is not None:
        bar.close()
    return out


def _progress_bar(progress: bool, total: int, desc: str):
    if not progress:
        return None
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit="rev", file=sys.stderr, leave=False)

