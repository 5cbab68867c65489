"""The switching surfaces of the pump model, defined once for both steppers.

Inside a step the right-hand side must be smooth, so each valve's contact state (seat,
free, stop), its pressure regime (Poiseuille, orifice: eq 2.18) and the cylinder's state
(liquid, cavitating) are fixed there (the *mode*, ``lumped.pump.N_MODE`` entries) and
change only where a switching function crosses zero. :func:`switch_values` gives those
functions for the current mode (each >= 0 while the mode holds; the crossing to < 0 is
the switch, direction "falling" in scipy's terms) and :func:`apply_switch` makes the
change at a located crossing, putting a valve exactly onto its surface.

A valve pressed on its seat or stop leaves it where the net force of everything but the
contact lets go, not where its deflection x crosses back (the two agree to the contact's
damping lag, c/k: 0.03 deg in the thesis pump). Settled in contact, x is a stiff variable
slaved to that force, nanometres deep and shrinking by fractions of a nanometre per crank
degree, so an integrator's error of a tolerance on x moved the lift-off by degrees (21.5 deg
on the fast path, benchmarks/pump_tolerance_study.py --effects); the force comes from the
pressures, which are integrated to the tolerance. While the valve still moves through its
impact transient (speed above :func:`settled_speed`) the kinematic surface decides, so
rebounds stay, and so it does while the valve is pressed deeper than DEEP_FRACTION of its
load-pressure deflection (held for sure: no force evaluation, :func:`force_decides`). The compiled
stepper (``lumped.steppers.RodasStepper``) calls the compiled copies of these very
functions inside its loop; the scipy stepper (``RadauStepper``) builds its terminal
events from them. Plain floats and arrays, so numba compiles the same source.
"""

from __future__ import annotations

import math

from lumped.pump import (
    CAVITATING, G, LIQUID, M_CAV, OFF_DEL, OFF_IN, S_MCYL, S_UDEL, S_UIN, S_XDEL, S_XIN, cylinder_volume_at,
    evaluate,
)
from lumped.valve import FREE, ORIFICE, POISEUILLE, SEAT, STOP, VALVE

#: number of switching functions: per valve seat, stop, regime; then the cylinder
N_SWITCHES = 7
#: hysteresis of the reverse crossings [m]: a mode entered exactly on its switching surface
#: must not switch back at its first step (a zero-length segment); 0.1 nm is far below
#: any opening the model resolves
HYSTERESIS = 1e-10
#: the same for the cavitation surface, relative to the density there
DENSITY_HYSTERESIS = 1e-12
#: a valve in contact counts as settled below this fraction of :func:`settled_speed`'s scale
SETTLED_FRACTION = 1e-3
#: a settled valve pressed deeper than this fraction of the load-pressure deflection P_load A / k
#: is held by a force ~10x its tolerance (contact_position_atol x atol <= 1 % of that deflection):
#: its deflection decides (the same quantity; saves a pump evaluation per event check, ~5 % of the
#: fast path's time)
DEEP_FRACTION = 0.1


def settled_speed(p, o: int, k: float) -> float:
    """Speed [m/s] below which a valve on a contact of stiffness k (seat or stop) has settled.

    eps P_load A / sqrt(k m) = eps omega delta: a contact oscillation (omega = sqrt(k/m)) at this
    speed spans eps = SETTLED_FRACTION of the deflection delta = P_load A / k a load-pressure force
    causes (the scale of lumped.steppers.tolerance_table). Scale-free: 0.14 mm/s for the thesis
    disc on its seat, 4 mm/s on the bench pump's soft seat (k = 1.5e6 N/m), whose deflection moves
    at ~1 mm/s near lift-off.
    """
    km = k * p[o + VALVE.moving_mass]
    if km <= 0.0:
        return math.inf
    return SETTLED_FRACTION * p[G.load_pressure] * p[o + VALVE.contact_area] / math.sqrt(km)


