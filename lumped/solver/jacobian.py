"""The Jacobian of the pump's right-hand side from the partials the physics already has.

df/dy by the chain rule through the pump equations (``lumped.solver.rhs.evaluate``):
rho_cyl = m_cyl / V(t) (eq 4.6), P_cyl from eq 4.11 with dP/dm = 1 / (V drho/dP) (0 while
cavitating), the valve mass flows of eqs 4.3-4.4 and their partials from
:func:`lumped.valves.kind.mass_flow` (the same function ``evaluate`` takes the flows from:
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


def _accel(x: float, u: float, dp: float, p_down: float, rho: float, ddp_dt: float, p, o: int, contact: int,
           regime: int, recompute: bool, qo: float, cd: float, aq: float, dqp: float, dqx: float) -> float:
    """A one-DOF valve's acceleration at perturbed inputs; its flow recomputed if the kind reads it."""
    if recompute:
        qo, cd, aq, dqp, dqx = valve_flow(x, u, dp, rho, p[G.viscosity], p, o, contact)
    f = ValveInputs(dp, p_down, p[G.vapour_pressure], rho, p[G.viscosity], qo, cd, aq, dqp, dqx, ddp_dt)
    return valve_acceleration(x, u, f, p, o, contact, regime)


def _accels(y, x: float, u: float, dp: float, p_down: float, rho: float, ddp_dt: float, p, o: int, contact: int,
            regime: int, recompute: bool, flow, out) -> None:
    """A several-DOF valve's accelerations at perturbed inputs (states y) into out at its rates' slots."""
    qo, cd, aq, dqp, dqx = flow
    if recompute:
        qo, cd, aq, dqp, dqx = valve_flow(x, u, dp, rho, p[G.viscosity], p, o, contact)
    f = ValveInputs(dp, p_down, p[G.vapour_pressure], rho, p[G.viscosity], qo, cd, aq, dqp, dqx, ddp_dt)
    valve_accelerations(y, state_start(p, o), dofs(p, o), x, u, f, p, o, contact, regime, out)


def _flow_partials(y, p, o: int, contact: int, dp: float, dp_m: float, dp_l: float, rho_c: float, other: float,
                   rho_other_l: float, vol: float, mu: float):
    """A valve's flow and the partials of its mass flow by (m_cyl, x, u, m_load).

    ``dp_m``, ``dp_l``: d(dp)/dm_cyl, d(dp)/dm_load; ``other`` the density on the valve's other side
    and ``rho_other_l`` its derivative by m_load (the load side of the complete circuit).
    """
    x, u = opening(y, p, o)
    rho_v, frac = orifice_density(rho_c, other, p, o)
    r_m = frac / vol
    r_l = rho_other_l if frac < 1.0 else 0.0
    qo, cd, aq, dqp, dqx = valve_flow(x, u, dp, rho_v, mu, p, o, contact)
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


