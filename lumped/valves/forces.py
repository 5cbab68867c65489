"""The physics every valve kind shares, written once: contact reactions, the flow through any kind and the
force terms kinds have in common.

Each kind's acceleration (``lumped/valves/disc.py``, ``reed.py``, ``ball.py``) calls these instead of
writing its own copy; numba compiles them with it (:mod:`lumped.solver.compiled` lists this module among the
physics). Plain float functions of the flat parameter array ``p`` read at a valve's block offset ``o``
(:data:`lumped.valves.common.VALVE`), SI units: x the opening [m] (0 seated, > 0 open), u its rate [m/s],
dp = P_up - P_down [Pa], forces in N (per unit area, Pa, for the reed of eq 3.21).

Contact state ``contact``: 0 seat, 1 free, 2 stop, -1 decide from x (:mod:`lumped.valves.common`).
"""

from __future__ import annotations

import math

from lumped.fluid.orifice import discharge_slope, orifice_flow
from lumped.valves.common import ORIFICE, POISEUILLE, SEAT, STOP, FREE, VALVE


# --------------------------------------------------------------------------- contact (eqs 2.20, 2.23)
def critical_damping(stiffness: float, mass: float, gamma: float = 1.0) -> float:
    """Critical damping of m x'' + gamma (c x' + k x) = 0 (eq 2.23).

    Parameters
    ----------
    stiffness : float
        k [N/m], or [Pa/m] per unit area (the reed).
    mass : float
        m [kg], or [kg/m^2] per unit area.
    gamma : float
        Modal factor multiplying damping and stiffness (the reed's gamma1 of eq 3.21; 1 for a rigid
        disc or ball).

    Returns
    -------
    float
        c_crit = 2 sqrt(gamma k m) / gamma [N s/m, or Pa s/m per unit area]; gamma = 1 gives eq 2.23's
        2 sqrt(k m).

    References
    ----------
    Knutson (2016), eq 2.23 (contact damping), eq 3.21 (the reed's modal equation).

    Examples
    --------
    Table 2.3's seat and stop damping, 6860 and 173 N s/m: k_seat = 3.02e9 N/m, k_stop = 1.91e6 N/m (section
    2.4.3.2) with the 3.9 g the thesis used (Table 2.1):

    >>> round(critical_damping(3.02e9, 3.9e-3), -1), round(critical_damping(1.91e6, 3.9e-3))
    (6860.0, 173)
    """
    return 2.0 * math.sqrt(gamma * stiffness * mass) / gamma


def contact_state(x: float, xstop: float) -> int:
    """The contact branch of eq 2.20 decided from the opening.

    Parameters
    ----------
    x : float
        Opening [m].
    xstop : float
        Stop gap x_stop [m].

    Returns
    -------
    int
        0 seat (x < 0), 1 free, 2 stop (x > x_stop).

    Examples
    --------
    >>> contact_state(-1e-9, 1e-3), contact_state(5e-4, 1e-3), contact_state(1.1e-3, 1e-3)
    (0, 1, 2)
    """
    if x < 0.0:
        return SEAT
    if x > xstop:
        return STOP
    return FREE


def contact_force(x: float, u: float, kseat: float, cseat: float, kstop: float, cstop: float,
                  xstop: float, contact: int) -> float:
    """Seat and stop reaction F_c of eq 2.20: a linear spring and dashpot while pressed into either.

    Parameters
    ----------
    x, u : float
        Opening [m] and its rate [m/s].
    kseat, cseat, kstop, cstop : float
        Contact stiffness [N/m] and damping [N s/m] of seat and stop (per unit area for the reed).
    xstop : float
        Stop gap [m].
    contact : int
        Contact state (-1: from x, :func:`contact_state`).

    Returns
    -------
    float
        F_c [N] (Pa per unit area): -k_seat x - c_seat u on the seat, -k_stop (x - x_stop) - c_stop u
        on the stop, 0 free.

    References
    ----------
    Knutson (2016), eq 2.20.

    Examples
    --------
    >>> contact_force(-1e-6, 0.0, 3e9, 0.0, 1e9, 0.0, 1e-3, -1)
    3000.0
    """
    if contact < 0:
        contact = contact_state(x, xstop)
    if contact == SEAT:
        return -kseat * x - cseat * u
    if contact == STOP:
        return -kstop * (x - xstop) - cstop * u
    return 0.0


