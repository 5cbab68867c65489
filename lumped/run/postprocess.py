"""Post-processors of a revolution: valve timing, impacts, losses, pressure extremes and the trace.

Each reads the last revolution's span (lumped.solver.steppers.Span: its events as
:class:`lumped.solver.layout.Event` records and its dense output) and the problem it came from; the
valves' openings come from their states through :mod:`lumped.solver.layout`, whatever their number
of degrees of freedom.
"""

from __future__ import annotations

import math

import numpy as np

from lumped.solver.layout import BLOCK_OFFSET, POSITIONS, S_MCYL
from lumped.solver.rhs import RATES_FIELDS
from lumped.run.trace import Trace
from lumped.valves.kind import VALVE

#: a stop contact counts when the element arrives after being this fraction of its stop gap clear
CONTACT_EXCURSION = 1e-3
EXCURSION_SAMPLES = 33               # dense-output samples between leaving the stop and returning
ENERGY_SAMPLES = 1440                # per revolution, for the valve losses and the pressure extremes
COL = {n: i for i, n in enumerate(RATES_FIELDS)}
#: the mass-balance error of a pump that barely delivers is relative to this fraction of one swept volume's mass
MASS_FLOOR = 1e-2


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
    from lumped.solver.layout import opening

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
    """The rates table (lumped.solver.rhs.rates_table) at n evenly spaced times of the span and its modes."""
    ts = span.t0 + problem.period * np.arange(n) / n
    ys, modes = span.sample(ts)
    return physics.rates_table(ts, ys, modes, problem.p), modes


def losses(rt: np.ndarray, problem, dt: float) -> tuple[float, float]:
    """Energy each valve dissipates by throttling over the revolution, the sum of dP Q_o dt [J] (>= 0).

    dP Q_o is the power the orifice flow of eqs 2.40-2.47 (3.23-3.25, 3.84) turns into heat: Q_o has the sign
    of dP, so every sample adds. The displacement flow A_Q u of eq 2.42 is left out: dP A_Q u is the work of
    the pressure on the moving element, stored in its spring, seat and motion and given back (a valve that
    stays seated, pressed in and out of a compliant seat by the cylinder pressure, dissipates nothing in its
    flow). The rectangle rule on ENERGY_SAMPLES evenly spaced samples is within 0.2 % of a Gauss rule on
    40,000 panels split at the events (the thesis cases and the 3 mm bore pump of tests/test_validity.py).
    """
    from lumped.solver.layout import G

    pc, pl = rt[:, COL["p_cyl"]], rt[:, COL["p_load"]]
    e_in = float(np.sum((problem.p[G.tank_pressure] - pc) * rt[:, COL["q_in"]]) * dt)
    e_del = float(np.sum((pc - pl) * rt[:, COL["q_del"]]) * dt)
    return e_in, e_del


def mass_balance(problem, rev) -> float:
    """Mass-balance error of a revolution [-]: |dm_cyl - (m_in - m_out - m_leak)| over the mass through the
    valves, or over 1 % of the oil mass of one swept volume when less flows (a pump that barely delivers:
    relative to a vanishing flow the integrator's round-off would read as a failure)."""
    q = problem.layout.quadratures
    a, b = rev.y_start, rev.span.y_end
    d_in, d_out, d_leak = (b[q[k]] - a[q[k]] for k in ("m_in", "m_out", "m_leak"))
    d_cyl = b[S_MCYL] - a[S_MCYL]
    return float(abs(d_cyl - (d_in - d_out - d_leak)) / max(abs(d_in), abs(d_out), MASS_FLOOR * problem.m_rev))


def valve_runs(span, problem, rt: np.ndarray, losses_j, kinds) -> dict:
    """What the revolution measured of each valve (:class:`lumped.validity.ValveRun`) from the rates table
    ``rt`` (ENERGY_SAMPLES evenly spaced samples), the span's peaks and each valve's kind name."""
    from lumped.solver.layout import PORTS, RATES_TAG, G
    from lumped.validity import ValveRun

    p, n = problem.p, len(rt)
    dt = problem.period / n
    pressure = {"tank": p[G.tank_pressure], "cylinder": rt[:, COL["p_cyl"]], "load": rt[:, COL["p_load"]]}
    out = {}
    for v, pos in enumerate(POSITIONS):
        o = BLOCK_OFFSET[v]
        tag = RATES_TAG[pos]
        x = rt[:, COL[f"x_{tag}"]]
        rho = rt[:, COL[f"rho_{tag}"]]
        flow = rt[:, COL[f"mdot_{tag}"]] / rho
        up, down = PORTS[pos]
        dp = pressure[up] - pressure[down]
        peak = max(float(span.peaks[v]), float(x.max()))
        re = 4.0 * rho * np.abs(rt[:, COL[f"q_{tag}"]]) / (p[G.viscosity] * p[o + VALVE.perimeter])
        out[pos] = ValveRun(
            position=pos, kind=kinds[v], opened=peak > 0.0, peak_opening=peak, min_opening=float(x.min()),
            seat_penetration=max(0.0, -float(x.min())), stop_penetration=max(0.0, peak - float(p[o + VALVE.stop_gap])),
            max_reynolds=float(re.max()), max_dp=float(dp.max()),
            forward_volume=float(np.sum(np.maximum(flow, 0.0)) * dt),
            backward_volume=float(np.sum(np.maximum(-flow, 0.0)) * dt), energy_loss=float(losses_j[v]))
    return out


def trace(spans, problem, npts: int, physics) -> Trace:
    """The kept revolutions sampled at npts points each from the dense output; a valve of several DOFs adds
    each coordinate's share of its opening, ``<position>_mode<i>_position`` = e_i q_i [m] (a modal reed's
    modal participation; their sum is ``<position>_position``)."""
    ts_all, rows, states = [], [], []
    for span in spans:
        ts = span.t0 + problem.period * np.arange(npts) / npts
        ys, modes = span.sample(ts)
        rows.append(physics.rates_table(ts, ys, modes, problem.p))
        ts_all.append(ts)
        states.append(ys)
    t = np.concatenate(ts_all)
    rt = np.concatenate(rows)
    ys = np.concatenate(states)
    signals = {
        "inlet_position": rt[:, COL["x_in"]], "delivery_position": rt[:, COL["x_del"]],
        "cylinder_pressure": rt[:, COL["p_cyl"]], "load_pressure": rt[:, COL["p_load"]],
        "inlet_mass_flow": rt[:, COL["mdot_in"]], "delivery_mass_flow": rt[:, COL["mdot_del"]],
        "inlet_velocity": rt[:, COL["u_in"]], "delivery_velocity": rt[:, COL["u_del"]],
        "vapour_volume": rt[:, COL["vapour_volume"]],
    }
    lay, p = problem.layout, problem.p
    for v, pos in enumerate(POSITIONS):
        # a modal reed's coordinates are its modes; an FE reed's are nodal DOFs (not worth a signal each)
        if lay.scalars[v] or getattr(getattr(problem.model, pos), "dynamics", "") != "modal":
            continue
        from lumped.reed.structure import modal_shares

        shares = modal_shares(problem.model.valve(pos), problem.model.oil.density, ys[:, lay.positions(v)])
        for i in range(lay.dofs[v]):
            signals[f"{pos}_mode{i + 1}_position"] = shares[:, i]
    return Trace(t - spans[0].t0, problem.speed_rpm, signals)

