"""The reed valve's 3-D laminar flow (fea.fluid.reed3d, reed_mesh, ns3d): closed forms and invariants.

Fast tests: Taylor-Hood Stokes and Navier-Stokes in a rectangular duct against the series
solution (flow rate within 1 %), the fluid mesh's volume and boundary areas against the
geometry's own arithmetic, conservation of a coarse reed solve. The 3-D model against the
thin film, the mesh study and the pressure sweeps are slow (``-m slow``).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import skfem
from skfem import ElementTetP1, FacetBasis, Functional

from fea.fluid import ns3d, reed3d
from fea.fluid.reed_mesh import Layers, MeshOptions, fluid_mesh

from duct import A, B, MU, RHO, duct as _duct, duct_flow as _duct_flow


@pytest.fixture(scope="module")
def duct():
    system = ns3d.assemble(_duct(4), ns3d.Fluid(RHO, MU), symmetry="none")
    return system, ns3d.traction_load(system, {"inlet": 1.0})


def test_duct_stokes_flow_within_one_percent(duct):
    system, unit = duct
    x = ns3d.stokes(system, 100.0 * unit, np.zeros(len(system.fixed)))
    q_in, q_out = -ns3d.boundary_flux(system, x, "inlet"), ns3d.boundary_flux(system, x, "outlet")
    assert q_in == pytest.approx(_duct_flow(100.0), rel=0.01)
    assert q_out == pytest.approx(q_in, rel=1e-10)


def test_duct_navier_stokes_keeps_the_developed_profile(duct):
    # unidirectional flow has (u . grad) u = 0: with inertia (Re ~ 40 on the hydraulic
    # diameter) Newton must return the Stokes flow rate from a guess half of it
    system, unit = duct
    dp = 1.0e5
    x0 = ns3d.stokes(system, dp * unit, np.zeros(len(system.fixed)))
    x, steps, factor = ns3d.newton(system, dp * unit, 0.5 * x0)
    factor.free()
    q = -ns3d.boundary_flux(system, x, "inlet")
    d_h = 4 * A * B / (A + B)
    assert RHO * q / (4 * A * B) * d_h / MU > 30.0
    assert q == pytest.approx(_duct_flow(dp), rel=0.01)
    assert steps <= 8


def test_duct_pseudo_transient_continuation_from_rest_reaches_the_series_flow(duct):
    # from a start far outside Newton's basin (a tenth of the flow) pseudo-time steps with the
    # physical mass reach the steady developed flow: the series flow rate within 1 %, and the
    # iteration ends as Newton's (quadratic) with dt grown from its CFL start
    system, unit = duct
    dp = 1.0e5
    x0 = ns3d.stokes(system, dp * unit, np.zeros(len(system.fixed)))
    x, steps, factor = ns3d.ptc(system, dp * unit, 0.1 * x0)
    factor.free()
    assert -ns3d.boundary_flux(system, x, "inlet") == pytest.approx(_duct_flow(dp), rel=0.01)
    r = ns3d.residual(system, x, dp * unit)[ns3d._free_dofs(system.ndofs, system.fixed)]
    assert np.linalg.norm(r) < 1e-8 * np.linalg.norm(dp * unit)
    assert steps <= ns3d.PTC_MAX_STEPS


def test_newton_jacobian_with_backflow_matches_finite_differences(duct):
    # a random state (inflow and outflow on the duct's open ends): the Jacobian's action, the
    # backflow stabilisation's derivative included, against finite differences of the residual
    # (first order in the step: the error falls 100x per 100x smaller step)
    system, _ = duct
    rng = np.random.default_rng(1)
    x, d = rng.normal(size=system.ndofs), rng.normal(size=system.ndofs)
    rhs = np.zeros(system.ndofs)
    Jd = ns3d._saddle(system, ns3d._velocity_block(system, x[:3 * system.nv], True)) @ d
    r0 = ns3d.residual(system, x, rhs)
    errs = [np.linalg.norm((ns3d.residual(system, x + e * d, rhs) - r0) / e - Jd) / np.linalg.norm(Jd)
            for e in (1e-3, 1e-5)]
    assert errs[1] < 1e-4 and errs[1] < 0.02 * errs[0]


def test_backflow_stabilisation_dissipates_inflow_energy(duct):
    # -beta rho int (u.n)_- |u|^2 dA >= 0 on a field entering through the outlet: the term's
    # contribution to the energy balance (u . R) is beta rho int |u.n| |u|^2 over the inflow
    system, _ = duct
    n = system.nv
    u = np.zeros(3 * n)
    u[:n] = -1.0                                     # u = -e_x: inflow through the outlet (x = L)
    blocks = ns3d._backflow(system.backflow, ns3d.BACKFLOW_BETA, RHO, [u[:n], u[n:2 * n], u[2 * n:]], False)
    energy = u[:n] @ (blocks[0][0] @ u[:n])
    assert energy == pytest.approx(ns3d.BACKFLOW_BETA * RHO * 1.0 * (2 * A) * (2 * B), rel=1e-10)


def test_mesh_peclet_of_a_uniform_flow():
    # u = U e_x on a cube of cells of edge h (longest edge of the Kuhn tetrahedra: h sqrt(3)):
    # P = U h sqrt(3) / (2 nu) on every cell
    n, U = 4, 0.5
    mesh = skfem.MeshTet.init_tensor(*[np.linspace(0, 1e-3, n + 1)] * 3)
    system = ns3d.assemble(mesh.with_boundaries({"wall": lambda x: x[0] < -1.0}), ns3d.Fluid(RHO, MU),
                           symmetry="none")
    x = np.zeros(system.ndofs)
    x[:system.nv] = U
    h = 1e-3 / n
    assert ns3d.mesh_peclet(system, x) == pytest.approx(U * h * np.sqrt(3) / (2 * MU / RHO), rel=1e-12)


def test_continuation_steps_are_limited_in_reynolds_number():
    # Re ~ dP^(1/2) from the last two points: a step to twice the last Re needs 4x its dP; a
    # target below the limit is taken whole; near Stokes (Re < STEP_FREE_RE) no limit
    def pt(dp, re):
        return reed3d.FlowPoint(opening=1e-3, dp=dp, flow=0.0, reynolds=re, cd=0.0, multiplier=0.0,
                                multiplier_pressure=0.0, force=0.0, dofs=0, newton_steps=0, seconds=0.0,
                                peak_rss_gb=0.0)
    run = reed3d._Continuation(system=None, valve=None, opening=1e-3, unit=None, history=[],
                               out=[pt(100.0, 5.0), pt(400.0, 10.0)], progress=False, ratio=2.0)
    assert reed3d._step_dp(run, 1e5) == pytest.approx(1600.0)
    assert reed3d._step_dp(run, 900.0) == 900.0
    assert reed3d._step_dp(run, 1900.0) == 1900.0        # within STEP_SLACK of the limit: taken whole
    run = reed3d._Continuation(system=None, valve=None, opening=1e-3, unit=None, history=[],
                               out=[pt(1.0, 0.01)], progress=False, ratio=2.0)
    assert reed3d._step_dp(run, 150.0) == 150.0          # Re 1.5 < STEP_FREE_RE


COARSE = MeshOptions(1.2e-3, 4e-3, Layers(port=1, gap=2, reed=1, above=1))


@pytest.fixture(scope="module")
def valve():
    return reed3d.prototype_valve(COARSE)


def _area(mesh, name: str, f) -> float:
    fb = FacetBasis(mesh, ElementTetP1(), facets=mesh.boundaries[name])
    return float(Functional(lambda w: f(w)).assemble(fb))


def test_fluid_mesh_volume_and_areas_match_the_geometry(valve):
    reed, seat = valve.reed, valve.seat
    fm = fluid_mesh(reed, seat, 0.5e-3, valve.shape, COARSE)
    m = fm.mesh
    s_end, y_end = fm.plan.extent
    h, top = reed.thickness, reed.thickness + seat.stop_gap
    a, r, L1 = seat.start(reed), reed.tip_radius - seat.land_width, reed.step_location
    port = (reed.tip_start - a) * r + np.pi * r**2 / 4                 # half port: rectangle + quarter disc
    # the prototype's pockets (half reed): both U-grooves, the outer legs sealed from the step
    # to the port's start (one land width), as fea.fluid.reed_mesh.sealed_depth does
    d, w = 0.508e-3, 1.5875e-3
    pockets = d * (w * (17.4625e-3 - a) + np.pi / 4 * (6.35e-3**2 - 4.7625e-3**2)
                   + w * 17.4625e-3 + np.pi / 4 * (3.175e-3**2 - 1.5875e-3**2))
    volume = s_end * y_end * top + port * seat.port_depth - reed.face_area / 2 * h + pockets
    x = m.p[:, m.t]
    vol = np.einsum("ij,ij->j", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0], axis=0), x[:, 3] - x[:, 0]) / 6
    assert vol.min() > 0.0
    assert vol.sum() == pytest.approx(volume, rel=5e-3)
    assert _area(m, "inlet", lambda w: 1.0 + 0 * w.x[0]) == pytest.approx(port, rel=5e-3)
    assert _area(m, "outlet", lambda w: 1.0 + 0 * w.x[0]) == pytest.approx((s_end + y_end) * top, rel=1e-9)
    # the reed's faces: upstream and downstream face each (grooves' ceilings included)
    assert _area(m, "reed", lambda w: abs(w.n[2])) == pytest.approx(reed.face_area, rel=5e-3)


def test_bad_opening_names_the_field(valve):
    from geometry.errors import InputError

    with pytest.raises(InputError, match="opening"):
        fluid_mesh(valve.reed, valve.seat, 2.5e-3, valve.shape, COARSE)


@pytest.fixture(scope="module")
def coarse_solve(valve):
    fm = fluid_mesh(valve.reed, valve.seat, 0.3e-3, valve.shape, COARSE)
    system = ns3d.assemble(fm.mesh, valve.fluid)
    x = ns3d.stokes(system, ns3d.traction_load(system, {"inlet": 1.0}), np.zeros(len(system.fixed)))
    return system, x


def test_coarse_stokes_solve_conserves_mass_and_loads_the_reed(valve, coarse_solve):
    system, x = coarse_solve
    q_in, q_out = -ns3d.boundary_flux(system, x, "inlet"), ns3d.boundary_flux(system, x, "outlet")
    assert q_in > 0.0 and q_out == pytest.approx(q_in, rel=1e-8)
    p = reed3d.point_outputs(system, x, valve, 0.3e-3, 1.0, 0, 0.0)
    # at 0.3 mm the film is thin: X near the thin film's 0.835, the viscous part small
    assert 0.78 < p.multiplier < 0.88
    assert abs(p.multiplier - p.multiplier_pressure) < 0.01


def test_moving_wall_conserves_volume(valve):
    fm = fluid_mesh(valve.reed, valve.seat, 0.3e-3, valve.shape, COARSE)
    system = ns3d.assemble(fm.mesh, valve.fluid)
    x = ns3d.stokes(system, np.zeros(system.ndofs), reed3d._reed_velocity(system, valve, 1.0))
    q_in, q_out = -ns3d.boundary_flux(system, x, "inlet"), ns3d.boundary_flux(system, x, "outlet")
    q_reed = ns3d.boundary_flux(system, x, "reed")
    assert abs(q_reed) < 1e-6 * valve.area_max
    assert q_out == pytest.approx(q_in, rel=1e-6)
    # the port supplies part of the volume the reed's upstream face sweeps: 0 < A_Q < A_2 (eq 3.29)
    s, y, w = reed3d.face_rule(valve.reed)
    assert 0.0 < 2 * q_in < float(np.sum(w * valve.psi(s)))


# ------------------------------------------------------------------------------ slow studies
@pytest.mark.slow
def test_small_opening_agrees_with_the_thin_film():
    """At 0.095 mm (gap / land = 0.06) the 3-D Stokes flow's X within 2 % of the film's (measured
    0.1 %); its leakage below the film's by the entry and exit losses the film leaves out
    (measured 7 %; docs/fluid.md), within 10 %."""
    from fea.fluid import reed_film

    valve = reed3d.prototype_valve()
    x = 0.095e-3
    p = reed3d.pressure_sweep(valve, x, ())[0]
    film = reed_film.reed_film(valve, x)
    assert p.multiplier == pytest.approx(film.multiplier, rel=0.02)
    assert 0.90 * film.flow < p.flow < film.flow


@pytest.mark.slow
def test_squeeze_coefficient_agrees_with_the_thin_film_as_its_leakage_does():
    """At 0.0475 mm (gap / land = 0.03) the 3-D squeeze coefficient of eq 3.51 against the sealing film's.
    Lubrication theory: the leakage scales as h^3 and the squeeze resistance as h^-3, so a model difference
    that acts as a slightly different effective gap moves the two by reciprocal factors; their product
    3-D/film is 1 within 3 % (measured: leakage 0.935, squeeze 1.08, product 1.01), and the 3-D squeeze
    lies above the film's by at most 15 %."""
    from fea.fluid import reed_film

    valve = reed3d.prototype_valve()
    x = 0.0475e-3
    film = reed_film.reed_film(valve, x)
    c3d = reed3d.squeeze_coefficient(valve, x)
    q3d = reed3d.pressure_sweep(valve, x, (), progress=False)[0].flow
    ratio_c, ratio_q = c3d / film.squeeze_coefficient, q3d / film.flow
    assert 1.0 < ratio_c < 1.15
    assert ratio_c * ratio_q == pytest.approx(1.0, abs=0.03)


