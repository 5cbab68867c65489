"""Disc check valve of chapter 2: coefficients, forces (eq 2.4) and flow (eq 2.41).

The dynamics functions read the flat parameter array of :mod:`lumped.params` (block at
offset ``o``) and floats only, so ``numba.njit`` can compile them unchanged. SI units:
x [m] opening (0 = seated, > 0 open), u [m/s], dp = P_up - P_down [Pa], forces [N].

Contact state ``contact``: 0 seat (x < 0 side), 1 free, 2 stop (x > x_stop side),
-1 decide from x. Pressure regime ``regime``: 0 Poiseuille, 1 orifice, -1 decide from x
(eq 2.18). The pump integrator fixes both per segment and switches them at events, so
the right-hand side is smooth inside each segment.
"""

from __future__ import annotations

import math

from lumped.orifice import orifice_flow
from lumped.params import (
    V_A1, V_A2, V_ADISC, V_APORT, V_AREA, V_C1, V_C2, V_CDA, V_CDB, V_CDC, V_CDINF, V_CDRAG,
    V_COS, V_CSEAT, V_CSTOP, V_CVISC, V_DDISC, V_F1, V_F2, V_FLOW, V_HMIN, V_KSEAT, V_KSPR,
    V_KSTOP, V_LPORT, V_MASS, V_PERIM, V_POIS, V_XPRE, V_XSTOP, V_XTRANS,
)


# ----------------------------------------------------------------- coefficients (section 2.4)
def c1_coefficient(inner_radius: float, outer_radius: float) -> float:
    """Poiseuille flow pressure coefficient C1 (dimensionless, eq 2.14)."""
    q = inner_radius / outer_radius
    return (1.0 - q * q) / (2.0 * math.log(outer_radius / inner_radius))


def c2_coefficient(inner_radius: float, outer_radius: float, bevel_angle: float, viscosity: float) -> float:
    """Stiction coefficient C2 [N m^2 s] (eq 2.15; Reynolds equation 2.7-2.13)."""
    r = outer_radius / inner_radius
    lr = math.log(r)
    return (3.0 * math.pi * viscosity / (2.0 * math.sin(bevel_angle) ** 4) * inner_radius**4
            * (r**4 - 1.0) * (1.0 - (r * r - 1.0) / ((r * r + 1.0) * lr)))


def helical_spring_stiffness(wire_diameter: float, coil_diameter: float, shear_modulus: float,
                             active_coils: float) -> float:
    """k_spr = d^4 G / (8 D^3 N_a) [N/m] (eq 2.43)."""
    return wire_diameter**4 * shear_modulus / (8.0 * coil_diameter**3 * active_coils)


# ----------------------------------------------------------------- forces and flow
def contact_state(x: float, xstop: float) -> int:
    """0 seat (x < 0), 1 free, 2 stop (x > x_stop): the branch of eq 2.20."""
    if x < 0.0:
        return 0
    if x > xstop:
        return 2
    return 1


def contact_force(x: float, u: float, kseat: float, cseat: float, kstop: float, cstop: float,
                  xstop: float, contact: int) -> float:
    """Seat and stop reaction F_c (eq 2.20), in the units of k x (N for the disc, Pa for the reed)."""
    if contact < 0:
        contact = contact_state(x, xstop)
    if contact == 0:
        return -kseat * x - cseat * u
    if contact == 2:
        return -kstop * (x - xstop) - cstop * u
    return 0.0


def displacement_area(u: float, a1: float, a2: float, f1: float, f2: float, contact: int) -> float:
    """Fluid displacement area A_Q(u) [m^2] (eq 2.42; 3.26).

    While pressed into a compliant seat (contact 0) the element displaces the same volume
    going in and coming out, so the mean of the two areas is used (valvelab's choice: the
    direction-dependent A_Q would pump a net volume through a seated valve).
    """
    if contact == 0:
        return a1 + 0.5 * (f1 + f2) * (a2 - a1)
    if u < 0.0:
        return a1 + f1 * (a2 - a1)
    return a1 + f2 * (a2 - a1)


