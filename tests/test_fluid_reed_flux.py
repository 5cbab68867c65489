"""The reed's 3-D flow at a prescribed flow rate (fea.fluid.reed_flux): closed forms and the dP-driven solver.

Fast: the bordered (Lagrange-multiplier) Newton in a rectangular duct returns the series
solution's pressure difference for the series flow rate at Re ~ 40. Slow (``-m slow``): on the
prototype (coarse mesh, 1.71 mm) the flow-rate continuation passes Re 10 to 15 with dP rising,
and its point at Re 10 is the dP-driven solver's at the same dP.
"""

from __future__ import annotations

import numpy as np
import pytest

from fea.fluid import ns3d, reed_flux

from duct import A, B, LD, MU, RHO, duct as _duct, duct_flow


def _duct_dp(q: float) -> float:
    """dP [Pa] that drives Q [m^3/s] through the duct (its flow is linear in dP)."""
    return q / duct_flow(1.0)


def test_prescribed_flow_rate_gives_the_series_pressure_difference():
    # the flow rate of the series at 1e5 Pa (Re ~ 40 on the hydraulic diameter) prescribed: the inlet
    # pressure the bordered Newton finds, from half the Stokes state and half the pressure, is the
    # series' within 1 %, and the flux is met to round-off
    system = ns3d.assemble(_duct(4), ns3d.Fluid(RHO, MU), symmetry="none")
    prob = reed_flux.FluxProblem.build(system)
    q = 4 * A * B**3 * 1e5 / (3 * MU * LD)                          # of the order of the series' flow
    dp_series = _duct_dp(q)
    x0 = ns3d.stokes(system, dp_series * prob.g, np.zeros(len(system.fixed)))
    x, P, steps, factor = reed_flux.flux_newton(prob, -q, 0.5 * x0, 0.5 * dp_series)
    factor.free()
    assert RHO * q / (4 * A * B) * (4 * A * B / (A + B)) / MU > 30.0
    assert P == pytest.approx(dp_series, rel=0.01)
    assert -ns3d.boundary_flux(system, x, "inlet") == pytest.approx(q, rel=1e-9)
    assert steps <= 8


def test_pseudo_transient_flow_from_rest_reaches_the_series_solution():
    # the flow-rate PTC from rest (zero velocity, P = 0) at the series flow rate of 1e5 Pa (Re ~ 40) settles
    # to the steady duct flow: the series' dP within 1 % and the flux to round-off
    system = ns3d.assemble(_duct(4), ns3d.Fluid(RHO, MU), symmetry="none")
    prob = reed_flux.FluxProblem.build(system)
    q = 4 * A * B**3 * 1e5 / (3 * MU * LD)
    x, P, steps, factor = reed_flux.flux_ptc(prob, -q, np.zeros(system.ndofs), 0.0)
    factor.free()
    assert P == pytest.approx(_duct_dp(q), rel=0.01)
    assert -ns3d.boundary_flux(system, x, "inlet") == pytest.approx(q, rel=1e-9)
    assert steps < 40


def test_a_total_pressure_inlet_is_the_static_pressure_plus_the_dynamic_one():
    # Bernoulli at the inlet: for a uniform inflow U the inflow term (beta = 1/2) acts on the momentum
    # equation as the traction of a static pressure lower than P by rho U^2 / 2
    U = 0.7
    load = None
    for inflow in ((), ("inlet",)):
        system = ns3d.assemble(_duct(2), ns3d.Fluid(RHO, MU), symmetry="none", inflow=inflow)
        u = np.zeros(3 * system.nv)
        u[:system.nv] = U                                  # the inlet is x = 0, its normal -x: inflow
        r = ns3d._velocity_block(system, u, False) @ u
        load = r if load is None else r - load
    dyn = ns3d.traction_load(system, {"inlet": 0.5 * RHO * U**2})[:3 * system.nv]
    assert np.allclose(load, dyn, rtol=1e-10, atol=1e-12 * np.max(np.abs(dyn)))


