"""The switching surfaces of the pump model, defined once for both steppers.

Inside a step the right-hand side must be smooth, so each valve's contact state (seat,
free, stop), its pressure regime (Poiseuille, orifice: eq 2.18) and the cylinder's state
(liquid, cavitating) are fixed there (the *mode*, ``lumped.solver.layout.MODE``) and change only
where a switching function crosses zero. :func:`switch_values` gives those functions for
the current mode (each >= 0 while the mode holds; the crossing to < 0 is the switch,
direction "falling" in scipy's terms) and :func:`apply_switch` makes the change at a
located crossing, putting a valve exactly onto its surface. Which function is which is
``lumped.solver.layout.SWITCH`` (per valve: seat, stop, regime; then the cylinder).

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
stepper (``lumped.solver.steppers.RodasStepper``) calls the compiled copies of these very
functions inside its loop; the scipy stepper (``RadauStepper``) builds its terminal
events from them. Plain floats and arrays, so numba compiles the same source.

The functions (:func:`switch_values`; x the opening, lumped.solver.layout.opening; h the hysteresis): each
valve's seat function, on its seat, -x (lifts off at x > 0), or where :func:`force_decides`, -a_f m / k_seat,
about the quasi-static deflection of the net non-contact force (its sign is what counts: the valve lifts off when
that force turns away from the seat); free, x + h (lands at x < -h). Its stop function: free, x_stop - x
(reaches the stop); on its stop, x - (x_stop - h), or where the force decides, a_f m / k_stop (leaves when the
force turns away from the stop). Its regime function: x_t - x in the Poiseuille regime and x - (x_t - h) in the
orifice one. The cylinder's: liquid, rho - rho(P_vap) (cavitates when the density falls below the liquid's at the
vapour pressure); cavitating, rho(P_vap) (1 + e) - rho (refilled). A function with no surface is 1.
"""

from __future__ import annotations

import math

from lumped.solver.layout import (
    BLOCK_OFFSET, CAVITATING, CAVITATION_SLOT, CAVITATION_SWITCH, CONTACT_SLOT, G, LIQUID, N_SWITCHES, N_VALVES,
    REGIME_SLOT, REGIME_SWITCH, S_MCYL, SEAT_SWITCH, STOP_SWITCH, SWITCH_VALVE, SWITCH_WHAT, event_code, is_scalar,
    limit_rate, opening, set_opening,
)
from lumped.solver.rhs import cylinder_volume_at, evaluate
from lumped.valves.kind import FREE, ORIFICE, POISEUILLE, SEAT, STOP, VALVE

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
#: its deflection decides (the same quantity, and it spares the pump evaluation the force would cost at
#: every event check)
DEEP_FRACTION = 0.1
#: what a switching function switches (lumped.solver.layout.SWITCH_WHAT, as numbers numba compares)
_WHAT_SEAT, _WHAT_STOP, _WHAT_REGIME, _WHAT_CAVITATION = 0, 1, 2, 3
SWITCH_KIND = tuple({"seat": 0, "stop": 1, "regime": 2, "cavitation": 3}[w] for w in SWITCH_WHAT)


def settled_speed(p, o: int, k: float) -> float:
    """The speed below which a valve on a contact of stiffness k (seat or stop) has settled.

    eps P_load A / sqrt(k m) = eps omega delta: a contact oscillation (omega = sqrt(k/m)) at this speed spans eps =
    SETTLED_FRACTION of the deflection delta = P_load A / k a load-pressure force causes (the scale of
    lumped.solver.steppers.tolerance_table). Scale-free: 0.14 mm/s for the thesis disc on its seat, 4 mm/s on the
    bench pump's soft seat (k = 1.5e6 N/m), whose deflection moves at ~1 mm/s near lift-off.

    Parameters
    ----------
    p : array of float
        The flat parameter array.
    o : int
        The valve's block offset in p.
    k : float
        The contact's stiffness [N/m].

    Returns
    -------
    float
        [m/s]; inf for a massless or rigid-free block.
    """
    km = k * p[o + VALVE.moving_mass]
    if km <= 0.0:
        return math.inf
    return SETTLED_FRACTION * p[G.load_pressure] * p[o + VALVE.contact_area] / math.sqrt(km)