@pytest.mark.slow
def test_continuation_passes_the_old_newton_stall_at_a_large_opening():
    """At 1.71 mm (0.9 x_stop; Newton with one geometric-mean halving stalled near Re 12 there) the
    adaptive continuation reaches Re 15 on the coarse mesh (measured: small Newton steps reach Re 19.6,
    docs/fluid.md). Against independent numbers: the
    first Navier-Stokes point (Re ~ 1) has the Stokes limit's Cd / sqrt(dP) within 3 % (inertia's
    share at Re 1), Cd grows with Re as the jet forms (eq 3.89's trend), and X stays between the
    film's plateau and 0."""
    valve = reed3d.prototype_valve(COARSE)
    pts = reed3d.pressure_sweep(valve, 1.71e-3, (1.0, 10.0, 15.0), progress=False)
    stokes, first, last = pts[0], pts[1], pts[-1]
    assert last.reynolds == pytest.approx(15.0, rel=reed3d.REYNOLDS_SLACK)
    # Stokes: Q ~ dP, so Cd / sqrt(dP) is constant; at Re 1 inertia changes it by a few per mille
    # (measured +0.24 %: the jet's pressure recovery outweighs the entry losses)
    ratio = (first.cd / np.sqrt(first.dp)) / (stokes.cd / np.sqrt(stokes.dp))
    assert ratio == pytest.approx(1.0, abs=0.03)
    cds = [p.cd for p in pts[1:]]
    assert all(b > a for a, b in zip(cds, cds[1:]))
    assert 0.0 < last.multiplier < 0.8356