def _kinetic_flux(system, x, name: str, inflow_only: bool = False) -> float:
    """rho / 2 int (u . n) |u|^2 dA over boundary ``name`` [W] (kinetic energy leaving; with ``inflow_only``
    the entering part alone, (u . n) -> min(u . n, 0))."""
    from skfem import ElementTetP2, FacetBasis, Functional

    fb = FacetBasis(system.mesh, ElementTetP2(), facets=system.mesh.boundaries[name])
    n = system.nv
    u = [fb.interpolate(x[a * n:(a + 1) * n]) for a in range(3)]

    @Functional
    def ke(w):
        un = w["u0"] * w.n[0] + w["u1"] * w.n[1] + w["u2"] * w.n[2]
        un = np.minimum(un, 0.0) if inflow_only else un
        return 0.5 * system.fluid.rho * un * (w["u0"] ** 2 + w["u1"] ** 2 + w["u2"] ** 2)
    return float(ke.assemble(fb, u0=u[0], u1=u[1], u2=u[2]))


def _energy_out(system, x) -> float:
    """What the flow does with the power P Q it is given [W]: the viscous dissipation mu int grad u : grad u,
    the kinetic energy leaving through the outlet and the inlet, less what the open boundaries' inflow terms
    take (beta rho int (u . n)_- |u|^2: 2 beta of the inflow's kinetic energy flux)."""
    n = system.nv
    mu = system.fluid.mu
    out = mu * sum(x[a * n:(a + 1) * n] @ (system.K @ x[a * n:(a + 1) * n]) for a in range(3))
    for name, beta in (("outlet", ns3d.BACKFLOW_BETA), ("inlet", ns3d.INFLOW_BETA if system.inflow else 0.0)):
        if name in system.mesh.boundaries:
            out += _kinetic_flux(system, x, name) - 2 * beta * _kinetic_flux(system, x, name, inflow_only=True)
    return out


def test_total_pressure_times_flow_is_dissipation_plus_the_kinetic_energy_leaving():
    # energy balance of the duct at Re ~ 40 with the inlet at a total pressure: P Q = mu int |grad u|^2 +
    # the kinetic energy flux out of the outlet (the inflow's own flux is cancelled by beta = 1/2); the
    # static-pressure (do-nothing) inlet misses it by the inflow's kinetic energy flux, several per cent here
    q = 4 * A * B**3 * 1e5 / (3 * MU * LD)
    miss = {}
    for inflow in ((), ("inlet",)):
        system = ns3d.assemble(_duct(4), ns3d.Fluid(RHO, MU), symmetry="none", inflow=inflow)
        prob = reed_flux.FluxProblem.build(system)
        x0 = ns3d.stokes(system, _duct_dp(q) * prob.g, np.zeros(len(system.fixed)))
        x, P, _, factor = reed_flux.flux_newton(prob, -q, x0, _duct_dp(q))
        factor.free()
        n = system.nv
        dissipation = MU * sum(x[a * n:(a + 1) * n] @ (system.K @ x[a * n:(a + 1) * n]) for a in range(3))
        miss[bool(inflow)] = P * q / (dissipation + _kinetic_flux(system, x, "outlet")) - 1.0
        if inflow:
            assert P * q == pytest.approx(_energy_out(system, x), rel=0.005)
    assert abs(miss[True]) < 0.005
    assert abs(miss[False]) > 0.02


def test_the_reynolds_number_sets_the_half_domains_flux():
    # eq 3.87: Re = 4 rho Q / (p_o mu) with Q both halves; the half domain's inlet outflux is -Q / 2
    from types import SimpleNamespace

    valve = SimpleNamespace(orifice_perimeter=0.0912, fluid=ns3d.Fluid(RHO, MU))
    flux = reed_flux._flux_of(valve, 40.0)
    assert 4 * RHO * (-2.0 * flux) / (0.0912 * MU) == pytest.approx(40.0, rel=1e-12)