def _valve_rows(t, y, p, mode, jac, yscratch, atol, rtol: float, o: int, v: int, dp: float, dp_m: float,
                dp_l: float, pd: float, pd_m: float, pd_l: float, rho_v: float, r_m: float, r_l: float, ddt: float,
                flow, hm: float, hml: float, complete: bool, a0, a1) -> float:
    """The valve's rows: positions move at their rates; its accelerations differenced (forward) by its
    states, m_cyl and m_load. Returns d(acceleration)/d(ddp_dt) of a one-DOF kind that reads the flow
    (the transient flow force's chain; 0 otherwise). ``a0``, ``a1``: scratch the length of the state."""
    contact = int(mode[CONTACT_SLOT[v]])
    regime = int(mode[REGIME_SLOT[v]])
    rec = p[o + VALVE.flow_in_acceleration] > 0.5
    qo, cd, aq, dqp, dqx = flow
    x, u = opening(y, p, o)
    n = dofs(p, o)
    i_load = load_index(p)
    if is_scalar(p, o):
        xi, ui = position_index(p, o, 0), accel_index(p, o, 0)
        jac[xi, ui] = 1.0
        hx = SQRT_EPS * max(abs(x), atol[xi] / rtol)
        hu = SQRT_EPS * max(abs(u), atol[ui] / rtol)
        a0 = _accel(x, u, dp, pd, rho_v, ddt, p, o, contact, regime, False, qo, cd, aq, dqp, dqx)
        ax = _accel(x + hx, u, dp, pd, rho_v, ddt, p, o, contact, regime, rec, qo, cd, aq, dqp, dqx)
        au = _accel(x, u + hu, dp, pd, rho_v, ddt, p, o, contact, regime, rec, qo, cd, aq, dqp, dqx)
        am = _accel(x, u, dp + dp_m * hm, pd + pd_m * hm, rho_v + r_m * hm, ddt, p, o, contact, regime, rec,
                    qo, cd, aq, dqp, dqx)
        jac[ui, xi] = (ax - a0) / hx
        jac[ui, ui] = (au - a0) / hu
        jac[ui, S_MCYL] = (am - a0) / hm
        if complete:
            al = _accel(x, u, dp + dp_l * hml, pd + pd_l * hml, rho_v + r_l * hml, ddt, p, o, contact, regime,
                        rec, qo, cd, aq, dqp, dqx)
            jac[ui, i_load] = (al - a0) / hml
        if not rec:
            return 0.0
        hd = SQRT_EPS * max(abs(ddt), 1.0)
        return (_accel(x, u, dp, pd, rho_v, ddt + hd, p, o, contact, regime, False, qo, cd, aq, dqp, dqx) - a0) / hd
    _multi_rows(y, p, mode, jac, yscratch, atol, rtol, o, x, u, dp, dp_m, dp_l, pd, pd_m, pd_l, rho_v, r_m, r_l, ddt,
                flow, hm, hml, complete, contact, regime, rec, n, a0, a1)
    return 0.0


def _multi_rows(y, p, mode, jac, yscratch, atol, rtol: float, o: int, x: float, u: float, dp: float, dp_m: float,
                dp_l: float, pd: float, pd_m: float, pd_l: float, rho_v: float, r_m: float, r_l: float, ddt: float,
                flow, hm: float, hml: float, complete: bool, contact: int, regime: int, rec: bool, n: int, a0,
                a1) -> None:
    """The acceleration rows of a valve with n > 1 DOFs: columns by each position and rate (its kind's
    partials where it has them and does not read the flow, else forward differences), then by the
    pressures (forward differences). ``a0``, ``a1``: scratch for its accelerations at their rates' slots."""
    i_load = load_index(p)
    s = state_start(p, o)
    r = s + n                                # the rows of its accelerations (its rates' slots)
    for j in range(n):
        jac[s + j, r + j] = 1.0
    _accels(y, x, u, dp, pd, rho_v, ddt, p, o, contact, regime, False, flow, a0)
    own = False
    if not rec:
        qo, cd, aq, dqp, dqx = flow
        f = ValveInputs(dp, pd, p[G.vapour_pressure], rho_v, p[G.viscosity], qo, cd, aq, dqp, dqx, ddt)
        own = valve_accelerations_jacobian(y, s, n, x, u, f, p, o, contact, regime, jac)
    if not own:
        for i in range(y.shape[0]):
            yscratch[i] = y[i]
        for j in range(2 * n):
            k = s + j                        # positions, then the rates right after them
            h = SQRT_EPS * max(abs(y[k]), atol[k] / rtol)
            w = opening_weight(p, o, j % n)
            yscratch[k] = y[k] + h
            if j < n:
                _accels(yscratch, x + w * h, u, dp, pd, rho_v, ddt, p, o, contact, regime, rec, flow, a1)
            else:
                _accels(yscratch, x, u + w * h, dp, pd, rho_v, ddt, p, o, contact, regime, rec, flow, a1)
            yscratch[k] = y[k]
            for i in range(n):
                jac[r + i, k] = (a1[r + i] - a0[r + i]) / h
    _accels(y, x, u, dp + dp_m * hm, pd + pd_m * hm, rho_v + r_m * hm, ddt, p, o, contact, regime, rec, flow, a1)
    for i in range(n):
        jac[r + i, S_MCYL] = (a1[r + i] - a0[r + i]) / hm
    if complete:
        _accels(y, x, u, dp + dp_l * hml, pd + pd_l * hml, rho_v + r_l * hml, ddt, p, o, contact, regime, rec,
                flow, a1)
        for i in range(n):
            jac[r + i, i_load] = (a1[r + i] - a0[r + i]) / hml


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


