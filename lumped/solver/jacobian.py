"""The Jacobian of the pump's right-hand side from the partials the physics already has.

df/dy by the chain rule through the pump equations (``lumped.solver.rhs.evaluate``):
rho_cyl = m_cyl / V(t) (eq 4.6), P_cyl from eq 4.11 with dP/dm = 1 / (V drho/dP) (0 while
cavitating), the valve mass flows of eqs 4.3-4.4 and their partials from
:func:`lumped.valves.forces.mass_flow` (the same function ``evaluate`` takes the flows from:
the mass-balance partials are written once) through each valve's opening x and rate u
(linear in its states: lumped.solver.layout.opening_weight), the piston leakage and needle valve
from ``lumped.solver.rhs``'s own (value, derivative) functions, and the load line's dP/dm. A
valve's positions move at its rates (exact rows of ones); only its accelerations are
differenced (forward, in each position and rate and in m_cyl, m_load through the pressures
and densities they see; a kind whose acceleration reads the flow, e.g. a disc with flow
forces, gets its flow recomputed at each perturbation and the chain through d(dP)/dt of
the transient force added).

Time enters only through V(t) in rho_cyl = m/V, so df/dt = df/dm_cyl (-m_cyl V'/V),
except through the transient flow force, whose dP/dt holds V' itself: then df/dt is
differenced. tests/test_jacobian.py compares every entry with central differences of
the right-hand side for random models of every kind, each effect on in turn, mixed kinds
and both circuits.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from lumped.solver.layout import (
    CAVITATING, CONTACT_SLOT, G, MODE, OFF_DEL, OFF_IN, REGIME_SLOT, S_MCYL, accel_index, dofs, is_scalar,
    load_index, opening, opening_weight, position_index, quadrature_indices, state_start,
)
from lumped.solver.rhs import (
    cylinder_pressure, cylinder_volume_at, evaluate, leakage_mass_flow, load_pressure, load_side_density,
    needle_mass_flow, oil_density_slope, orifice_density,
)
from lumped.valves.kind import (
    VALVE, ValveInputs, mass_flow, valve_acceleration, valve_accelerations, valve_accelerations_jacobian, valve_flow,
)

SQRT_EPS = 1.4901161193847656e-08
#: inlined by numba into their callers (lumped.solver.compiled): called, each bound the parameter array and the
#: records anew for every acceleration differenced, a cost the hot path pays 10-12 times per Jacobian
#: (docs/extending.md, "Long kernels")
INLINE = ("_valve_rows", "_accel", "_at", "_at_m", "_at_l", "_inputs", "_cylinder", "_load", "_time_partials")


class Cylinder(NamedTuple):
    """The cylinder at (t, y): volume V [m^3] and dV/dt [m^3/s], oil mass m [kg], pressure P [Pa], dP/dm
    [Pa/kg] (0 while cavitating), density m / V [kg/m^3], cavitation state."""

    vol: float
    dvol: float
    m: float
    pc: float
    pc_m: float
    rho_c: float
    cav: int


class Load(NamedTuple):
    """The load side: its oil mass [kg] (complete circuit; else 0), pressure [Pa] and dP/dm [Pa/kg]."""

    ml: float
    pl: float
    pl_ml: float


class Increments(NamedTuple):
    """The differencing: atol (array) and rtol of the integrator the increments scale with, the increments of
    m_cyl and m_load [kg], and whether the load line is a state (complete circuit)."""

    atol: np.ndarray
    rtol: float
    hm: float
    hml: float
    complete: bool


class Scratch(NamedTuple):
    """Scratch arrays the length of the state: a perturbed state, a several-DOF valve's accelerations twice."""

    y: np.ndarray
    a0: np.ndarray
    a1: np.ndarray


class Side(NamedTuple):
    """One valve as its rows see it: block offset ``o`` and number ``v``; its pressure difference dp, downstream
    pressure pd and orifice density rho [SI], each with its partials by m_cyl (``_m``) and m_load (``_l``);
    d(dp)/dt [Pa/s]."""

    o: int
    v: int
    dp: float
    dp_m: float
    dp_l: float
    pd: float
    pd_m: float
    pd_l: float
    rho: float
    r_m: float
    r_l: float
    ddt: float