def contact_reaction(x: float, u: float, p, o: int, contact: int) -> float:
    """F_c of eq 2.20 for the valve at block offset ``o`` (:func:`contact_force` with its packed constants).

    Parameters
    ----------
    x, u : float
        Opening [m], rate [m/s].
    p : array of float
        The flat parameter array; ``o`` the valve's block offset.
    contact : int
        Contact state (-1: from x).

    Returns
    -------
    float
        F_c [N] for the disc and ball, [Pa] for the reed (eq 3.21 is per unit area).
    """
    return contact_force(x, u, p[o + VALVE.seat_k], p[o + VALVE.seat_c], p[o + VALVE.stop_k],
                         p[o + VALVE.stop_c], p[o + VALVE.stop_gap], contact)


def contact_slopes(x: float, p, o: int, contact: int) -> tuple[float, float]:
    """Partials (dF_c/dx, dF_c/du) of :func:`contact_reaction` (eq 2.20) in a contact state.

    Parameters
    ----------
    x : float
        Opening [m] (decides the state when ``contact`` is -1).
    p : array of float
        The flat parameter array; ``o`` the valve's block offset.
    contact : int
        Contact state.

    Returns
    -------
    tuple of float
        (-k, -c) of the seat or stop being pressed [N/m, N s/m; per unit area for the reed], (0, 0) free.
    """
    if contact < 0:
        contact = contact_state(x, p[o + VALVE.stop_gap])
    if contact == SEAT:
        return -p[o + VALVE.seat_k], -p[o + VALVE.seat_c]
    if contact == STOP:
        return -p[o + VALVE.stop_k], -p[o + VALVE.stop_c]
    return 0.0, 0.0


# --------------------------------------------------------------------------- flow (eqs 2.38-2.42, 3.22-3.26)
def displacement_area(u: float, a1: float, a2: float, f1: float, f2: float, contact: int) -> float:
    """Fluid displacement area A_Q(u) of a moving element: A_1 + f (A_2 - A_1) (eq 2.42; 3.26).

    While pressed into a compliant seat (contact 0) the element displaces the same volume going in and
    coming out, so the mean of the two factors is used (valvelab's choice: the direction-dependent A_Q
    would pump a net volume through a seated valve).

    Parameters
    ----------
    u : float
        Rate of the opening [m/s]: f1 closing (u < 0), f2 opening.
    a1, a2 : float
        A_1 (the port) and A_2 (the moving face) [m^2].
    f1, f2 : float
        Displacement factors closing and opening [-].
    contact : int
        Contact state.

    Returns
    -------
    float
        A_Q [m^2].

    References
    ----------
    Knutson (2016), eq 2.42 (disc), eq 3.26 (reed).

    Examples
    --------
    >>> displacement_area(-0.1, 1.0, 3.0, 0.5, 0.9, 1), displacement_area(0.1, 1.0, 3.0, 0.5, 0.9, 1)
    (2.0, 2.8)
    """
    if contact == SEAT:
        return a1 + 0.5 * (f1 + f2) * (a2 - a1)
    if u < 0.0:
        return a1 + f1 * (a2 - a1)
    return a1 + f2 * (a2 - a1)


def orifice_area(x: float, p, o: int) -> float:
    """Orifice (curtain) area A_o of an open valve: area_per_opening x + area_curvature x^2.

    The flow-area law every kind shares: eq 2.40 for the disc (pi d_port sin(theta) x), eq 3.25 for the reed
    (l_o x), ball 1 of ``lumped/valves/ball.py`` (a ball in a cone, Merritt 1967 section 3.5). It must grow
    with x over the lift (:class:`lumped.valves.common.Common` checks it).

    Parameters
    ----------
    x : float
        Opening [m], > 0.
    p : array of float
        The flat parameter array; ``o`` the valve's block offset.

    Returns
    -------
    float
        A_o [m^2].
    """
    return p[o + VALVE.area_per_opening] * x + p[o + VALVE.area_curvature] * x * x