def _pressure_rates(t: float, y, p, mode, fscratch, vol: float, dvol: float, rho_c: float, pc: float, pc_m: float,
                    ml: float, pl_ml: float, hm: float, hml: float, cav: int, complete: bool):
    """What a transient flow force's chain needs: (dm_cyl/dt, dm_load/dt, dP_cyl/dt, dP_load/dt,
    d(dP_cyl/dm)/dm_cyl, d(dP_load/dm)/dm_load)."""
    r0 = evaluate(t, y, p, mode, fscratch)
    dmc = r0.dm_cyl
    dmlr = r0.dm_load
    dpc_dt = (dmc - rho_c * dvol) * pc_m
    dpl_dt = 0.0
    dpcm_m = 0.0
    dplm_l = 0.0
    if complete:
        dpl_dt = dmlr * pl_ml
    if cav != CAVITATING:
        # d(pc_m)/dm = d/dm 1/(V rho'(P)): rho' at the perturbed pressure, no inversion
        pc_m2 = 1.0 / (vol * oil_density_slope(pc + pc_m * hm, p))
        dpcm_m = (pc_m2 - pc_m) / hm
    if complete:
        plm2 = load_pressure(ml + hml, p)[1]
        dplm_l = (plm2 - pl_ml) / hml
    return dmc, dmlr, dpc_dt, dpl_dt, dpcm_m, dplm_l


def _transient_chain(jac, p, n_dyn: int, a_d_in: float, a_d_del: float, vol: float, dvol: float, rho_c: float,
                     pc_m: float, pl_ml: float, rates, complete: bool) -> None:
    """Add to the acceleration rows the chain through d(dP)/dt of a transient flow force (eq 2.37):
    dP_cyl/dt = (dm_cyl/dt - rho V') dP/dm, its partial by y_s through the mass row of J, rho = m/V
    and dP/dm itself; the inlet sees -dP_cyl/dt, the delivery dP_cyl/dt - dP_load/dt."""
    dmc, dmlr, _, _, dpcm_m, dplm_l = rates
    i_load = load_index(p)
    for s in range(n_dyn):
        dpc_s = jac[S_MCYL, s] * pc_m
        if s == S_MCYL:
            dpc_s += -(dvol / vol) * pc_m + (dmc - rho_c * dvol) * dpcm_m
        dpl_s = 0.0
        if complete:
            dpl_s = jac[i_load, s] * pl_ml
            if s == i_load:
                dpl_s += dmlr * dplm_l
        if a_d_in != 0.0:
            jac[accel_index(p, OFF_IN, 0), s] += a_d_in * (-dpc_s)
        if a_d_del != 0.0:
            jac[accel_index(p, OFF_DEL, 0), s] += a_d_del * (dpc_s - dpl_s)