class At(NamedTuple):
    """The pressures and density a valve's acceleration is evaluated at (perturbed or not)."""

    dp: float
    pd: float
    rho: float
    ddt: float


class ValveMode(NamedTuple):
    """A valve's block offset, contact state, pressure regime, and whether its flow is recomputed at the
    perturbed inputs (a kind whose acceleration reads the flow)."""

    o: int
    contact: int
    regime: int
    recompute: bool


def _at(s: Side) -> At:
    """The valve's unperturbed inputs."""
    return At(s.dp, s.pd, s.rho, s.ddt)


def _at_m(s: Side, h: float) -> At:
    """Its inputs with m_cyl moved by h [kg]."""
    return At(s.dp + s.dp_m * h, s.pd + s.pd_m * h, s.rho + s.r_m * h, s.ddt)


def _at_l(s: Side, h: float) -> At:
    """Its inputs with m_load moved by h [kg]."""
    return At(s.dp + s.dp_l * h, s.pd + s.pd_l * h, s.rho + s.r_l * h, s.ddt)


def _inputs(at: At, p, flow) -> ValveInputs:
    qo, cd, aq, dqp, dqx = flow
    return ValveInputs(at.dp, at.pd, p[G.vapour_pressure], at.rho, p[G.viscosity], qo, cd, aq, dqp, dqx, at.ddt)


def _accel(x: float, u: float, at: At, p, vm: ValveMode, flow) -> float:
    """A one-DOF valve's acceleration at perturbed inputs; its flow recomputed if the kind reads it."""
    if vm.recompute:
        flow = valve_flow(x, u, at.dp, at.rho, p[G.viscosity], p, vm.o, vm.contact)
    return valve_acceleration(x, u, _inputs(at, p, flow), p, vm.o, vm.contact, vm.regime)


def _accels(y, x: float, u: float, at: At, p, vm: ValveMode, flow, out) -> None:
    """A several-DOF valve's accelerations at perturbed inputs (states y) into out at its rates' slots."""
    if vm.recompute:
        flow = valve_flow(x, u, at.dp, at.rho, p[G.viscosity], p, vm.o, vm.contact)
    valve_accelerations(y, state_start(p, vm.o), dofs(p, vm.o), x, u, _inputs(at, p, flow), p, vm.o, vm.contact,
                        vm.regime, out)


def _flow_partials(y, p, o: int, contact: int, drop, cyl: Cylinder, other):
    """A valve's flow and the partials of its mass flow by (m_cyl, x, u, m_load).

    ``drop``: (dp, d(dp)/dm_cyl, d(dp)/dm_load); ``other``: (the density on the valve's other side, its
    derivative by m_load: the load side of the complete circuit). Returns (partials, flow, rho, d rho/dm_cyl,
    d rho/dm_load).
    """
    dp, dp_m, dp_l = drop
    x, u = opening(y, p, o)
    rho_v, frac = orifice_density(cyl.rho_c, other[0], p, o)
    r_m = frac / cyl.vol
    r_l = other[1] if frac < 1.0 else 0.0
    qo, cd, aq, dqp, dqx = valve_flow(x, u, dp, rho_v, p[G.viscosity], p, o, contact)
    mdot, f_dp, f_rho, f_x, f_u = mass_flow(qo, aq, u, dp, rho_v, dqp, dqx)
    part = (f_dp * dp_m + f_rho * r_m, f_x, f_u, f_dp * dp_l + f_rho * r_l)
    return part, (qo, cd, aq, dqp, dqx), rho_v, r_m, r_l


def _flow_columns(jac, row: int, sign: float, p, o: int, f_x: float, f_u: float) -> None:
    """d(mass flow)/d(the valve's states) into a row: through its opening x and rate u."""
    n = dofs(p, o)
    if is_scalar(p, o):
        jac[row, position_index(p, o, 0)] = sign * f_x
        jac[row, accel_index(p, o, 0)] = sign * f_u
        return
    _multi_flow_columns(jac, row, sign, p, o, f_x, f_u, n)