def valve_flow(x: float, u: float, dp: float, rho: float, mu: float, p, o: int,
               contact: int) -> tuple[float, float, float, float, float]:
    """Flow through a check valve of any kind: the orifice equation with Cd(Re) through A_o(x), plus the
    volume the moving element displaces (disc eqs 2.38-2.42, reed eqs 3.22-3.26).

    Parameters
    ----------
    x, u : float
        Opening [m] and its rate [m/s].
    dp : float
        P_up - P_down [Pa].
    rho, mu : float
        Density of the orifice equation [kg/m^3] (section 4.3.5) and viscosity [Pa s].
    p : array of float
        The flat parameter array (its orifice warm start is written back); ``o`` the block offset.
    contact : int
        Contact state (-1: from x). Seated the orifice is shut: Q_o = 0.

    Returns
    -------
    tuple of float
        (Q_o the orifice flow [m^3/s], Cd, A_Q [m^2], dQ_o/d(dp) [m^3/s/Pa], dQ_o/dx [m^2/s]); the total
        volume flow is Q_o + A_Q u.

    References
    ----------
    Knutson (2016), eqs 2.38-2.48 and 3.22-3.26, 3.86-3.89; Wu et al. (2002) for Cd(Re).
    """
    if contact < 0:
        contact = contact_state(x, p[o + VALVE.stop_gap])
    aq = displacement_area(u, p[o + VALVE.area_1], p[o + VALVE.area_2], p[o + VALVE.f_closing],
                           p[o + VALVE.f_opening], contact)
    if contact == SEAT or x <= 0.0:
        return 0.0, 0.0, aq, 0.0, 0.0
    k_area = p[o + VALVE.area_per_opening]
    k2 = p[o + VALVE.area_curvature]
    per = p[o + VALVE.perimeter]
    lift_k = p[o + VALVE.cd_lift_exponent]
    if lift_k != 0.0:
        # Re_eff = Re (x / x_stop)^k: the same law with the perimeter p (x_stop / x)^k
        per = per * (p[o + VALVE.stop_gap] / x) ** lift_k
    area = orifice_area(x, p, o)
    q, cd, dq_ddp, dq_da = orifice_flow(area, dp, rho, mu, per, p[o + VALVE.cd_inf],
                                        p[o + VALVE.cd_a], p[o + VALVE.cd_b], p[o + VALVE.cd_c],
                                        p[o + VALVE.orifice_start])
    # the root sqrt(Re) starts the next solve of this valve (2-3 Halley steps become ~1)
    s = math.sqrt(4.0 * rho * abs(q) / (mu * per))
    p[o + VALVE.orifice_start] = s
    dq_dx = dq_da * (k_area + 2.0 * k2 * x)
    if lift_k != 0.0 and cd > 0.0:
        # the perimeter's share: dQ/dp_er = -dQ/dA A Cd'(s) s / (2 p_er Cd) (implicit in s^2 = 4 rho |Q| /
        # (mu p_er), Q = Cd(s) A V), with dp_er/dx = -k p_er / x
        slope = discharge_slope(s, p[o + VALVE.cd_inf], p[o + VALVE.cd_a], p[o + VALVE.cd_b], p[o + VALVE.cd_c])
        dq_dx += dq_da * area * slope * s * lift_k / (2.0 * cd * x)
    return q, cd, aq, dq_ddp, dq_dx