@pytest.mark.slow
def test_mesh_study_converges_in_the_stokes_limit():
    """Three meshes at 0.25 mm: Cd and X converge monotonically, the last change below 0.5 %."""
    study = reed3d.mesh_study(reed3d.prototype_valve(), 0.25e-3, (1.0,))
    for key in ("cd", "multiplier"):
        g = study[1.0][key]
        assert g.converging, (key, g.note)
        assert abs(g.approx_error_pct[0]) < 0.5, (key, g.approx_error_pct)


# ------------------------------------------------------------------------------ valvelab flow --fidelity 3d
def _cli(*args, cache_dir):
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    r = subprocess.run([sys.executable, "-m", "studies", *args], capture_output=True, text=True, timeout=3600,
                       env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg",
                            "HOME": str(cache_dir), "VALVELAB_CACHE_DIR": str(cache_dir),
                            "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS", "2")})
    return r.returncode, r.stdout, r.stderr


@pytest.mark.parametrize("args, field", [
    (("--resolution", "2"), "--resolution"),
    (("--lift-mm", "2.5"), "--lift-mm"),
    (("--reynolds", "0"), "--reynolds")])
def test_flow_3d_bad_input_exits_2_before_any_solve(tmp_path, args, field):
    rc, out, err = _cli("flow", "thesis-reed:delivery", "--fidelity", "3d", *args, "--json", cache_dir=tmp_path)
    assert rc == 2 and out == "", err
    assert field in err and len(err.strip().splitlines()) == 1