def _multi_flow_columns(jac, row: int, sign: float, p, o: int, f_x: float, f_u: float, n: int) -> None:
    """:func:`_flow_columns` of a valve with n > 1 DOFs: each state weighted by its share of the opening."""
    for j in range(n):
        w = opening_weight(p, o, j)
        jac[row, position_index(p, o, j)] = sign * f_x * w
        jac[row, accel_index(p, o, j)] = sign * f_u * w


def _valve_rows(y, p, mode, jac, scratch: Scratch, inc: Increments, side: Side, flow) -> float:
    """The valve's rows: positions move at their rates; its accelerations differenced (forward) by its
    states, m_cyl and m_load. Returns d(acceleration)/d(ddp_dt) of a one-DOF kind that reads the flow
    (the transient flow force's chain; 0 otherwise)."""
    o = side.o
    rec = p[o + VALVE.flow_in_acceleration] > 0.5
    contact = int(mode[CONTACT_SLOT[side.v]])
    regime = int(mode[REGIME_SLOT[side.v]])
    if not is_scalar(p, o):
        _multi_rows(y, p, jac, scratch, inc, side, flow, ValveMode(o, contact, regime, rec))
        return 0.0
    x, u = opening(y, p, o)
    fixed = ValveMode(o, contact, regime, False)
    moved = ValveMode(o, contact, regime, rec)
    xi, ui = position_index(p, o, 0), accel_index(p, o, 0)
    jac[xi, ui] = 1.0
    hx = SQRT_EPS * max(abs(x), inc.atol[xi] / inc.rtol)
    hu = SQRT_EPS * max(abs(u), inc.atol[ui] / inc.rtol)
    at = _at(side)
    a0 = _accel(x, u, at, p, fixed, flow)
    jac[ui, xi] = (_accel(x + hx, u, at, p, moved, flow) - a0) / hx
    jac[ui, ui] = (_accel(x, u + hu, at, p, moved, flow) - a0) / hu
    jac[ui, S_MCYL] = (_accel(x, u, _at_m(side, inc.hm), p, moved, flow) - a0) / inc.hm
    if inc.complete:
        jac[ui, load_index(p)] = (_accel(x, u, _at_l(side, inc.hml), p, moved, flow) - a0) / inc.hml
    if not rec:
        return 0.0
    hd = SQRT_EPS * max(abs(side.ddt), 1.0)
    return (_accel(x, u, At(side.dp, side.pd, side.rho, side.ddt + hd), p, fixed, flow) - a0) / hd


def _multi_rows(y, p, jac, scratch: Scratch, inc: Increments, side: Side, flow, vm: ValveMode) -> None:
    """The acceleration rows of a valve with n > 1 DOFs: columns by each position and rate (its kind's
    partials where it has them and does not read the flow, else forward differences), then by the
    pressures (forward differences); its accelerations at their rates' slots of the scratch."""
    o = side.o
    n = dofs(p, o)
    x, u = opening(y, p, o)
    s = state_start(p, o)
    r = s + n                                # the rows of its accelerations (its rates' slots)
    a0, a1 = scratch.a0, scratch.a1
    for j in range(n):
        jac[s + j, r + j] = 1.0
    at = _at(side)
    _accels(y, x, u, at, p, ValveMode(o, vm.contact, vm.regime, False), flow, a0)
    own = False
    if not vm.recompute:
        own = valve_accelerations_jacobian(y, s, n, x, u, _inputs(at, p, flow), p, o, vm.contact, vm.regime, jac)
    if not own:
        _multi_state_columns(y, p, jac, scratch, inc, side, flow, vm)
    _accels(y, x, u, _at_m(side, inc.hm), p, vm, flow, a1)
    for i in range(n):
        jac[r + i, S_MCYL] = (a1[r + i] - a0[r + i]) / inc.hm
    if inc.complete:
        _accels(y, x, u, _at_l(side, inc.hml), p, vm, flow, a1)
        i_load = load_index(p)
        for i in range(n):
            jac[r + i, i_load] = (a1[r + i] - a0[r + i]) / inc.hml