def test_the_aim_is_lowered_to_the_pressure_cap():
    # Stokes-like history (Re ~ dP): the Re expected at the cap is proportional; with Re ~ dP^0.5, its root
    x = np.zeros(3)
    assert reed_flux._capped([(0.01, x, 1.0)], 5.0, 100.0) == pytest.approx(1.0)
    hist = [(1.0, x, 100.0), (2.0, x, 400.0)]
    assert reed_flux._capped(hist, 50.0, 1600.0) == pytest.approx(4.0)
    assert reed_flux._capped(hist, 3.0, 1600.0) == 3.0 and reed_flux._capped(hist, 3.0, None) == 3.0


def test_grad_div_matrix_integrates_the_divergences():
    # linear fields are exact in P2: u = (x, 0, 0) and v = (0, y, -2 z) have div u = 1, div v = -1, so
    # v^T G u = -gamma |duct| and u^T G u = gamma |duct| (volume 2a 2b L)
    system = ns3d.assemble(_duct(2), ns3d.Fluid(RHO, MU), symmetry="none", grad_div=3.0)
    n, p = system.nv, system.V.doflocs
    u, v = np.zeros(3 * n), np.zeros(3 * n)
    u[:n] = p[0]
    v[n:2 * n], v[2 * n:] = p[1], -2 * p[2]
    vol = 2 * A * 2 * B * LD
    assert u @ (system.grad_div @ u) == pytest.approx(3.0 * vol, rel=1e-10)
    assert v @ (system.grad_div @ u) == pytest.approx(-3.0 * vol, rel=1e-10)


def test_grad_div_leaves_the_duct_flow_the_series_one():
    # grad-div is consistent (zero on a solenoidal field): with gamma = mu the prescribed series flow
    # still needs the series' dP within 1 % at Re ~ 40, and int (div u)^2 is lower than without
    q = 4 * A * B**3 * 1e5 / (3 * MU * LD)
    dp_series = _duct_dp(q)
    div = []
    for gamma in (0.0, MU):
        system = ns3d.assemble(_duct(4), ns3d.Fluid(RHO, MU), symmetry="none", grad_div=gamma)
        prob = reed_flux.FluxProblem.build(system)
        x0 = ns3d.stokes(system, dp_series * prob.g, np.zeros(len(system.fixed)))
        x, P, _, factor = reed_flux.flux_newton(prob, -q, 0.5 * x0, 0.5 * dp_series)
        factor.free()
        assert P == pytest.approx(dp_series, rel=0.01)
        n3 = 3 * system.nv
        G1 = ns3d.grad_div_matrix(system.fast, 1.0)
        div.append(float(x[:n3] @ (G1 @ x[:n3])))            # int (div u)^2 dx
    assert div[1] < 0.6 * div[0]                              # measured 0.51 (4 cells across)


def test_spectrum_is_the_dense_generalised_eigenproblems():
    # the eigenvalues nearest zero of J_b v = lambda M_b v by ARPACK shift-invert equal those of a dense
    # QZ solve (scipy.linalg.eig) of the same pencil at a Navier-Stokes state; at rest (the Jacobian is the
    # Stokes operator, symmetric) every one is real and positive
    import scipy.linalg as sl
    import scipy.sparse as sp

    system = ns3d.assemble(_duct(2), ns3d.Fluid(RHO, MU), symmetry="none")
    prob = reed_flux.FluxProblem.build(system)
    q = 4 * A * B**3 * 1e5 / (3 * MU * LD)
    x0 = ns3d.stokes(system, _duct_dp(q) * prob.g, np.zeros(len(system.fixed)))
    x, _, _, factor = reed_flux.flux_newton(prob, -q, x0, _duct_dp(q))
    factor.free()
    for state in (np.zeros_like(x), x):
        vals = reed_flux.spectrum(prob, state, 4)
        Jb = reed_flux.bordered_jacobian(prob, state).toarray()
        M = ns3d.velocity_mass(system)[prob.free][:, prob.free]
        Mb = sp.block_diag([M, sp.csr_matrix((1, 1))]).toarray()
        dense = sl.eig(Jb, Mb, right=False)
        dense = dense[np.isfinite(dense)]
        dense = dense[np.argsort(np.abs(dense))][:4]
        assert np.max(np.min(np.abs(vals[:, None] - dense[None, :]), axis=1) / np.abs(vals)) < 1e-6
    stokes_vals = reed_flux.spectrum(prob, np.zeros_like(x), 4)
    assert np.all(np.abs(stokes_vals.imag) < 1e-8 * np.abs(stokes_vals)) and np.all(stokes_vals.real > 0)