def valve_flow(x: float, u: float, dp: float, rho: float, mu: float, p, o: int,
               contact: int) -> tuple[float, float, float, float, float]:
    """Flow through a check valve (disc eqs 2.40-2.42, reed eqs 3.23-3.26), both valve kinds.

    Returns (Q_o orifice [m^3/s], Cd, A_Q [m^2], dQ_o/d(dp) [m^3/s/Pa], dQ_o/dx [m^2/s]).
    The total volume flow is Q_o + A_Q u. Seated (contact 0) the orifice is shut: Q_o = 0.
    """
    if contact < 0:
        contact = contact_state(x, p[o + V_XSTOP])
    aq = displacement_area(u, p[o + V_A1], p[o + V_A2], p[o + V_F1], p[o + V_F2], contact)
    if contact == 0 or x <= 0.0:
        return 0.0, 0.0, aq, 0.0, 0.0
    k_area = p[o + V_AREA]
    q, cd, dq_ddp, dq_da = orifice_flow(k_area * x, dp, rho, mu, p[o + V_PERIM],
                                        p[o + V_CDINF], p[o + V_CDA], p[o + V_CDB], p[o + V_CDC])
    return q, cd, aq, dq_ddp, dq_da * k_area


def pressure_force(x: float, u: float, dp: float, p_down: float, p_vap: float, p, o: int,
                   regime: int) -> float:
    """Pressure force F_p [N] with the Poiseuille/orifice switch of eq 2.18.

    Poiseuille regime: max(F_p,min, C1 dP A_disc - C2 u / x^3) (eqs 2.13, 2.16, 2.17), the
    film floored at the roughness height; orifice regime: dP A_disc. C2 = 0 when the
    squeeze_film switch is off; with the regime switch off the orifice form always applies.
    """
    a_disc = p[o + V_ADISC]
    if p[o + V_POIS] < 0.5:
        return dp * a_disc
    if regime < 0:
        regime = 0 if x < p[o + V_XTRANS] else 1
    if regime == 1:
        return dp * a_disc
    f = p[o + V_C1] * dp * a_disc
    c2 = p[o + V_C2]
    if c2 > 0.0 and x > 0.0:
        gap = x if x > p[o + V_HMIN] else p[o + V_HMIN]
        f -= c2 * u / (gap * gap * gap)
    a_port = p[o + V_APORT]
    f_min = dp * a_port + (p_vap - p_down) * (a_disc - a_port)
    return f if f > f_min else f_min


def disc_acceleration(x: float, u: float, dp: float, p_down: float, p_vap: float, rho: float,
                      mu: float, q_o: float, cd: float, aq: float, dq_ddp: float, dq_dx: float,
                      ddp_dt: float, p, o: int, contact: int, regime: int) -> float:
    """du/dt [m/s^2] of the disc: F / (m_disc + m_s/3 + m_f) with F of eq 2.4 (eqs 2.1-2.4).

    Forces: pressure (eq 2.18), spring with preload (eq 2.19), seat/stop contact
    (eq 2.20), drag opposing the motion (eq 2.28), and with the flow_force switch the
    steady (eq 2.36) and transient (eq 2.37) flow forces. The transient force holds
    rho (L + x) dQ/dt with dQ/dt = dQ/d(dp) d(dp)/dt + dQ/dx u + A_Q du/dt; its du/dt
    part is moved to the left side as an added inertia rho (L + x) A_Q.
    """
    m = p[o + V_MASS]
    xstop = p[o + V_XSTOP]
    if contact < 0:
        contact = contact_state(x, xstop)
    f = pressure_force(x, u, dp, p_down, p_vap, p, o, regime)
    f -= p[o + V_KSPR] * (x + p[o + V_XPRE])
    f += contact_force(x, u, p[o + V_KSEAT], p[o + V_CSEAT], p[o + V_KSTOP], p[o + V_CSTOP], xstop, contact)
    # drag (eq 2.28) opposes the motion
    f -= p[o + V_CVISC] * mu * u * p[o + V_DDISC] + 0.5 * rho * abs(u) * u * p[o + V_CDRAG] * p[o + V_ADISC]
    if p[o + V_FLOW] > 0.5:
        q = q_o + aq * u
        a_o = 0.0
        if contact != 0 and x > 0.0:
            a_o = p[o + V_AREA] * x
        f += rho * q * q / p[o + V_APORT] - 2.0 * cd * cd * a_o * abs(dp) * p[o + V_COS]
        arm = p[o + V_LPORT] + x
        f -= rho * (q * u + arm * (dq_ddp * ddp_dt + dq_dx * u))
        m += rho * arm * aq
    return f / m