def pump_jacobian(t: float, y, p, mode, pc_hint: float, jac, ft, fscratch, yscratch, atol, rtol: float,
                  n_dyn: int) -> int:
    """Fill ``jac`` (df/dy, columns n_dyn.. zero) and ``ft`` (df/dt); returns the rhs calls made (0 or 2).

    ``pc_hint``: P_cyl at (t, y) if the caller has it (NaN: computed here). Increments of
    the differenced accelerations: sqrt(eps) max(|y_j|, atol_j / rtol).
    """
    n = y.shape[0]
    for j in range(n):
        for i in range(n):
            jac[i, j] = 0.0
    vol, dvol = cylinder_volume_at(t, p)
    m = y[S_MCYL]
    cav = int(mode[MODE.cavitation])
    if pc_hint == pc_hint:
        pc = pc_hint
        rho_c = m / vol
        pc_m = 0.0 if cav == CAVITATING else 1.0 / (vol * oil_density_slope(pc, p))
    else:
        pc, pc_m, rho_c = cylinder_pressure(m, vol, p, cav)
    complete = p[G.complete] > 0.5
    pt = p[G.tank_pressure]
    pl = p[G.load_pressure]
    pl_ml = 0.0
    ml = 0.0
    i_load = load_index(p)
    if complete:
        ml = y[i_load]
        pl, pl_ml = load_pressure(ml, p)
    mu = p[G.viscosity]
    hm = SQRT_EPS * max(abs(m), atol[S_MCYL] / rtol)
    hml = SQRT_EPS * max(abs(ml), atol[i_load] / rtol)

    # ---- mass flows and their partials: d mdot / d(m_cyl, x, u, m_load) per valve
    # inlet: from the tank (a fixed pressure) into the cylinder
    dp_in, dpm_in = pt - pc, -pc_m
    dmi, flow_in, rho_in, rm_in, rl_in = _flow_partials(
        y, p, OFF_IN, int(mode[MODE.inlet_contact]), dp_in, dpm_in, 0.0, rho_c, p[G.rho_tank], 0.0, vol, mu)
    # delivery: from the cylinder into the load line
    dp_del, dpm_del, dpl_del = pc - pl, pc_m, -pl_ml
    other_l = 0.5 * oil_density_slope(pl, p) * pl_ml
    dmd, flow_del, rho_del, rm_del, rl_del = _flow_partials(
        y, p, OFF_DEL, int(mode[MODE.delivery_contact]), dp_del, dpm_del, dpl_del, rho_c,
        load_side_density(pl, p), other_l, vol, mu)
    uses_flow = p[OFF_IN + VALVE.flow_in_acceleration] > 0.5 or p[OFF_DEL + VALVE.flow_in_acceleration] > 0.5
    leak, leak_pc, leak_rho = leakage_mass_flow(pc, rho_c, p)
    nv_l = needle_mass_flow(pl, p)[1] * pl_ml if complete else 0.0
    _mass_rows(jac, p, complete, dmi, dmd, leak_pc * pc_m + leak_rho / vol, nv_l)

    # ---- pressure rates seen by a transient flow force, and their partials
    rates = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if uses_flow:
        rates = _pressure_rates(t, y, p, mode, fscratch, vol, dvol, rho_c, pc, pc_m, ml, pl_ml, hm, hml, cav,
                                complete)
    dpc_dt, dpl_dt = rates[2], rates[3]

    # ---- accelerations, differenced
    # fscratch and ft are free until the end: the several-DOF valves' scratch
    a_d_in = _valve_rows(t, y, p, mode, jac, yscratch, atol, rtol, OFF_IN, 0, dp_in, dpm_in, 0.0, pc, pc_m, 0.0,
                         rho_in, rm_in, rl_in, -dpc_dt, flow_in, hm, hml, complete, fscratch, ft)
    a_d_del = _valve_rows(t, y, p, mode, jac, yscratch, atol, rtol, OFF_DEL, 1, dp_del, dpm_del, dpl_del, pl, 0.0,
                          pl_ml, rho_del, rm_del, rl_del, dpc_dt - dpl_dt, flow_del, hm, hml, complete, fscratch, ft)
    if a_d_in != 0.0 or a_d_del != 0.0:
        _transient_chain(jac, p, n_dyn, a_d_in, a_d_del, vol, dvol, rho_c, pc_m, pl_ml, rates, complete)

    # ---- df/dt: through rho_cyl = m/V(t) only, unless a transient flow force holds V' itself
    if not uses_flow:
        dm_dt = -m * dvol / vol
        for i in range(n):
            ft[i] = jac[i, S_MCYL] * dm_dt
        return 0
    dt = SQRT_EPS * max(abs(t), 1e-6)
    evaluate(t, y, p, mode, fscratch)
    evaluate(t + dt, y, p, mode, yscratch)
    for i in range(n):
        ft[i] = (yscratch[i] - fscratch[i]) / dt
    return 2