@pytest.mark.slow
def test_flow_rate_continuation_on_the_prototype_matches_the_pressure_driven_solve():
    # coarse mesh at 1.71 mm: the flow-rate continuation reaches Re 15 with dP rising at each point;
    # the dP-driven Newton at its Re-10 point's dP returns its flow (the same discrete problem: the
    # Lagrange multiplier is the inlet pressure) within 1e-5
    from dataclasses import replace

    from fea.fluid import reed3d

    valve = replace(reed3d.prototype_valve(), mesh=reed3d.STUDY_MESHES[0])
    pts = reed_flux.flow_sweep(valve, 1.71e-3, (1.0, 10.0, 15.0), progress=False)
    assert pts[-1].reynolds == pytest.approx(15.0, rel=1e-6)
    dps = [p.dp for p in pts[1:]]
    assert all(b > a for a, b in zip(dps, dps[1:]))
    at10 = next(p for p in pts if abs(p.reynolds - 10.0) < 1e-6)
    ref = reed3d.pressure_sweep(valve, 1.71e-3, dps=(at10.dp / 4, at10.dp / 2, at10.dp), progress=False)[-1]
    assert ref.flow == pytest.approx(at10.flow, rel=1e-5)
    assert ref.multiplier == pytest.approx(at10.multiplier, rel=1e-5)


@pytest.mark.slow
def test_the_prototypes_flow_at_re_40_conserves_energy_and_is_the_one_from_rest():
    # coarse mesh, 1.71 mm, the inlet at a total pressure: the flow-rate continuation reaches Re 40; there
    # P Q equals the dissipation plus the kinetic energy leaving (a conservation law, within 2 %, measured
    # 1.1 %: the rest is Taylor-Hood's discrete divergence, which grad-div shows at 3.6 % of dP on this mesh,
    # and quadrature; the static inlet would miss by the inflow's kinetic energy, rho U^2 / 2 of the port alone
    # 6 % of dP), the pseudo-transient run from rest settles to the same flow (an independent path: dP within
    # 1e-6), and the smallest eigenvalue of the bordered Jacobian is real and positive (a stable steady flow;
    # measured 78.8 1/s)
    from dataclasses import replace

    from fea.fluid import reed3d

    valve = replace(reed3d.prototype_valve(), mesh=reed3d.STUDY_MESHES[0])
    assert valve.inlet_total
    states = {}
    pts = reed_flux.flow_sweep(valve, 1.71e-3, (1.0, 10.0, 40.0), progress=False,
                               on_state=lambda prob, x, P, p: states.update({round(p.reynolds, 9): (prob, x, P)}))
    assert pts[-1].reynolds == pytest.approx(40.0, rel=1e-9)
    prob, x, P = states[40.0]
    flux = reed_flux._flux_of(valve, 40.0)
    assert P * -flux == pytest.approx(_energy_out(prob.system, x), rel=0.02)
    xr, Pr, _, factor = reed_flux.flux_ptc(prob, flux, np.zeros_like(x), 0.0)
    factor.free()
    assert Pr == pytest.approx(P, rel=1e-6)
    lam = reed_flux.spectrum(prob, x, 2)
    assert abs(lam[0].imag) < 1e-6 * abs(lam[0]) and lam[0].real > 10.0