def force_decides(depth: float, u: float, p, o: int, k: float) -> bool:
    """Whether the force (not the deflection ``depth`` [m] into a contact of stiffness k) decides
    a valve's lift-off: settled (|u| below :func:`settled_speed`), and its depth below
    SETTLED_FRACTION of the stop gap (a soft contact's deflection is followed to the tolerance)
    and below DEEP_FRACTION of the load-pressure deflection (deeper, it is held for sure)."""
    if abs(u) > settled_speed(p, o, k):
        return False
    return depth <= SETTLED_FRACTION * p[o + VALVE.stop_gap] and \
        depth * k <= DEEP_FRACTION * p[G.load_pressure] * p[o + VALVE.contact_area]


def _contact(p, o: int) -> tuple[float, float, float, float]:
    """A valve block's contact stiffness and damping (seat k, c; stop k, c), as a tuple (no
    allocation: this runs in every force-decided switching check)."""
    return p[o + VALVE.seat_k], p[o + VALVE.seat_c], p[o + VALVE.stop_k], p[o + VALVE.stop_c]


def _set_contact(p, o: int, c) -> None:
    """Write a tuple of :func:`_contact`'s order into a valve block."""
    p[o + VALVE.seat_k], p[o + VALVE.seat_c], p[o + VALVE.stop_k], p[o + VALVE.stop_c] = c


def free_accelerations(t: float, y, p, mode) -> tuple[float, float]:
    """(inlet, delivery) accelerations [m/s^2] without the seat and stop reactions: the net
    non-contact force over the moving mass, in the current mode (lumped.pump.evaluate with
    the contact stiffness and damping zeroed for the call; p is restored)."""
    c_in, c_del = _contact(p, OFF_IN), _contact(p, OFF_DEL)
    _set_contact(p, OFF_IN, (0.0, 0.0, 0.0, 0.0))
    _set_contact(p, OFF_DEL, (0.0, 0.0, 0.0, 0.0))
    r = evaluate(t, y, p, mode)
    _set_contact(p, OFF_IN, c_in)
    _set_contact(p, OFF_DEL, c_del)
    return r.a_in, r.a_del


def switch_values(t: float, y, p, mode, g) -> None:
    """Fill g[0:N_SWITCHES] with the switching functions of the current mode (fire below 0).

    Valve v (0 inlet, 1 delivery), entries 3 v .. 3 v + 2: on its seat, -x (lifts off at x > 0),
    or where :func:`force_decides`, -a_f m / k_seat, about the quasi-static deflection of the net
    non-contact force (its sign is what counts: the valve lifts off when that force turns away from
    the seat); free, x + h (lands at x < -h) and x_stop - x (reaches the stop);
    on its stop, x - (x_stop - h), or where the force decides, a_f m / k_stop (leaves when the
    force turns away from the stop); the regime, x_t - x in the Poiseuille regime and x - (x_t - h) in the
    orifice one. Entry 6, the cylinder: liquid, rho - rho(P_vap) (cavitates when the density
    falls below the liquid's at the vapour pressure); cavitating, rho(P_vap) (1 + e) - rho
    (refilled). An entry with no surface is 1.
    """
    hy = HYSTERESIS
    need = False
    for v in range(2):
        o = OFF_IN if v == 0 else OFF_DEL
        x = y[S_XIN] if v == 0 else y[S_XDEL]
        u = y[S_UIN] if v == 0 else y[S_UDEL]
        c = int(mode[2 * v])
        r = int(mode[2 * v + 1])
        xstop = p[o + VALVE.stop_gap]
        if c == SEAT:
            g[3 * v] = -x
            g[3 * v + 1] = 1.0
            if force_decides(-x, u, p, o, p[o + VALVE.seat_k]):
                need = True
                g[3 * v] = math.nan          # the force's, below
        elif c == FREE:
            g[3 * v] = x + hy
            g[3 * v + 1] = xstop - x
        else:
            g[3 * v] = 1.0
            g[3 * v + 1] = x - (xstop - hy)
            if force_decides(x - xstop, u, p, o, p[o + VALVE.stop_k]):
                need = True
                g[3 * v + 1] = math.nan
        g[3 * v + 2] = 1.0
        xt = p[o + VALVE.regime_opening]
        if xt > 0.0:
            g[3 * v + 2] = xt - x if r == POISEUILLE else x - (xt - hy)
    if need:
        a = free_accelerations(t, y, p, mode)
        for v in range(2):
            o = OFF_IN if v == 0 else OFF_DEL
            m = p[o + VALVE.moving_mass]
            if math.isnan(g[3 * v]):
                g[3 * v] = -a[v] * m / p[o + VALVE.seat_k]
            if math.isnan(g[3 * v + 1]):
                g[3 * v + 1] = a[v] * m / p[o + VALVE.stop_k]
    g[6] = 1.0
    rho_v = p[G.rho_vapour]
    if rho_v > 0.0:
        rho = y[S_MCYL] / cylinder_volume_at(t, p)[0]
        if int(mode[M_CAV]) == LIQUID:
            g[6] = (rho - rho_v) / rho_v
        else:
            g[6] = (rho_v * (1.0 + DENSITY_HYSTERESIS) - rho) / rho_v