def force_decides(depth: float, u: float, p, o: int, k: float) -> bool:
    """Whether the force, not the deflection into a contact, decides a valve's lift-off.

    Settled (|u| below :func:`settled_speed`), and its depth below SETTLED_FRACTION of the stop gap (a soft
    contact's deflection is followed to the tolerance) and below DEEP_FRACTION of the load-pressure deflection
    (deeper, it is held for sure). A valve of several DOFs (a modal or FE reed on its seat lands) is decided by its
    opening: its net free acceleration holds its higher modes' elastic forces, whose sign flips at their frequency.

    Parameters
    ----------
    depth : float
        Deflection into the contact [m].
    u : float
        Opening rate [m/s].
    p : array of float
        The flat parameter array.
    o : int
        The valve's block offset in p.
    k : float
        The contact's stiffness [N/m].

    Returns
    -------
    bool
    """
    if not is_scalar(p, o):
        return False
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


def free_accelerations(t: float, y, p, mode, scratch) -> tuple[float, float]:
    """The openings' accelerations without the seat and stop reactions: the net non-contact force over the moving
    mass, in the current mode.

    lumped.solver.rhs.evaluate with the contact stiffness and damping zeroed for the call; p is restored.

    Parameters
    ----------
    t : float
        Time [s].
    y : array of float
        The pump's state (lumped.solver.layout).
    p : array of float
        The flat parameter array.
    mode : array of float
        The mode (contact, regime and cylinder states; lumped.solver.layout slots).
    scratch : array of float
        Room for dy/dt (the state's length).

    Returns
    -------
    (a_in, a_del) : tuple of float
        Inlet and delivery [m/s^2].
    """
    o_in, o_del = BLOCK_OFFSET
    c_in, c_del = _contact(p, o_in), _contact(p, o_del)
    _set_contact(p, o_in, (0.0, 0.0, 0.0, 0.0))
    _set_contact(p, o_del, (0.0, 0.0, 0.0, 0.0))
    r = evaluate(t, y, p, mode, scratch)
    _set_contact(p, o_in, c_in)
    _set_contact(p, o_del, c_del)
    return r.a_in, r.a_del


def switch_values(t: float, y, p, mode, g) -> None:
    """The switching functions of the current mode into g[0:N_SWITCHES] (an event fires where one drops below 0;
    each function: the module docstring).

    Parameters
    ----------
    t, y, p, mode
        Time [s], the pump's state, the flat parameter array and the mode (lumped.solver.layout).
    g : array of float
        Written: the functions; the state's length more is scratch (:func:`free_accelerations`).

    Returns
    -------
    None
    """
    hy = HYSTERESIS
    need = False
    for v in range(N_VALVES):
        o = BLOCK_OFFSET[v]
        x, u = opening(y, p, o)
        c = int(mode[CONTACT_SLOT[v]])
        r = int(mode[REGIME_SLOT[v]])
        i_seat, i_stop, i_reg = SEAT_SWITCH[v], STOP_SWITCH[v], REGIME_SWITCH[v]
        xstop = p[o + VALVE.stop_gap]
        if c == SEAT:
            g[i_seat] = -x
            g[i_stop] = 1.0
            if force_decides(-x, u, p, o, p[o + VALVE.seat_k]):
                need = True
                g[i_seat] = math.nan          # the force's, below
        elif c == FREE:
            g[i_seat] = x + hy
            g[i_stop] = xstop - x
        else:
            g[i_seat] = 1.0
            g[i_stop] = x - (xstop - hy)
            if force_decides(x - xstop, u, p, o, p[o + VALVE.stop_k]):
                need = True
                g[i_stop] = math.nan
        g[i_reg] = 1.0
        xt = p[o + VALVE.regime_opening]
        if xt > 0.0:
            g[i_reg] = xt - x if r == POISEUILLE else x - (xt - hy)
    if need:
        _force_switches(t, y, p, mode, g)
    i_cav = CAVITATION_SWITCH
    g[i_cav] = 1.0
    rho_v = p[G.rho_vapour]
    if rho_v > 0.0:
        rho = y[S_MCYL] / cylinder_volume_at(t, p)[0]
        if int(mode[CAVITATION_SLOT]) == LIQUID:
            g[i_cav] = (rho - rho_v) / rho_v
        else:
            g[i_cav] = (rho_v * (1.0 + DENSITY_HYSTERESIS) - rho) / rho_v


def _force_switches(t: float, y, p, mode, g) -> None:
    """The seat and stop functions :func:`switch_values` left NaN (where :func:`force_decides`): -a_f m / k_seat
    and a_f m / k_stop from the free accelerations a_f (the valve's loop stays free of this call, which only a
    settled contact needs)."""
    a = free_accelerations(t, y, p, mode, g[N_SWITCHES:])
    for v in range(N_VALVES):
        o = BLOCK_OFFSET[v]
        m = p[o + VALVE.moving_mass]
        if math.isnan(g[SEAT_SWITCH[v]]):
            g[SEAT_SWITCH[v]] = -a[v] * m / p[o + VALVE.seat_k]
        if math.isnan(g[STOP_SWITCH[v]]):
            g[STOP_SWITCH[v]] = a[v] * m / p[o + VALVE.stop_k]