def _multi_state_columns(y, p, jac, scratch: Scratch, inc: Increments, side: Side, flow, vm: ValveMode) -> None:
    """A several-DOF valve's acceleration rows by its own positions and rates, forward differences against
    its unperturbed accelerations in ``scratch.a0``."""
    o = side.o
    n = dofs(p, o)
    x, u = opening(y, p, o)
    s = state_start(p, o)
    r = s + n
    yp, a0, a1 = scratch.y, scratch.a0, scratch.a1
    at = _at(side)
    for i in range(y.shape[0]):
        yp[i] = y[i]
    for j in range(2 * n):
        k = s + j                        # positions, then the rates right after them
        h = SQRT_EPS * max(abs(y[k]), inc.atol[k] / inc.rtol)
        w = opening_weight(p, o, j % n)
        yp[k] = y[k] + h
        if j < n:
            _accels(yp, x + w * h, u, at, p, vm, flow, a1)
        else:
            _accels(yp, x, u + w * h, at, p, vm, flow, a1)
        yp[k] = y[k]
        for i in range(n):
            jac[r + i, k] = (a1[r + i] - a0[r + i]) / h


def _mass_rows(jac, p, complete: bool, dmi, dmd, leak_m: float, nv_l: float) -> None:
    """The rows of the masses (eq 4.5, the load line, the running totals) from the valves' mass-flow
    partials ``dmi``, ``dmd`` (by m_cyl, x, u, m_load), the leakage's and the needle valve's."""
    i_in, i_out, i_leak, i_nv = quadrature_indices(p)
    i_load = load_index(p)
    jac[S_MCYL, S_MCYL] = dmi[0] - dmd[0] - leak_m
    _flow_columns(jac, S_MCYL, 1.0, p, OFF_IN, dmi[1], dmi[2])
    _flow_columns(jac, S_MCYL, -1.0, p, OFF_DEL, dmd[1], dmd[2])
    jac[i_in, S_MCYL] = dmi[0]
    _flow_columns(jac, i_in, 1.0, p, OFF_IN, dmi[1], dmi[2])
    jac[i_out, S_MCYL] = dmd[0]
    _flow_columns(jac, i_out, 1.0, p, OFF_DEL, dmd[1], dmd[2])
    jac[i_leak, S_MCYL] = leak_m
    if complete:
        jac[S_MCYL, i_load] = -dmd[3]
        jac[i_out, i_load] = dmd[3]
        jac[i_load, S_MCYL] = dmd[0]
        _flow_columns(jac, i_load, 1.0, p, OFF_DEL, dmd[1], dmd[2])
        jac[i_load, i_load] = dmd[3] - nv_l
        jac[i_nv, i_load] = nv_l


def _pressure_rates(t: float, y, p, mode, fscratch, cyl: Cylinder, load: Load, inc: Increments):
    """What a transient flow force's chain needs: (dm_cyl/dt, dm_load/dt, dP_cyl/dt, dP_load/dt,
    d(dP_cyl/dm)/dm_cyl, d(dP_load/dm)/dm_load)."""
    r0 = evaluate(t, y, p, mode, fscratch)
    dmc = r0.dm_cyl
    dmlr = r0.dm_load
    dpc_dt = (dmc - cyl.rho_c * cyl.dvol) * cyl.pc_m
    dpl_dt = 0.0
    dpcm_m = 0.0
    dplm_l = 0.0
    if inc.complete:
        dpl_dt = dmlr * load.pl_ml
    if cyl.cav != CAVITATING:
        # d(pc_m)/dm = d/dm 1/(V rho'(P)): rho' at the perturbed pressure, no inversion
        pc_m2 = 1.0 / (cyl.vol * oil_density_slope(cyl.pc + cyl.pc_m * inc.hm, p))
        dpcm_m = (pc_m2 - cyl.pc_m) / inc.hm
    if inc.complete:
        plm2 = load_pressure(load.ml + inc.hml, p)[1]
        dplm_l = (plm2 - load.pl_ml) / inc.hml
    return dmc, dmlr, dpc_dt, dpl_dt, dpcm_m, dplm_l