def mass_flow(qo: float, aq: float, u: float, dp: float, rho: float, dq_ddp: float,
              dq_dx: float) -> tuple[float, float, float, float, float]:
    """Mass flow through a valve, rho (Q_o + A_Q u) (eqs 4.3, 4.4), and its partials.

    Q_o of the orifice equation with Cd(Re) scales as rho^(1/w' - 1) at fixed dp, so dQ_o/d rho =
    (dp dQ_o/d(dp) - Q_o) / rho. The pump's right-hand side (lumped.solver.rhs.evaluate) and its Jacobian
    (lumped.solver.jacobian) both take the valve mass flows from here.

    Parameters
    ----------
    qo, aq, dq_ddp, dq_dx : float
        From :func:`valve_flow`: Q_o [m^3/s], A_Q [m^2], dQ_o/d(dp) [m^3/s/Pa], dQ_o/dx [m^2/s].
    u : float
        Rate of the opening [m/s].
    dp : float
        P_up - P_down [Pa].
    rho : float
        Density of the orifice equation [kg/m^3].

    Returns
    -------
    tuple of float
        (mdot [kg/s], d mdot/d(dp) [kg/s/Pa], d mdot/d rho [m^3/s], d mdot/dx [kg/s/m], d mdot/du [kg/m]),
        each at fixed other arguments.

    References
    ----------
    Knutson (2016), eqs 4.3-4.5.

    Examples
    --------
    >>> mass_flow(1e-4, 2e-4, 0.5, 1e6, 850.0, 0.0, 0.0)[0]
    0.17
    """
    q = qo + aq * u
    return rho * q, rho * dq_ddp, q + (dp * dq_ddp - qo), rho * dq_dx, rho * aq


def regime_of(x: float, p, o: int) -> int:
    """Pressure regime decided from the opening (eq 2.18).

    Parameters
    ----------
    x : float
        Opening [m].
    p : array of float
        The flat parameter array; ``o`` the valve's block offset.

    Returns
    -------
    int
        Poiseuille (0) below the regime opening x_t, orifice (1) above it or where the valve has no regime
        switch (x_t <= 0).
    """
    xt = p[o + VALVE.regime_opening]
    if xt > 0.0 and x < xt:
        return POISEUILLE
    return ORIFICE


# --------------------------------------------------------------------------- force terms kinds share
def spring_force(x: float, stiffness: float, preload: float) -> float:
    """Spring force pushing the element toward its seat, k_spr (x + x_pre) (eq 2.19; the caller subtracts it).

    Parameters
    ----------
    x : float
        Opening [m].
    stiffness : float
        k_spr [N/m].
    preload : float
        x_pre, the compression when seated [m].

    Returns
    -------
    float
        The force [N].

    References
    ----------
    Knutson (2016), eq 2.19.

    Examples
    --------
    The thesis disc's spring seated: k_spr = 213 N/m measured (section 2.4.3.1), x_pre = 6.2 mm (Table 2.3):

    >>> round(spring_force(0.0, 213.0, 6.2e-3), 4)
    1.3206
    """
    return stiffness * (x + preload)


def steady_flow_force(x: float, u: float, f, p, o: int, contact: int, port_area: float, cos_jet: float) -> float:
    """Steady flow force on an element lifted off its seat: the momentum flux of the control volume of
    eq 2.36 (Merritt 1967, eq 3-63 for poppets).

    F_s = rho Q^2 / A_port - 2 Cd^2 A_o |dP| cos(theta_jet), with Q = Q_o + A_Q u the volume flow in, the
    jet leaving the curtain A_o (:func:`orifice_area`; 0 seated) at theta_jet to the axis. Positive: opening.

    Parameters
    ----------
    x, u : float
        Opening [m] and its rate [m/s].
    f : lumped.valves.common.ValveInputs
        The pump's inputs (rho, dp, q_o, aq, cd).
    p : array of float
        The flat parameter array; ``o`` the valve's block offset.
    contact : int
        Contact state (seated: no jet).
    port_area : float
        A_port [m^2], where the flow enters.
    cos_jet : float
        cos(theta_jet).

    Returns
    -------
    float
        F_s [N].

    References
    ----------
    Knutson (2016), eqs 2.30, 2.36; Merritt, *Hydraulic Control Systems* (1967), section 3.5.
    """
    q = f.q_o + f.aq * u
    a_o = 0.0
    if contact != SEAT and x > 0.0:
        a_o = orifice_area(x, p, o)
    return f.rho * q * q / port_area - 2.0 * f.cd * f.cd * a_o * abs(f.dp) * cos_jet