def apply_switch(k: int, y, p, mode) -> int:
    """Make the mode change of switching function k at its crossing; returns slot*100 + old*10 + new.

    A valve is put exactly onto its surface (x = 0, -h, x_stop, x_stop - h, x_t, x_t - h),
    so the new mode starts on the right side of it; a valve leaving a contact does not move
    into it (u >= 0 off the seat, <= 0 off the stop: a settled valve leaves with the contact
    surface, which is at rest, and a speed of the integrator's error into the contact would
    land it again at once); the cylinder switch moves no state (the mass is the state: it
    stays exactly conserved).
    """
    if k == 6:
        old = int(mode[M_CAV])
        new = CAVITATING if old == LIQUID else LIQUID
        mode[M_CAV] = new
        return M_CAV * 100 + old * 10 + new
    v = k // 3
    kind = k % 3
    o = OFF_IN if v == 0 else OFF_DEL
    xi = S_XIN if v == 0 else S_XDEL
    c = int(mode[2 * v])
    r = int(mode[2 * v + 1])
    hy = HYSTERESIS
    if kind == 0:
        slot, old, new, level = 2 * v, c, (FREE if c == SEAT else SEAT), (0.0 if c == SEAT else -hy)
    elif kind == 1:
        slot, old, new = 2 * v, c, (STOP if c == FREE else FREE)
        level = p[o + VALVE.stop_gap] - (0.0 if c == FREE else hy)
    else:
        slot, old, new = 2 * v + 1, r, (ORIFICE if r == POISEUILLE else POISEUILLE)
        level = p[o + VALVE.regime_opening] - (0.0 if r == POISEUILLE else hy)
    mode[slot] = new
    y[xi] = level
    if slot == 2 * v and new == FREE:
        ui = S_UIN if v == 0 else S_UDEL
        y[ui] = max(y[ui], 0.0) if old == SEAT else min(y[ui], 0.0)
    return slot * 100 + old * 10 + new


def redo_at_crossing(k: int, mode) -> bool:
    """Whether a step should be redone to end at crossing k: only when a valve leaves its seat
    or stop. In contact the opening is a stiff component slaved to the pressure, which the
    interpolant of a long step does not follow; in free flight (and the cylinder density)
    it does, to the tolerance."""
    if k >= 6:
        return False
    c = int(mode[2 * (k // 3)])
    kind = k % 3
    return (kind == 0 and c == SEAT) or (kind == 1 and c == STOP)


def initial_mode(t: float, y, p, mode) -> None:
    """Contact state, regime and cylinder state decided from the state (at the start of a run)."""
    for v in range(2):
        o = OFF_IN if v == 0 else OFF_DEL
        x = y[S_XIN] if v == 0 else y[S_XDEL]
        mode[2 * v] = SEAT if x <= 0.0 else (STOP if x > p[o + VALVE.stop_gap] else FREE)
        xt = p[o + VALVE.regime_opening]
        mode[2 * v + 1] = POISEUILLE if (xt > 0.0 and x < xt) else ORIFICE
    mode[M_CAV] = LIQUID
    rho_v = p[G.rho_vapour]
    if rho_v > 0.0 and y[S_MCYL] / cylinder_volume_at(t, p)[0] < rho_v:
        mode[M_CAV] = CAVITATING


def decode(code: int) -> tuple[int, int, int]:
    """(mode slot, old, new) of an :func:`apply_switch` code."""
    return code // 100, (code // 10) % 10, code % 10