def apply_switch(k: int, y, p, mode) -> int:
    """Make the mode change of switching function k at its crossing.

    A valve is put exactly onto its surface (x = 0, -h, x_stop, x_stop - h, x_t, x_t - h), so the new mode starts on
    the right side of it; a valve leaving a contact does not move into it (u >= 0 off the seat, <= 0 off the stop: a
    settled valve leaves with the contact surface, which is at rest, and a speed of the integrator's error into the
    contact would land it again at once); the cylinder switch moves no state (the mass is the state: it stays
    exactly conserved).

    Parameters
    ----------
    k : int
        The switching function.
    y : array of float
        The state; the valve's opening and rate may be rewritten.
    p : array of float
        The flat parameter array.
    mode : array of float
        Rewritten: the new mode.

    Returns
    -------
    int
        The event code (lumped.solver.layout.event_code).
    """
    what = SWITCH_KIND[k]
    if what == _WHAT_CAVITATION:
        old = int(mode[CAVITATION_SLOT])
        new = CAVITATING if old == LIQUID else LIQUID
        mode[CAVITATION_SLOT] = new
        return event_code(CAVITATION_SLOT, old, new)
    v = SWITCH_VALVE[k]
    o = BLOCK_OFFSET[v]
    c = int(mode[CONTACT_SLOT[v]])
    r = int(mode[REGIME_SLOT[v]])
    hy = HYSTERESIS
    if what == _WHAT_SEAT:
        slot, old, new, level = CONTACT_SLOT[v], c, (FREE if c == SEAT else SEAT), (0.0 if c == SEAT else -hy)
    elif what == _WHAT_STOP:
        slot, old, new = CONTACT_SLOT[v], c, (STOP if c == FREE else FREE)
        level = p[o + VALVE.stop_gap] - (0.0 if c == FREE else hy)
    else:
        slot, old, new = REGIME_SLOT[v], r, (ORIFICE if r == POISEUILLE else POISEUILLE)
        level = p[o + VALVE.regime_opening] - (0.0 if r == POISEUILLE else hy)
    mode[slot] = new
    set_opening(y, p, o, level)
    if slot == CONTACT_SLOT[v] and new == FREE:
        limit_rate(y, p, o, 1.0 if old == SEAT else -1.0)
    return event_code(slot, old, new)


def redo_at_crossing(k: int, mode) -> bool:
    """Whether a step should be redone to end at crossing k: only when a valve leaves its seat or stop.

    In contact the opening is a stiff component slaved to the pressure, which the interpolant of a long step does
    not follow; in free flight (and the cylinder density) it does, to the tolerance.

    Parameters
    ----------
    k : int
        The switching function.
    mode : array of float
        The mode (contact, regime and cylinder states; lumped.solver.layout slots).

    Returns
    -------
    bool
    """
    what = SWITCH_KIND[k]
    if what == _WHAT_CAVITATION or what == _WHAT_REGIME:
        return False
    c = int(mode[CONTACT_SLOT[SWITCH_VALVE[k]]])
    return (what == _WHAT_SEAT and c == SEAT) or (what == _WHAT_STOP and c == STOP)


def initial_mode(t: float, y, p, mode) -> None:
    """Contact state, regime and cylinder state decided from the state (at the start of a run).

    Parameters
    ----------
    t : float
        Time [s].
    y : array of float
        The pump's state (lumped.solver.layout).
    p : array of float
        The flat parameter array.
    mode : array of float
        Written: the mode.

    Returns
    -------
    None
    """
    for v in range(N_VALVES):
        o = BLOCK_OFFSET[v]
        x = opening(y, p, o)[0]
        mode[CONTACT_SLOT[v]] = SEAT if x <= 0.0 else (STOP if x > p[o + VALVE.stop_gap] else FREE)
        xt = p[o + VALVE.regime_opening]
        mode[REGIME_SLOT[v]] = POISEUILLE if (xt > 0.0 and x < xt) else ORIFICE
    mode[CAVITATION_SLOT] = LIQUID
    rho_v = p[G.rho_vapour]
    if rho_v > 0.0 and y[S_MCYL] / cylinder_volume_at(t, p)[0] < rho_v:
        mode[CAVITATION_SLOT] = CAVITATING
