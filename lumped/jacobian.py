"""The Jacobian of the pump's right-hand side from the partials the physics already has.

df/dy by the chain rule through the pump equations (``lumped.pump.evaluate``):
rho_cyl = m_cyl / V(t) (eq 4.6), P_cyl from eq 4.11 with dP/dm = 1 / (V drho/dP) (0 while
cavitating), the valve mass flows of eqs 4.3-4.4 and their partials from
:func:`lumped.valve.mass_flow` (the same function ``evaluate`` takes the flows from:
the mass-balance partials are written once), the piston leakage and needle valve from
``lumped.pump``'s own (value, derivative) functions, and the load line's dP/dm. Only the
valve accelerations are differenced (forward, in x, u and in m_cyl, m_load through the
pressures and densities they see; a kind whose acceleration reads the flow, e.g. a
disc with flow forces, gets its flow recomputed at each perturbation and the chain
through d(dP)/dt of the transient force added).

Time enters only through V(t) in rho_cyl = m/V, so df/dt = df/dm_cyl (-m_cyl V'/V),
except through the transient flow force, whose dP/dt holds V' itself: then df/dt is
differenced. tests/test_jacobian.py compares every entry with central differences of
the right-hand side for random models, each effect on in turn, both kinds, mixed kinds
and both circuits.
"""

from __future__ import annotations

from lumped.pump import (
    G, M_CAV, M_CDEL, M_CIN, M_RDEL, M_RIN, OFF_DEL, OFF_IN, S_MCYL, S_MIN, S_MLEAK, S_MLOAD, S_MNV, S_MOUT,
    cylinder_pressure, cylinder_volume_at, evaluate, leakage_mass_flow, load_pressure, load_side_density,
    needle_mass_flow, oil_density_slope, orifice_density, rates_to_derivative,
)
from lumped.valve import VALVE, mass_flow, valve_acceleration, valve_flow

SQRT_EPS = 1.4901161193847656e-08


def _accel(x: float, u: float, dp: float, p_down: float, rho: float, ddp_dt: float, p, o: int, contact: int,
           regime: int, recompute: bool, qo: float, cd: float, aq: float, dqp: float, dqx: float) -> float:
    """A valve's acceleration at perturbed inputs; its flow recomputed if the kind reads it."""
    if recompute:
        qo, cd, aq, dqp, dqx = valve_flow(x, u, dp, rho, p[G.viscosity], p, o, contact)
    return valve_acceleration(x, u, dp, p_down, p[G.vapour_pressure], rho, p[G.viscosity], qo, cd, aq, dqp, dqx,
                              ddp_dt, p, o, contact, regime)