def test_flow_3d_needs_a_reed_to_mesh(tmp_path):
    from dataclasses import replace

    from geometry.errors import InputError
    from lumped import load_model

    f = tmp_path / "bad.toml"
    f.write_text('[valves]\nflow.geometry = "no-such-reed.toml"\n')
    rc, out, err = _cli("flow", f"{f}:inlet", "--fidelity", "3d", "--json", cache_dir=tmp_path)
    assert rc == 2 and "valves.inlet.flow.geometry" in err
    v = replace(load_model("thesis-reed").delivery, flow_geometry=None)
    with pytest.raises(InputError, match="geometry"):
        v.fluid_reed("valves.delivery")
    # a valve that names its geometry meshes that one; the thesis reed's flow.geometry is dropped then
    from lumped.model.model_file import with_values

    g = with_values(load_model("thesis-reed"), {"valves.geometry": "stepped2", "valves.fidelity": "analytic"})
    assert g.delivery.flow_geometry is None and g.delivery.fluid_reed("valves.delivery").name == "stepped2"


@pytest.mark.slow
def test_flow_3d_end_to_end_on_the_thesis_reed(tmp_path):
    """``valvelab flow thesis-reed:delivery --fidelity 3d --lift-mm 0.285 --reynolds 1 --json``: the
    CONTRACT keys; at 0.285 mm (gap / land 0.18) X within 0.5 % of the sealing film's (measured 0.03 %);
    Cd and Re consistent with the flow and dP by their definitions (eqs 3.84, 3.87); the force
    coefficient within the X band (the flow force is small at Re 1). Measured: 211 s wall at load 13,
    29 s CPU, 2.5 GB."""
    from fea.fluid import reed_film

    rc, out, err = _cli("flow", "thesis-reed:delivery", "--fidelity", "3d", "--lift-mm", "0.285", "--reynolds", "1",
                        "--json", cache_dir=tmp_path)
    assert rc == 0, err
    d = json.loads(out)
    assert d["valve"] == "thesis-reed:delivery" and d["fidelity"] == "3d" and len(d["points"]) == 1
    p = d["points"][0]
    for key in ("lift", "reynolds", "flow", "dp", "cd", "force", "force_coefficient", "flow_force",
                "pressure_load_multiplier", "u_num"):
        assert key in p
    assert d["mesh"]["dofs"] > 100_000 and d["cpu_seconds"] > 0
    assert p["lift"] == pytest.approx(0.285e-3) and p["reynolds"] == pytest.approx(1.0, rel=reed3d.REYNOLDS_SLACK)
    rho, mu = 876.0, 0.06834497086850068                     # thesis-reed's oil
    assert p["cd"] == pytest.approx(p["flow"] / (19.4e-3 * p["lift"] * np.sqrt(2 * p["dp"] / rho)), rel=1e-9)
    assert p["reynolds"] == pytest.approx(4 * rho * p["flow"] / (91.2e-3 * mu), rel=1e-9)
    film = reed_film.reed_film(reed3d.prototype_valve(), 0.285e-3)
    assert p["pressure_load_multiplier"] == pytest.approx(film.multiplier, rel=5e-3)
    assert 0.75 < p["force_coefficient"] < 0.95
