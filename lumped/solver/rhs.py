"""The pump's right-hand side (chapter 4): fluid states, valve flows and every rate at one instant.

Plain functions of floats, the state vector and the flat parameter array
(:func:`lumped.solver.layout.pack`), so ``numba.njit`` compiles the very same source for the fast
path (``lumped.solver.compiled``). Where each state and parameter sits is :mod:`lumped.solver.layout`'s:
the cylinder oil mass m_cyl (eq 4.5), each valve's positions and rates (its kind decides how
many: one DOF is the opening x and its rate u), the load-line oil mass (complete circuit;
constant otherwise), and the cumulative masses through the inlet valve, delivery valve,
piston clearance and needle valve, which make the mass balance checkable to round-off.
Time 0 is top dead centre.

The mode (``lumped.solver.layout.MODE``: fixed inside a step, switched at located crossings by
``lumped.solver.switching``): the contact state and pressure regime of each valve, and whether the
cylinder is cavitating (its pressure held at the vapour pressure while the liquid no longer
fills it: the mass state still says how much oil is there, so the vapour volume
V - m / rho(P_vap) collapses exactly as the piston returns).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from lumped.fluid import oil as oil_mod
from lumped.solver.layout import (
    CAVITATING, G, MODE, OFF_DEL, OFF_IN, S_MCYL, load_index, n_states, opening, quadrature_indices, valve_rates,
    write_rates,
)
from lumped.model.pump import cylinder_volume
from lumped.valves.kind import VALVE, ValveInputs, mass_flow, valve_flow


def cylinder_volume_at(t: float, p) -> tuple[float, float]:
    """Cylinder volume and its rate at a time after top dead centre (eq 4.2 with theta = omega t).

    Parameters
    ----------
    t : float
        Time from TDC [s].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).

    Returns
    -------
    tuple of float
        (V_cyl [m^3], dV_cyl/dt [m^3/s]).

    References
    ----------
    Knutson (2016), eq 4.2.
    """
    omega = p[G.omega]
    return cylinder_volume(omega * t, omega, p[G.piston_area], p[G.crank_radius], p[G.rod_length],
                           p[G.dead_volume])


# ----------------------------------------------------------------- fluid states and their partials
def oil_density(pressure: float, p) -> float:
    """Density of the pump's oil at an absolute pressure (eq 4.11, :func:`lumped.fluid.oil.density`).

    Parameters
    ----------
    pressure : float
        [Pa, absolute].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).

    Returns
    -------
    float
        rho [kg/m^3].

    References
    ----------
    Knutson (2016), eq 4.11.
    """
    return oil_mod.density(pressure, p[G.density], p[G.atmospheric_pressure], p[G.bulk_modulus],
                           p[G.polytropic_exponent], p[G.air_content])


def oil_density_slope(pressure: float, p) -> float:
    """Slope d rho/dP of the pump oil's density (eq 4.11, :func:`lumped.fluid.oil.density_slope`).

    Parameters
    ----------
    pressure : float
        [Pa, absolute].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).

    Returns
    -------
    float
        [kg/m^3/Pa].

    References
    ----------
    Knutson (2016), eq 4.11.
    """
    return oil_mod.density_slope(pressure, p[G.density], p[G.atmospheric_pressure], p[G.bulk_modulus],
                                 p[G.polytropic_exponent], p[G.air_content])


def cylinder_pressure(m: float, vol: float, p, cavitating: int) -> tuple[float, float, float]:
    """Pressure of an oil mass in the cylinder volume: eq 4.11 inverted while the liquid fills it, the vapour
    pressure while it cavitates.

    Parameters
    ----------
    m : float
        Oil mass in the cylinder [kg].
    vol : float
        Cylinder volume [m^3].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).
    cavitating : int
        The cylinder's mode (lumped.solver.layout.CAVITATING: cavitating).

    Returns
    -------
    tuple of float
        (P_cyl [Pa], dP_cyl/dm [Pa/kg] (0 cavitating), rho_cyl = m / V [kg/m^3]).

    Notes
    -----
    Cavitating, the pressure is held at the vapour pressure (the liquid at rho(P_vap), the rest of the volume
    vapour; Wylie's discrete vapour cavity model), so dP/dm = 0 there. The root starts the next inversion (kept
    in the packed array's scratch slot).

    References
    ----------
    Knutson (2016), eqs 4.6, 4.11-4.16; Wylie & Streeter, *Fluid Transients in Systems* (1993), section 8.5.
    """
    rho = m / vol
    if cavitating == CAVITATING:
        return p[G.vapour_pressure], 0.0, rho
    pc = oil_mod.pressure(rho, p[G.density], p[G.atmospheric_pressure], p[G.bulk_modulus],
                          p[G.polytropic_exponent], p[G.air_content], p[G.pressure_start])
    # the root starts the next inversion (an integrator's stages are neighbouring states: ~1-2
    # Newton steps instead of a fresh start); scratch, not a parameter
    p[G.pressure_start] = pc
    return pc, 1.0 / (vol * oil_density_slope(pc, p)), rho


def load_mass(pl: float, p) -> tuple[float, float]:
    """Oil mass held by the load line and accumulator at a load pressure (section 4.2.1): oil volume V_line + V_acc
    - V_gas, the gas at V_acc (P_pre/P)^(1/n) above its precharge, filling the accumulator below it.

    Parameters
    ----------
    pl : float
        Load pressure [Pa, absolute].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).

    Returns
    -------
    tuple of float
        (mass [kg], d mass/dP [kg/Pa]).

    References
    ----------
    Knutson (2016), section 4.2.1, eq 4.11.
    """
    rho = oil_density(pl, p)
    drho = oil_density_slope(pl, p)
    vacc, ppre, n = p[G.accumulator_volume], p[G.accumulator_precharge], p[G.accumulator_exponent]
    vol = p[G.line_volume]
    dvol = 0.0
    if pl > ppre:
        vgas = vacc * (ppre / pl) ** (1.0 / n)
        vol += vacc - vgas
        dvol = vgas / (n * pl)
    return rho * vol, drho * vol + rho * dvol


def load_pressure(m: float, p) -> tuple[float, float]:
    """The load pressure holding an oil mass in the load line and accumulator (the inverse of :func:`load_mass`, by
    Newton's method in a shrinking bracket).

    Parameters
    ----------
    m : float
        Oil mass [kg].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).

    Returns
    -------
    tuple of float
        (P_load [Pa], dP_load/dm [Pa/kg]).

    References
    ----------
    Knutson (2016), section 4.2.1.
    """
    vline, vacc, ppre, n = p[G.line_volume], p[G.accumulator_volume], p[G.accumulator_precharge], \
        p[G.accumulator_exponent]
    m_pre = load_mass(ppre, p)[0]
    if m <= m_pre:
        pl = oil_mod.pressure(m / vline, p[G.density], p[G.atmospheric_pressure], p[G.bulk_modulus],
                              p[G.polytropic_exponent], p[G.air_content])
        return pl, 1.0 / (vline * oil_density_slope(pl, p))
    # gas law with incompressible oil as the first guess
    vgas = vacc + vline - m / p[G.density]
    guess = ppre * (vacc / vgas) ** n if vgas > 1e-3 * vacc else ppre * 1e3 ** n
    lo, hi = ppre, 1e12
    pl = guess if lo < guess < hi else 2.0 * ppre
    dm = 1.0
    for _ in range(200):
        f, dm = load_mass(pl, p)
        f -= m
        if f > 0.0:
            hi = pl
        else:
            lo = pl
        new = pl - f / dm
        if not (lo < new < hi):
            new = 0.5 * (lo + hi)
        if abs(new - pl) <= 1e-13 * new + 4e-16 * p[G.bulk_modulus]:
            return new, 1.0 / dm
        pl = new
    return pl, 1.0 / dm


def needle_mass_flow(pl: float, p) -> tuple[float, float]:
    """Mass flow through the complete circuit's needle valve to tank, rho Cd A sqrt(2 |dP| / rho) sign(dP), and its
    derivative by the load pressure.

    Parameters
    ----------
    pl : float
        Load pressure [Pa, absolute].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).

    Returns
    -------
    tuple of float
        (mdot [kg/s], d mdot/dP_load [kg/s/Pa]).

    References
    ----------
    Knutson (2016), section 4.2.1 (the orifice equation of eq 2.38).
    """
    dp = pl - p[G.tank_pressure]
    rho = oil_density(pl, p)
    cda = p[G.needle_cda]
    adp = abs(dp)
    q = cda * math.sqrt(2.0 * rho * adp)
    # d/dP of rho q: q' = cda (2 rho' |dp| + 2 rho sign) / (2 sqrt(2 rho |dp|))
    root = math.sqrt(2.0 * rho * adp) if adp > 0.0 else 0.0
    dq = 0.0
    if root > 0.0:
        dq = cda * (oil_density_slope(pl, p) * adp + rho) / root
    return (q if dp >= 0.0 else -q), dq


def leakage_mass_flow(pc: float, rho: float, p) -> tuple[float, float, float]:
    """Laminar leakage past the piston, rho K (P_cyl - P_tank) (eq 4.5), and its partials.

    Parameters
    ----------
    pc : float
        Cylinder pressure [Pa].
    rho : float
        Cylinder density [kg/m^3].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).

    Returns
    -------
    tuple of float
        (mdot [kg/s], d mdot/dP_cyl [kg/s/Pa], d mdot/d rho [m^3/s]).

    References
    ----------
    Knutson (2016), eq 4.5.
    """
    k = p[G.leak]
    d = pc - p[G.tank_pressure]
    return rho * k * d, rho * k, k * d


def orifice_density(rho_cyl: float, rho_other: float, p, o: int) -> tuple[float, float]:
    """The density in a valve's orifice equation (section 4.3.5): the cylinder's, or the mean of the cylinder's and
    the other side's.

    Parameters
    ----------
    rho_cyl : float
        Cylinder density [kg/m^3].
    rho_other : float
        The valve's other side [kg/m^3].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).
    o : int
        The valve's block offset.

    Returns
    -------
    tuple of float
        (rho [kg/m^3], d rho/d rho_cyl [-]).

    References
    ----------
    Knutson (2016), section 4.3.5.
    """
    if p[o + VALVE.average_density] > 0.5:
        return 0.5 * (rho_cyl + rho_other), 0.5
    return rho_cyl, 1.0


def load_side_density(pl: float, p) -> float:
    """Oil density on the load side: at the constant load pressure (simplified circuit, packed once) or at the load
    line's pressure (complete circuit).

    Parameters
    ----------
    pl : float
        Load pressure [Pa].
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).

    Returns
    -------
    float
        rho [kg/m^3].

    References
    ----------
    Knutson (2016), eq 4.11, section 4.2.1.
    """
    if p[G.complete] > 0.5:
        return oil_density(pl, p)
    return p[G.rho_load]


# ----------------------------------------------------------------- right-hand side
class Rates(NamedTuple):
    """Everything the pump equations give at one instant (SI): the named record of :func:`evaluate`."""

    dm_cyl: float          # dm_cyl/dt = mdot_in - mdot_del - mdot_leak [kg/s] (eq 4.5)
    x_in: float            # inlet valve opening [m]
    u_in: float            # its rate [m/s]
    a_in: float            # its acceleration [m/s^2]
    x_del: float
    u_del: float
    a_del: float
    dm_load: float         # d(load-line mass)/dt [kg/s] (complete circuit)
    mdot_in: float         # mass flow into the cylinder through the inlet valve [kg/s] (eq 4.3)
    mdot_del: float        # ... out through the delivery valve (eq 4.4)
    mdot_leak: float       # ... past the piston (eq 4.5)
    mdot_needle: float     # ... through the needle valve (complete circuit)
    p_cyl: float           # cylinder pressure [Pa]
    p_load: float          # load pressure [Pa]
    q_in: float            # orifice volume flow of the inlet valve [m^3/s]
    q_del: float
    rho_cyl: float         # mean oil density in the cylinder [kg/m^3]
    rho_in: float          # density in the inlet valve's orifice equation (section 4.3.5) [kg/m^3]
    rho_del: float         # ... the delivery valve's
    volume: float          # cylinder volume [m^3]
    vapour_volume: float   # volume not filled by liquid while cavitating [m^3]


def evaluate(t: float, y, p, mode, dydt, accelerations: bool = True) -> Rates:
    """Everything the pump equations give at one instant: the rates of every state into ``dydt`` and the named
    record of the pump's quantities.

    The mass balance of eq 4.5 with the valve mass flows of eqs 4.3-4.4, the cylinder pressure from eq 4.11 inverted
    by Newton (eqs 4.12-4.16) or held at the vapour pressure while cavitating, the load line of the complete circuit
    (section 4.2.1), and the valve dynamics of the valves' kinds (chapters 2 and 3).

    Parameters
    ----------
    t, y, p, mode
        Time from TDC [s], the state, the packed parameters and the mode (lumped.solver.layout).
    dydt : array of float
        Written: dy/dt.
    accelerations : bool
        False: the valves' accelerations and their rates are not computed (``a_in``, ``a_del`` NaN).

    Returns
    -------
    Rates
        The pump's quantities at (t, y), SI units.

    References
    ----------
    Knutson (2016), eqs 4.1-4.17, chapters 2-3.
    """
    vol, dvol = cylinder_volume_at(t, p)
    m = y[S_MCYL]
    cav = int(mode[MODE.cavitation])
    pc, pc_m, rho_cyl = cylinder_pressure(m, vol, p, cav)
    pt = p[G.tank_pressure]
    complete = p[G.complete] > 0.5
    pl = p[G.load_pressure]
    pl_m = 0.0
    i_load = load_index(p)
    if complete:
        pl, pl_m = load_pressure(y[i_load], p)
    mu = p[G.viscosity]
    # the valves' openings, orifice densities (section 4.3.5), flows and mass flows (eqs 4.3, 4.4) written out
    # here, not in a helper: a compiled call binding y and p costs a reference count each (docs/extending.md)
    x_in, u_in = opening(y, p, OFF_IN)
    x_del, u_del = opening(y, p, OFF_DEL)
    rho_in = orifice_density(rho_cyl, p[G.rho_tank], p, OFF_IN)[0]
    rho_del = orifice_density(rho_cyl, load_side_density(pl, p), p, OFF_DEL)[0]
    dp_in = pt - pc
    dp_del = pc - pl
    c_in, c_del = int(mode[MODE.inlet_contact]), int(mode[MODE.delivery_contact])
    qo_in, cd_in, aq_in, dqp_in, dqx_in = valve_flow(x_in, u_in, dp_in, rho_in, mu, p, OFF_IN, c_in)
    qo_del, cd_del, aq_del, dqp_del, dqx_del = valve_flow(x_del, u_del, dp_del, rho_del, mu, p, OFF_DEL, c_del)
    mdot_in = mass_flow(qo_in, aq_in, u_in, dp_in, rho_in, dqp_in, dqx_in)[0]
    mdot_del = mass_flow(qo_del, aq_del, u_del, dp_del, rho_del, dqp_del, dqx_del)[0]
    mdot_leak = leakage_mass_flow(pc, rho_cyl, p)[0]
    dm = mdot_in - mdot_del - mdot_leak                # eq 4.5
    # pressure rates, needed by the transient flow force (eq 2.37)
    dpc = (dm - rho_cyl * dvol) * pc_m
    dml = 0.0
    mdot_nv = 0.0
    dpl = 0.0
    if complete:
        mdot_nv = needle_mass_flow(pl, p)[0]
        dml = mdot_del - mdot_nv
        dpl = dml * pl_m
    p_vap = p[G.vapour_pressure]
    f_in = ValveInputs(dp_in, pc, p_vap, rho_in, mu, qo_in, cd_in, aq_in, dqp_in, dqx_in, -dpc)
    f_del = ValveInputs(dp_del, pl, p_vap, rho_del, mu, qo_del, cd_del, aq_del, dqp_del, dqx_del, dpc - dpl)
    a_in = a_del = math.nan
    if accelerations:
        a_in = valve_rates(y, x_in, u_in, f_in, p, OFF_IN, c_in, int(mode[MODE.inlet_regime]), dydt)
        a_del = valve_rates(y, x_del, u_del, f_del, p, OFF_DEL, c_del, int(mode[MODE.delivery_regime]), dydt)
    vap = 0.0
    if cav == CAVITATING and p[G.rho_vapour] > 0.0:
        vap = vol - m / p[G.rho_vapour]
        if vap < 0.0:
            vap = 0.0
    i_in, i_out, i_leak, i_nv = quadrature_indices(p)
    write_rates(dydt, p, OFF_IN, u_in, a_in)
    write_rates(dydt, p, OFF_DEL, u_del, a_del)
    dydt[S_MCYL] = dm
    dydt[i_load] = dml
    dydt[i_in] = mdot_in
    dydt[i_out] = mdot_del
    dydt[i_leak] = mdot_leak
    dydt[i_nv] = mdot_nv
    return Rates(dm, x_in, u_in, a_in, x_del, u_del, a_del, dml, mdot_in, mdot_del, mdot_leak, mdot_nv, pc, pl,
                 qo_in, qo_del, rho_cyl, rho_in, rho_del, vol, vap)


def rhs(t: float, y, p, mode) -> np.ndarray:
    """Time derivative of the pump's state (lumped.solver.layout's state vector): :func:`evaluate` into a new array.

    Parameters
    ----------
    t : float
        Time from TDC [s].
    y : array of float
        The state.
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).
    mode : array of float
        The mode (contact states, regimes, cavitation).

    Returns
    -------
    numpy.ndarray
        dy/dt (SI units of the states per second).

    References
    ----------
    Knutson (2016), eqs 4.1-4.17.
    """
    out = np.empty(n_states(p))
    evaluate(t, y, p, mode, out)
    return out


#: columns of :func:`rates_table`: the fields of :class:`Rates`
RATES_FIELDS = Rates._fields
N_RATES = len(RATES_FIELDS)


def rates_table(ts, ys, modes, p) -> np.ndarray:
    """The pump equations' quantities (:class:`Rates`) at sampled times, states and modes, one row per sample.

    Parameters
    ----------
    ts : array of float
        Times [s].
    ys : array of float
        States (rows).
    modes : array of float
        Modes (rows).
    p : array of float
        The packed parameters (lumped.solver.layout: the global block G).

    Returns
    -------
    numpy.ndarray
        (len(ts), len(RATES_FIELDS)), SI units of each field; the valves' accelerations a_in, a_del are left NaN (no
        post-processor reads them, and their forces are a third of an evaluation's cost).
    """
    out = np.empty((ts.shape[0], N_RATES))
    scratch = np.empty(ys.shape[1])
    for i in range(ts.shape[0]):
        r = evaluate(ts[i], ys[i], p, modes[i], scratch, False)
        for j in range(N_RATES):
            out[i, j] = r[j]
    return out