def _transient_chain(jac, p, n_dyn: int, a_d, cyl: Cylinder, load: Load, rates, complete: bool) -> None:
    """Add to the acceleration rows the chain through d(dP)/dt of a transient flow force (eq 2.37):
    dP_cyl/dt = (dm_cyl/dt - rho V') dP/dm, its partial by y_s through the mass row of J, rho = m/V
    and dP/dm itself; the inlet sees -dP_cyl/dt, the delivery dP_cyl/dt - dP_load/dt. ``a_d``: (inlet,
    delivery) d(acceleration)/d(ddp_dt)."""
    dmc, dmlr, _, _, dpcm_m, dplm_l = rates
    a_d_in, a_d_del = a_d
    i_load = load_index(p)
    for s in range(n_dyn):
        dpc_s = jac[S_MCYL, s] * cyl.pc_m
        if s == S_MCYL:
            dpc_s += -(cyl.dvol / cyl.vol) * cyl.pc_m + (dmc - cyl.rho_c * cyl.dvol) * dpcm_m
        dpl_s = 0.0
        if complete:
            dpl_s = jac[i_load, s] * load.pl_ml
            if s == i_load:
                dpl_s += dmlr * dplm_l
        if a_d_in != 0.0:
            jac[accel_index(p, OFF_IN, 0), s] += a_d_in * (-dpc_s)
        if a_d_del != 0.0:
            jac[accel_index(p, OFF_DEL, 0), s] += a_d_del * (dpc_s - dpl_s)


def _cylinder(t: float, y, p, mode, pc_hint: float) -> Cylinder:
    """The cylinder at (t, y); ``pc_hint``: its pressure if the caller has it (NaN: computed)."""
    vol, dvol = cylinder_volume_at(t, p)
    m = y[S_MCYL]
    cav = int(mode[MODE.cavitation])
    if pc_hint == pc_hint:
        pc = pc_hint
        rho_c = m / vol
        pc_m = 0.0 if cav == CAVITATING else 1.0 / (vol * oil_density_slope(pc, p))
    else:
        pc, pc_m, rho_c = cylinder_pressure(m, vol, p, cav)
    return Cylinder(vol, dvol, m, pc, pc_m, rho_c, cav)


def _load(y, p) -> Load:
    """The load side at y: the requested pressure in the simplified circuit, the load line's in the complete."""
    if p[G.complete] > 0.5:
        ml = y[load_index(p)]
        pl, pl_ml = load_pressure(ml, p)
        return Load(ml, pl, pl_ml)
    return Load(0.0, p[G.load_pressure], 0.0)


