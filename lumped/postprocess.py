"""Post-processors of a revolution: valve timing, impacts, losses, pressure extremes and the trace.

Each reads the last revolution's span (lumped.steppers.Span: its events as
:class:`lumped.layout.Event` records and its dense output) and the problem it came from; the
valves' openings come from their states through :mod:`lumped.layout`, whatever their number
of degrees of freedom.
"""

from __future__ import annotations

import math

import numpy as np

from lumped.layout import BLOCK_OFFSET, POSITIONS
from lumped.rhs import RATES_FIELDS
from lumped.trace import Trace
from lumped.valve import VALVE

#: a stop contact counts when the element arrives after being this fraction of its stop gap clear
CONTACT_EXCURSION = 1e-3
EXCURSION_SAMPLES = 33               # dense-output samples between leaving the stop and returning
ENERGY_SAMPLES = 1440                # per revolution, for the valve losses and the pressure extremes
COL = {n: i for i, n in enumerate(RATES_FIELDS)}


def _contact_events(span, pos: str) -> list:
    return [e for e in span.events if e.where == pos and e.what == "contact"]


def stop_arrivals(span, problem, v: int) -> int:
    """Arrivals of valve v on its stop in the span that follow a real excursion (see CONTACT_EXCURSION).

    A contact is counted when the element arrives on the stop after having been at least
    CONTACT_EXCURSION x the stop gap clear of it since it last left it; a departure and
    return of a few nanometres while pressed on a compliant stop is the step-size control
    crossing x_stop, not a rebound anyone could measure, and counting it would make the
    count depend on the tolerance (the two steppers then disagree).
    """
    gap = float(problem.p[BLOCK_OFFSET[v] + VALVE.stop_gap])
    n, left_at = 0, None
    for e in _contact_events(span, POSITIONS[v]):
        if e.old == "stop" and e.new != "stop":
            left_at = e.t
        elif e.new == "stop":
            if left_at is None or e.t <= left_at:
                n += 1
            else:
                ys, _ = span.sample(np.linspace(left_at, e.t, EXCURSION_SAMPLES))
                if gap - float(np.min(problem.layout.openings(ys, problem.p, v)[0])) >= CONTACT_EXCURSION * gap:
                    n += 1
            left_at = None
    return n


def valve_timing(span, problem, y_start: np.ndarray) -> tuple[tuple, tuple, tuple]:
    """(opening angles, closing angles, stop arrivals) of each valve in a revolution: the crank angles
    [rad] where its main opening starts and ends (None: never opens, or never reseats)."""
    from lumped.layout import opening

    period, omega, t0 = problem.period, problem.omega, span.t0
    opening_a, closing_a, stops = [], [], []
    for v, pos in enumerate(POSITIONS):
        stops.append(stop_arrivals(span, problem, v))
        # open intervals [start, end) of x > 0 within the periodic revolution
        was_open = opening(y_start, problem.p, BLOCK_OFFSET[v])[0] > 0.0
        intervals, start = [], (t0 if was_open else None)
        for e in _contact_events(span, pos):
            if e.new == "free" and start is None:
                start = e.t
            elif e.new == "seat" and start is not None:
                intervals.append((start, e.t))
                start = None
        if start is not None:
            intervals.append((start, t0 + period))
        # never open, or never reseated (held off its seat, e.g. by a squeeze film): no timing
        # to report; 0 deg would be a silent wrong number
        if not intervals or intervals == [(t0, t0 + period)]:
            opening_a.append(None)
            closing_a.append(None)
            continue
        # join an interval running into the end with one starting the revolution (periodicity)
        if len(intervals) > 1 and intervals[0][0] == t0 and intervals[-1][1] == t0 + period:
            first = intervals.pop(0)
            a, b = intervals.pop()
            intervals.append((a, b + (first[1] - first[0])))
        a, b = max(intervals, key=lambda iv: iv[1] - iv[0])
        opening_a.append(float(((a - t0) * omega) % (2 * math.pi)))
        closing_a.append(float(((b - t0) * omega) % (2 * math.pi)))
    return tuple(opening_a), tuple(closing_a), tuple(stops)


def impacts(span, problem) -> list[tuple[float, float]]:
    """Largest speeds [m/s] at which each valve arrives on its seat and on its stop in the span."""
    out = []
    for v, pos in enumerate(POSITIONS):
        seat = stop = 0.0
        for e, y in zip(span.events, span.event_states):
            if e.where != pos or e.what != "contact" or e.old != "free":
                continue
            u = abs(float(problem.layout.openings(np.asarray(y)[None, :], problem.p, v)[1][0]))
            if e.new == "seat":
                seat = max(seat, u)
            elif e.new == "stop":
                stop = max(stop, u)
        out.append((seat, stop))
    return out


def rates(span, problem, physics, n: int = ENERGY_SAMPLES):
    """The rates table (lumped.rhs.rates_table) at n evenly spaced times of the span and its modes."""
    ts = span.t0 + problem.period * np.arange(n) / n
    ys, modes = span.sample(ts)
    return physics.rates_table(ts, ys, modes, problem.p), modes


def losses(rt: np.ndarray, problem, dt: float) -> tuple[float, float]:
    """Pressure-drop energy of each valve over the revolution, sum of dP Q dt [J] (Q = mdot / rho_orifice)."""
    from lumped.layout import G

    pc, pl = rt[:, COL["p_cyl"]], rt[:, COL["p_load"]]
    q_in = rt[:, COL["mdot_in"]] / rt[:, COL["rho_in"]]
    q_del = rt[:, COL["mdot_del"]] / rt[:, COL["rho_del"]]
    e_in = float(np.sum((problem.p[G.tank_pressure] - pc) * q_in) * dt)
    e_del = float(np.sum((pc - pl) * q_del) * dt)
    return e_in, e_del


def trace(spans, problem, npts: int, physics) -> Trace:
    """The kept revolutions sampled at npts points each from the dense output."""
    ts_all, rows = [], []
    for span in spans:
        ts = span.t0 + problem.period * np.arange(npts) / npts
        ys, modes = span.sample(ts)
        rows.append(physics.rates_table(ts, ys, modes, problem.p))
        ts_all.append(ts)
    t = np.concatenate(ts_all)
    rt = np.concatenate(rows)
    signals = {
        "inlet_position": rt[:, COL["x_in"]], "delivery_position": rt[:, COL["x_del"]],
        "cylinder_pressure": rt[:, COL["p_cyl"]], "load_pressure": rt[:, COL["p_load"]],
        "inlet_mass_flow": rt[:, COL["mdot_in"]], "delivery_mass_flow": rt[:, COL["mdot_del"]],
        "inlet_velocity": rt[:, COL["u_in"]], "delivery_velocity": rt[:, COL["u_del"]],
        "vapour_volume": rt[:, COL["vapour_volume"]],
    }
    return Trace(t - spans[0].t0, problem.speed_rpm, signals)