def pump_jacobian(t: float, y, p, mode, pc_hint: float, jac, ft, fscratch, yscratch, atol, rtol: float,
                  n_dyn: int) -> int:
    """Fill ``jac`` (df/dy, columns n_dyn.. zero) and ``ft`` (df/dt); returns the rhs calls made (0 or 1).

    ``pc_hint``: P_cyl at (t, y) if the caller has it (NaN: computed here). Increments of
    the differenced accelerations: sqrt(eps) max(|y_j|, atol_j / rtol).
    """
    n = y.shape[0]
    for j in range(n):
        for i in range(n):
            jac[i, j] = 0.0
    vol, dvol = cylinder_volume_at(t, p)
    m = y[S_MCYL]
    cav = int(mode[M_CAV])
    if pc_hint == pc_hint:
        pc = pc_hint
        rho_c = m / vol
        pc_m = 0.0 if cav == 1 else 1.0 / (vol * oil_density_slope(pc, p))
    else:
        pc, pc_m, rho_c = cylinder_pressure(m, vol, p, cav)
    complete = p[G.complete] > 0.5
    pt = p[G.tank_pressure]
    pl = p[G.load_pressure]
    pl_ml = 0.0
    ml = 0.0
    if complete:
        ml = y[S_MLOAD]
        pl, pl_ml = load_pressure(ml, p)
    mu = p[G.viscosity]
    hm = SQRT_EPS * max(abs(m), atol[S_MCYL] / rtol)
    hml = SQRT_EPS * max(abs(ml), atol[S_MLOAD] / rtol)

    # ---- mass flows and their partials: d mdot / d(m_cyl, x, u, m_load) per valve
    dmd = (0.0, 0.0, 0.0, 0.0)
    dmi = (0.0, 0.0, 0.0, 0.0)
    flow_in = (0.0, 0.0, 0.0, 0.0, 0.0)      # valve_flow of each valve, reused for its acceleration
    flow_del = (0.0, 0.0, 0.0, 0.0, 0.0)
    uses_flow = False
    for v in range(2):
        o = OFF_IN if v == 0 else OFF_DEL
        xi = 1 + 2 * v
        x, u = y[xi], y[xi + 1]
        contact = int(mode[M_CIN if v == 0 else M_CDEL])
        if v == 0:
            dp, dp_m, dp_l = pt - pc, -pc_m, 0.0
            other = p[G.rho_tank]
        else:
            dp, dp_m, dp_l = pc - pl, pc_m, -pl_ml
            other = load_side_density(pl, p)
        rho_v, frac = orifice_density(rho_c, other, p, o)
        r_m = frac / vol
        r_l = 0.0
        if v == 1 and frac < 1.0:
            r_l = 0.5 * oil_density_slope(pl, p) * pl_ml
        qo, cd, aq, dqp, dqx = valve_flow(x, u, dp, rho_v, mu, p, o, contact)
        mdot, f_dp, f_rho, f_x, f_u = mass_flow(qo, aq, u, dp, rho_v, dqp, dqx)
        part = (f_dp * dp_m + f_rho * r_m, f_x, f_u, f_dp * dp_l + f_rho * r_l)
        flow = (qo, cd, aq, dqp, dqx)
        if v == 0:
            dmi = part
            flow_in = flow
        else:
            dmd = part
            flow_del = flow
        if p[o + VALVE.flow_in_acceleration] > 0.5:
            uses_flow = True
    leak, leak_pc, leak_rho = leakage_mass_flow(pc, rho_c, p)
    leak_m = leak_pc * pc_m + leak_rho / vol
    nv_l = 0.0
    if complete:
        nv_l = needle_mass_flow(pl, p)[1] * pl_ml
    # rows of the masses (eq 4.5; the load line; the running totals)
    jac[S_MCYL, S_MCYL] = dmi[0] - dmd[0] - leak_m
    jac[S_MCYL, 1] = dmi[1]
    jac[S_MCYL, 2] = dmi[2]
    jac[S_MCYL, 3] = -dmd[1]
    jac[S_MCYL, 4] = -dmd[2]
    jac[S_MIN, S_MCYL] = dmi[0]
    jac[S_MIN, 1] = dmi[1]
    jac[S_MIN, 2] = dmi[2]
    jac[S_MOUT, S_MCYL] = dmd[0]
    jac[S_MOUT, 3] = dmd[1]
    jac[S_MOUT, 4] = dmd[2]
    jac[S_MLEAK, S_MCYL] = leak_m
    if complete:
        jac[S_MCYL, S_MLOAD] = -dmd[3]
        jac[S_MOUT, S_MLOAD] = dmd[3]
        jac[S_MLOAD, S_MCYL] = dmd[0]
        jac[S_MLOAD, 3] = dmd[1]
        jac[S_MLOAD, 4] = dmd[2]
        jac[S_MLOAD, S_MLOAD] = dmd[3] - nv_l
        jac[S_MNV, S_MLOAD] = nv_l
    jac[1, 2] = 1.0
    jac[3, 4] = 1.0

    # ---- pressure rates seen by a transient flow force, and their partials
    dmc = 0.0          # dm_cyl/dt and dm_load/dt, needed only by a transient flow force
    dmlr = 0.0
    dpc_dt = 0.0
    dpl_dt = 0.0
    dpcm_m = 0.0
    dplm_l = 0.0
    if uses_flow:
        r0 = evaluate(t, y, p, mode)
        dmc = r0.dm_cyl
        dmlr = r0.dm_load
        dpc_dt = (dmc - rho_c * dvol) * pc_m
        if complete:
            dpl_dt = dmlr * pl_ml
        if cav == 0:
            # d(pc_m)/dm = d/dm 1/(V rho'(P)): rho' at the perturbed pressure, no inversion
            pc_m2 = 1.0 / (vol * oil_density_slope(pc + pc_m * hm, p))
            dpcm_m = (pc_m2 - pc_m) / hm
        if complete:
            plm2 = load_pressure(ml + hml, p)[1]
            dplm_l = (plm2 - pl_ml) / hml

    # ---- accelerations, differenced
    for v in range(2):
        o = OFF_IN if v == 0 else OFF_DEL
        xi = 1 + 2 * v
        x, u = y[xi], y[xi + 1]
        contact = int(mode[M_CIN if v == 0 else M_CDEL])
        regime = int(mode[M_RIN if v == 0 else M_RDEL])
        if v == 0:
            dp, dp_m, dp_l, pd, pd_m, pd_l, other = pt - pc, -pc_m, 0.0, pc, pc_m, 0.0, p[G.rho_tank]
            qo, cd, aq, dqp, dqx = flow_in
        else:
            dp, dp_m, dp_l, pd, pd_m, pd_l, other = pc - pl, pc_m, -pl_ml, pl, 0.0, pl_ml, load_side_density(pl, p)
            qo, cd, aq, dqp, dqx = flow_del
        rho_v, frac = orifice_density(rho_c, other, p, o)
        r_m = frac / vol
        r_l = 0.5 * oil_density_slope(pl, p) * pl_ml if (v == 1 and frac < 1.0) else 0.0
        ddt = -dpc_dt if v == 0 else dpc_dt - dpl_dt
        rec = p[o + VALVE.flow_in_acceleration] > 0.5
        hx = SQRT_EPS * max(abs(x), atol[xi] / rtol)
        hu = SQRT_EPS * max(abs(u), atol[xi + 1] / rtol)
        a0 = _accel(x, u, dp, pd, rho_v, ddt, p, o, contact, regime, False, qo, cd, aq, dqp, dqx)
        ax = _accel(x + hx, u, dp, pd, rho_v, ddt, p, o, contact, regime, rec, qo, cd, aq, dqp, dqx)
        au = _accel(x, u + hu, dp, pd, rho_v, ddt, p, o, contact, regime, rec, qo, cd, aq, dqp, dqx)
        am = _accel(x, u, dp + dp_m * hm, pd + pd_m * hm, rho_v + r_m * hm, ddt, p, o, contact, regime, rec,
                    qo, cd, aq, dqp, dqx)
        jac[xi + 1, xi] = (ax - a0) / hx
        jac[xi + 1, xi + 1] = (au - a0) / hu
        jac[xi + 1, S_MCYL] = (am - a0) / hm
        if complete:
            al = _accel(x, u, dp + dp_l * hml, pd + pd_l * hml, rho_v + r_l * hml, ddt, p, o, contact, regime,
                        rec, qo, cd, aq, dqp, dqx)
            jac[xi + 1, S_MLOAD] = (al - a0) / hml
        if rec:
            hd = SQRT_EPS * max(abs(ddt), 1.0)
            a_d = (_accel(x, u, dp, pd, rho_v, ddt + hd, p, o, contact, regime, False, qo, cd, aq, dqp, dqx)
                   - a0) / hd
            # dP_cyl/dt = (dm_cyl/dt - rho V') dP/dm: its partial by y_s through the mass row of J,
            # rho = m/V and dP/dm itself
            sgn = -1.0 if v == 0 else 1.0
            for s in range(n_dyn):
                dpc_s = jac[S_MCYL, s] * pc_m
                if s == S_MCYL:
                    dpc_s += -(dvol / vol) * pc_m + (dmc - rho_c * dvol) * dpcm_m
                d_s = sgn * dpc_s
                if v == 1 and complete:
                    dpl_s = jac[S_MLOAD, s] * pl_ml
                    if s == S_MLOAD:
                        dpl_s += dmlr * dplm_l
                    d_s -= dpl_s
                jac[xi + 1, s] += a_d * d_s

    # ---- df/dt: through rho_cyl = m/V(t) only, unless a transient flow force holds V' itself
    if not uses_flow:
        dm_dt = -m * dvol / vol
        for i in range(n):
            ft[i] = jac[i, S_MCYL] * dm_dt
        return 0
    dt = SQRT_EPS * max(abs(t), 1e-6)
    e0 = evaluate(t, y, p, mode)
    e1 = evaluate(t + dt, y, p, mode)
    rates_to_derivative(e0, fscratch)
    rates_to_derivative(e1, yscratch)
    for i in range(n):
        ft[i] = (yscratch[i] - fscratch[i]) / dt
    return 2