def pump_jacobian(t: float, y, p, mode, pc_hint: float, jac, ft, fscratch, yscratch, atol, rtol: float,
                  n_dyn: int) -> int:
    """The pump's Jacobian df/dy (columns n_dyn.. zero) and df/dt, analytic where the physics is and differenced
    (increments sqrt(eps) max(|y_j|, atol_j / rtol)) where it is not; the integrator's hook (rodas.specialize).

    Parameters
    ----------
    t, y, p, mode
        Time [s], the pump's state, the flat parameter array and the mode (lumped.solver.layout).
    pc_hint : float
        P_cyl at (t, y) [Pa] if the caller has it (NaN: computed here).
    jac, ft, fscratch, yscratch : array of float
        Written: (n, n) df/dy and df/dt (per state's unit); scratch of the state's length.
    atol, rtol : array of float, float
        The integrator's tolerances (the increments' floor).
    n_dyn : int
        States that feed back.

    Returns
    -------
    int
        The right-hand side calls made (0 or 2).
    """
    n = y.shape[0]
    for j in range(n):
        for i in range(n):
            jac[i, j] = 0.0
    cyl = _cylinder(t, y, p, mode, pc_hint)
    load = _load(y, p)
    complete = p[G.complete] > 0.5
    inc = Increments(atol, rtol, SQRT_EPS * max(abs(cyl.m), atol[S_MCYL] / rtol),
                     SQRT_EPS * max(abs(load.ml), atol[load_index(p)] / rtol), complete)
    # ---- mass flows and their partials: d mdot / d(m_cyl, x, u, m_load) per valve
    # inlet: from the tank (a fixed pressure) into the cylinder; delivery: from the cylinder into the load line
    drop_in = (p[G.tank_pressure] - cyl.pc, -cyl.pc_m, 0.0)
    dmi, flow_in, rho_in, rm_in, rl_in = _flow_partials(
        y, p, OFF_IN, int(mode[MODE.inlet_contact]), drop_in, cyl, (p[G.rho_tank], 0.0))
    drop_del = (cyl.pc - load.pl, cyl.pc_m, -load.pl_ml)
    other_del = (load_side_density(load.pl, p), 0.5 * oil_density_slope(load.pl, p) * load.pl_ml)
    dmd, flow_del, rho_del, rm_del, rl_del = _flow_partials(
        y, p, OFF_DEL, int(mode[MODE.delivery_contact]), drop_del, cyl, other_del)
    uses_flow = p[OFF_IN + VALVE.flow_in_acceleration] > 0.5 or p[OFF_DEL + VALVE.flow_in_acceleration] > 0.5
    leak, leak_pc, leak_rho = leakage_mass_flow(cyl.pc, cyl.rho_c, p)
    nv_l = needle_mass_flow(load.pl, p)[1] * load.pl_ml if complete else 0.0
    _mass_rows(jac, p, complete, dmi, dmd, leak_pc * cyl.pc_m + leak_rho / cyl.vol, nv_l)
    # ---- pressure rates seen by a transient flow force, and their partials
    rates = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if uses_flow:
        rates = _pressure_rates(t, y, p, mode, fscratch, cyl, load, inc)
    dpc_dt, dpl_dt = rates[2], rates[3]
    # ---- accelerations, differenced (fscratch and ft are free until the end: the several-DOF valves' scratch)
    scratch = Scratch(yscratch, fscratch, ft)
    side_in = Side(OFF_IN, 0, drop_in[0], drop_in[1], 0.0, cyl.pc, cyl.pc_m, 0.0, rho_in, rm_in, rl_in, -dpc_dt)
    side_del = Side(OFF_DEL, 1, drop_del[0], drop_del[1], drop_del[2], load.pl, 0.0, load.pl_ml, rho_del, rm_del,
                    rl_del, dpc_dt - dpl_dt)
    a_d_in = _valve_rows(y, p, mode, jac, scratch, inc, side_in, flow_in)
    a_d_del = _valve_rows(y, p, mode, jac, scratch, inc, side_del, flow_del)
    if a_d_in != 0.0 or a_d_del != 0.0:
        _transient_chain(jac, p, n_dyn, (a_d_in, a_d_del), cyl, load, rates, complete)
    return _time_partials(t, y, p, mode, jac, ft, (fscratch, yscratch), cyl)


def _time_partials(t: float, y, p, mode, jac, ft, scratch, cyl: Cylinder) -> int:
    """df/dt into ``ft``: through rho_cyl = m/V(t) only (the m_cyl column times -m V'/V), unless a transient
    flow force holds V' itself (a valve's acceleration reads the flow: then differenced, the rhs calls made, 2)."""
    n = y.shape[0]
    if not (p[OFF_IN + VALVE.flow_in_acceleration] > 0.5 or p[OFF_DEL + VALVE.flow_in_acceleration] > 0.5):
        dm_dt = -cyl.m * cyl.dvol / cyl.vol
        for i in range(n):
            ft[i] = jac[i, S_MCYL] * dm_dt
        return 0
    f0, f1 = scratch
    dt = SQRT_EPS * max(abs(t), 1e-6)
    evaluate(t, y, p, mode, f0)
    evaluate(t + dt, y, p, mode, f1)
    for i in range(n):
        ft[i] = (f1[i] - f0[i]) / dt
    return 2
