"""The modal reed (lumped.reed.modal_basis) and the whole FE reed, structural side.

Checked against independent numbers: the clamped-free beam's closed forms (beta_n L of
Blevins 1979, its modal integrals and the static tip deflection W L^4 / 8 EI), eq 3.21 and
Table 3.4 integrated over the first mode shape found by another code path, the FE reed's own
static solution and exact dynamics (the matrix exponential, solve_ivp), and the edge
integral of the opening written out by hand. Plate and solid cases are marked slow.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.linalg import expm

from geometry import InputError, load_reed
from geometry.reed_port import (ReedPort, check_port, edge_rule, face_rule, footprint_area, footprint_mask,
                                parse_port, read_port, station_rule)
from lumped.reed import modal_basis as rm
from lumped.reed.quadrature import ProfileQuadrature, profile_breaks

#: beta_n L of the clamped-free uniform beam, cos x cosh x = -1 (Blevins 1979, Table 8-1)
BETA_L = (1.875104069, 4.694091133, 7.854757438, 10.99554073, 14.13716839, 17.27875953)
PROTO = load_reed("prototype")
UNIFORM = load_reed("uniform")
#: a port off the reed's axis: 5 mm wide, centred 3.5 mm off it, from 8 to 20 mm
OFF_AXIS = ReedPort(s_start=8.0e-3, s_end=20.0e-3, width=5.0e-3, y_center=3.5e-3)


def closed_form_omega(reed):
    A, I = reed.section(0.5 * reed.length)
    m = reed.material
    return np.array(BETA_L) ** 2 * np.sqrt(m.youngs_modulus * I / (m.density * A * reed.length**4))


# ------------------------------------------------------------------------------ the port
def test_port_reads_and_checks_naming_the_key():
    where = "valves.delivery.port"
    p = read_port({"s_start": 0.008, "s_end": 0.02, "width": 0.005, "y_center": 0.0035}, where, PROTO)
    assert p == OFF_AXIS
    assert parse_port(None, where) is None and check_port(None, PROTO) is None
    bad = [({"s_start": 0.008, "s_end": 0.026, "width": 0.005}, "s_end"),                 # past the tip
           ({"s_start": 0.008, "s_end": 0.02, "width": 0.005, "y_center": 0.006}, "y_center"),  # off the side
           ({"s_start": 0.001, "s_end": 0.02, "width": 0.01}, "width"),                      # wider than the root
           ({"s_start": 0.01, "s_end": 0.005, "width": 0.001}, "s_end"),
           ({"s_start": -0.001, "s_end": 0.005, "width": 0.001}, "s_start"),
           ({"s_start": 0.01, "s_end": 0.02}, "width"),
           ({"s_start": 0.01, "s_end": 0.02, "width": 0.001, "widht": 1}, "widht")]
    for table, key in bad:
        with pytest.raises(InputError) as e:
            read_port(table, where, PROTO)
        assert e.value.field == f"{where}.{key}", (table, e.value)
    # on the rounded tip the outline narrows: a port reaching into it must fit there too
    with pytest.raises(InputError, match="must lie on the reed's face"):
        check_port(ReedPort(0.018, 0.025, 0.01), PROTO, where)


def test_footprint_rules_integrate_areas_and_lengths():
    # the whole face: the exact face area (rounded tip: W ~ sqrt(L - s), mapped rule)
    for reed in (UNIFORM, load_reed("stepped2"), PROTO):
        S, Y, w = face_rule(reed)
        assert w.sum() == pytest.approx(reed.face_area, rel=1e-8)
        s, ws, W = station_rule(reed)
        assert ws.sum() == pytest.approx(reed.length, rel=1e-12)
        assert ws @ W == pytest.approx(reed.face_area, rel=1e-6)
        assert np.all(footprint_mask(reed, None, S, Y))
    S, Y, w = face_rule(PROTO, OFF_AXIS)
    assert w.sum() == pytest.approx(OFF_AXIS.area, rel=1e-12) == footprint_area(PROTO, OFF_AXIS)
    assert np.all(OFF_AXIS.contains(S, Y))
    # int_F s dA of the rectangle
    assert w @ S == pytest.approx(OFF_AXIS.width * (0.02**2 - 0.008**2) / 2, rel=1e-12)
    es, ey, ew = edge_rule(PROTO, OFF_AXIS)
    assert ew.sum() == pytest.approx(OFF_AXIS.perimeter, rel=1e-12)
    assert ew @ ey == pytest.approx(OFF_AXIS.perimeter * OFF_AXIS.y_center, rel=1e-12)   # its centroid
    assert not footprint_mask(PROTO, OFF_AXIS, 0.01, -0.003)


# ------------------------------------------------------------------------------ bad input
def test_bad_modes_port_and_fidelity_name_the_key():
    field = "valves.delivery.modes"
    for n in (0, 7, 2.5, True, "3"):
        with pytest.raises(InputError) as e:
            rm.modal_basis(PROTO, "analytic", n, field=field)
        assert e.value.field == field
    with pytest.raises(InputError) as e:
        rm.modal_basis(PROTO, "beam", 2, port=ReedPort(0.008, 0.03, 0.005), port_field="valves.delivery.port")
    assert e.value.field == "valves.delivery.port.s_end"
    with pytest.raises(InputError) as e:
        rm.modal_basis(PROTO, "fem", 2, fidelity_field="valves.delivery.fidelity")
    assert e.value.field == "valves.delivery.fidelity"
    with pytest.raises(InputError) as e:
        rm.fe_reed(PROTO, fidelity="solid", fidelity_field="valves.delivery.fidelity")
    assert e.value.field == "valves.delivery.fidelity" and "beam" in e.value.message


def test_more_modes_than_the_eigen_solve_gave_names_modes():
    def two_modes(reed, port=None, mesh_size=None, n_modes=6):
        return rm.analytic_basis(reed, port, mesh_size, n_modes=2)

    rm.register("two-modes", two_modes)
    try:
        assert rm.modal_basis(UNIFORM, "two-modes", 2).n_modes == 2
        with pytest.raises(InputError) as e:
            rm.modal_basis(UNIFORM, "two-modes", 3, field="valves.inlet.modes")
        assert e.value.field == "valves.inlet.modes" and "gave 2" in e.value.message
    finally:
        rm.FIDELITIES.pop("two-modes")


# ------------------------------------------------------------------------------ frequencies
def test_exact_eb_frequencies_of_a_uniform_cantilever_against_the_closed_form():
    b = rm.modal_basis(UNIFORM, "analytic", 6)
    assert b.kinds == tuple(f"bending {k}" for k in range(1, 7))
    np.testing.assert_allclose(b.omega, closed_form_omega(UNIFORM), rtol=5e-9)
    scale = closed_form_omega(UNIFORM)[0] / BETA_L[0] ** 2
    assert tuple(np.round(np.sqrt(b.omega / scale), 4)) == (1.8751, 4.6941, 7.8548, 10.9955, 14.1372, 17.2788)


def test_beam_fe_frequencies_converge_to_the_closed_form_at_fourth_order():
    from fea import beam

    exact = closed_form_omega(UNIFORM)
    err = {k: beam.modal_basis(UNIFORM, mesh_size=UNIFORM.length / k).omega / exact - 1 for k in (8, 16, 32)}
    assert all(np.all(e > 0) for e in err.values())                       # conforming: from above
    order = np.log2(err[16] / err[32])
    assert np.all((order > 3.8) & (order < 4.2)), order
    assert np.all(np.abs(rm.modal_basis(UNIFORM, "beam", 6).omega / exact - 1) < 1e-7)   # default L/200


def test_uniform_cantilever_modal_quantities_against_closed_forms():
    # phi = cosh bx - cos bx - sigma (sinh bx - sin bx): int phi = 2 sigma / b, int phi^2 = L
    L, W, h = UNIFORM.length, UNIFORM.width_tip, UNIFORM.thickness
    x = np.array(BETA_L)
    sigma = (np.sinh(x) - np.sin(x)) / (np.cosh(x) + np.cos(x))
    tip = np.cosh(x) - np.cos(x) - sigma * (np.sinh(x) - np.sin(x))    # +-2, the largest |phi|
    rho_a = UNIFORM.material.density * W * h
    E, I = UNIFORM.material.youngs_modulus, W * h**3 / 12
    for fid, rtol in (("analytic", 1e-8), ("beam", 1e-6)):      # beam: its L/200 mesh
        b = rm.modal_basis(UNIFORM, fid, 6)
        np.testing.assert_allclose(b.tip, 1.0, rtol=1e-12)
        np.testing.assert_allclose(b.modal_mass, rho_a * L / tip**2, rtol=rtol)
        np.testing.assert_allclose(b.load, W * 2 * sigma / (x / L) / tip, rtol=rtol)
        # one mode: 32 sigma_1 / (b1 L)^5 = 1.0134 times the static tip W L^4 / (8 E I); six modes converge
        exact = W * L**4 / (8 * E * I)
        assert b.static_deflection(1.0, 1)[0] / exact == pytest.approx(32 * sigma[0] / x[0] ** 5, rel=1e-7)
        errors = [abs(b.static_deflection(1.0, n)[0] / exact - 1) for n in range(1, 7)]
        assert errors[0] > 1e-2 and errors[-1] < 1e-5 and errors[2] < 2e-4


# ------------------------------------------------------------------------------ eq 3.21
def _first_mode_integrals(reed, fidelity):
    """Table 3.4's integrals over the first mode shape psi (psi(L) = 1) found by another code path."""
    from fea import beam
    from lumped.reed import euler_bernoulli as reed_beam

    if fidelity == "analytic":   # power iteration on the flexibility operator, not the dense eig
        _, s, psi = reed_beam.free_vibration(reed, s_out=reed_beam.plot_grid(reed, 2001))
    else:
        r = beam.solve(reed, n_modes=1)
        s, psi = r.s, r.psi_mode
    keep = np.append(np.diff(s) > 1e-9 * reed.length, True)
    sp = CubicSpline(s[keep], psi[keep])
    q = ProfileQuadrature(profile_breaks(reed), 48)
    p, W = sp(q.s), reed.width(q.s)
    A, I = reed.section(q.s)
    return {"psi2W": q.integral(p**2 * W), "psiW": q.integral(p * W), "psi2A": q.integral(p**2 * A),
            "psi2W2": q.integral(p**2 * W**2),
            "bending_energy": q.integral(reed.material.youngs_modulus * I * sp(q.s, 2) ** 2)}


@pytest.mark.parametrize("fidelity", ["analytic", "beam"])
@pytest.mark.parametrize("name", ["stepped2", "prototype"])
def test_one_mode_is_eq_3_21(fidelity, name):
    """m_1 = rho_c h_eff int psi^2 W, Gamma_1 = gamma1 int psi^2 W, k_1 = gamma1 kappa int psi^2 W, added
    mass gamma3 rho W2 pi/4 int psi^2 W, with Table 3.4 and eq 3.20 over the first mode shape."""
    reed = load_reed(name)
    b = rm.modal_basis(reed, fidelity, 1)
    t = b.tip[0]                                        # tip normalisation psi(L) = 1
    m, gamma, k = b.modal_mass[0] / t**2, b.load[0] / t, b.modal_stiffness[0] / t**2
    ig = _first_mode_integrals(reed, fidelity)
    rho_c, W2 = reed.material.density, reed.width_tip
    gamma1 = ig["psiW"] / ig["psi2W"]
    gamma3 = ig["psi2W2"] / (W2 * ig["psi2W"])
    h_eff = ig["psi2A"] / ig["psi2W"]                   # eq 3.20 (grooves: h W -> A)
    kappa = ig["bending_energy"] / ig["psiW"]           # Table 3.4, integrated by parts
    # beam: its Gauss rule of m(s) against the exact profile quadrature (half-ring grooves)
    assert m == pytest.approx(rho_c * h_eff * ig["psi2W"], rel=2e-5)
    assert gamma == pytest.approx(gamma1 * ig["psi2W"], rel=1e-7)
    assert k == pytest.approx(gamma1 * kappa * ig["psi2W"], rel=3e-4)   # psi'' of a spline: ~1e-4
    assert b.added_mass(870.0, 1.0, 0.0)[0, 0] / t**2 == pytest.approx(
        gamma3 * 870.0 * W2 * np.pi / 4 * ig["psi2W"], rel=2e-5)
    assert np.all(b.theta == 0.0) and b.opening[0] == b.tip[0]
    # today's one-mode valve takes gamma1, kappa from the static shape: about 1 % apart (documented)
    from lumped.reed.fidelities import reed_properties

    p = reed_properties(reed, fidelity)
    assert 0.004 < gamma1 / p.gamma1 - 1 < 0.009
    assert 0.010 < b.static_deflection(1.0)[0] * p.kappa - 1 < 0.014


# ------------------------------------------------------------------------------ the FE reed
def test_fe_reed_modes_equal_the_beam_basis_on_the_same_mesh():
    fe = rm.fe_reed(PROTO, OFF_AXIS)
    assert fe.n_dof <= 60 and fe.fidelity == "beam"
    b = rm.modal_basis(PROTO, "beam", 6, port=OFF_AXIS, mesh_size=fe.mesh_size)
    omega, P = fe.modes()
    np.testing.assert_allclose(omega[:6], b.omega, rtol=1e-9)
    np.testing.assert_allclose(np.diag(P[:, :6].T @ fe.mass @ P[:, :6]), 1.0, rtol=1e-10)
    # normalisation-free: Gamma^2 / m, Gamma c / k and Gamma tip / k per mode
    f, c, tip = P[:, :6].T @ fe.load, P[:, :6].T @ fe.opening, P[:, :6].T @ fe.tip
    k = omega[:6] ** 2
    np.testing.assert_allclose(f**2, b.load**2 / b.modal_mass, rtol=1e-8)
    np.testing.assert_allclose(f * c / k, b.load * b.opening / b.modal_stiffness, rtol=1e-7, atol=1e-20)
    np.testing.assert_allclose(f * tip / k, b.load * b.tip / b.modal_stiffness, rtol=1e-7, atol=1e-20)
    # the FE reed's static deflection against exact E-B (spectral, another model): 56 DOFs
    from lumped.reed.euler_bernoulli import exact_stiffness

    whole = rm.fe_reed(PROTO)
    assert whole.static_deflection(1.0)[0] * exact_stiffness(PROTO) == pytest.approx(1.0, abs=1e-5)


def test_opening_is_the_mean_lift_over_the_port_outline_scaled_to_the_tip():
    """c_i = <phi_i>_edge / <phi_1>_edge phi_1(L) with the edge integral written out for a beam:
    two sides along s and two across (w constant across)."""
    from lumped.reed import euler_bernoulli as reed_beam

    b = rm.modal_basis(PROTO, "analytic", 4, port=OFF_AXIS)
    modes = reed_beam.modes(PROTO, 4)
    a, e, width = OFF_AXIS.s_start, OFF_AXIS.s_end, OFF_AXIS.width
    edge = []
    for j in range(4):
        sp = CubicSpline(modes.s, modes.shapes[:, j])
        edge.append(2 * sp.integrate(a, e) + width * (sp(a) + sp(e)))
    edge = np.array(edge) * np.sign(modes.shapes[-1])          # the basis's sign: positive at the tip
    c = edge / edge[0] * b.tip[0]
    np.testing.assert_allclose(b.opening, c, rtol=1e-5)
    assert b.opening[0] == pytest.approx(b.tip[0], rel=1e-14)


@pytest.mark.parametrize("case", ["whole face", "off-axis port", "twice as long, half as thick"])
def test_static_modal_deflection_converges_to_the_fe_reed(case):
    reed, port = {"whole face": (PROTO, None), "off-axis port": (PROTO, OFF_AXIS),
                  "twice as long, half as thick": (PROTO.scaled(2, 0.5), None)}[case]
    fe = rm.fe_reed(reed, port)
    b = rm.modal_basis(reed, "beam", 6, port=port, mesh_size=fe.mesh_size)
    rows = rm.static_convergence(b, fe)["rows"]
    tip = [abs(r["tip_error"]) for r in rows]
    x = [abs(r["opening_error"]) for r in rows]
    assert tip[0] > 5e-3 and x[0] > 5e-3                 # one mode misses ~1 % (2 % at the port)
    assert max(tip[2:]) < 5e-4 and max(x[2:]) < 5e-4    # three modes: within 0.05 %
    assert tip[-1] < 1e-4 and x[-1] < 1e-4
    if port is not None:
        # a beam cannot twist: the off-axis port loads it as the same port on the axis does
        centred = rm.fe_reed(reed, ReedPort(port.s_start, port.s_end, port.width))
        assert centred.static_deflection(1.0) == pytest.approx(fe.static_deflection(1.0), rel=1e-12)


def test_free_release_n_modes_against_the_fe_reed():
    """Released from the static deflection: N modes vs the FE reed over 20 periods of mode 1."""
    fe = rm.fe_reed(PROTO)
    b = rm.modal_basis(PROTO, "beam", 6, mesh_size=fe.mesh_size)
    res = rm.release_errors(b, fe, periods=20)
    err = [r["tip_error"] for r in res["rows"]]
    assert err[0] > 1e-2 and err[1] > 1e-3                # one and two modes miss 0.1 %
    assert all(e < 1e-3 for e in err[2:])                 # three modes and more are within it
    assert all(r["tip_error"] <= r["bound"] * (1 + 1e-9) for r in res["rows"])
    # the FE reed's superposition against the matrix exponential of its first-order form
    n = fe.n_dof
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(fe.mass, fe.stiffness), np.zeros((n, n))]])
    u0 = fe.static_displacement(1.0)
    T = 2 * np.pi / b.omega[0]
    for t in (0.37 * T, T):
        y = expm(A * t) @ np.concatenate([u0, 0 * u0])
        assert fe.tip @ y[:n] == pytest.approx(fe.tip @ fe.free_response(u0, [t])[0], abs=1e-8 * (fe.tip @ u0))
    # the modal model's closed form against solve_ivp (three modes, 20 periods)
    q0 = b.static_coordinates(1.0, 3)
    om = b.omega[:3]
    sol = solve_ivp(lambda t, y: np.concatenate([y[3:], -om**2 * y[:3]]), (0, 20 * T),
                    np.concatenate([q0, 0 * q0]), method="DOP853", rtol=1e-12, atol=1e-12 * abs(q0).max(),
                    dense_output=True)
    ts = np.linspace(0, 20 * T, 3001)
    np.testing.assert_allclose(sol.sol(ts)[:3].T @ b.tip[:3], b.free_response(q0, ts) @ b.tip[:3],
                               atol=1e-8 * abs(q0 @ b.tip[:3]))


# ------------------------------------------------------------------------------ the basis object
def test_basis_is_cached_truncated_and_read_only():
    b6 = rm.modal_basis(PROTO, "analytic", 6)
    assert rm.modal_basis(PROTO, "analytic", 6) is b6
    b2 = rm.modal_basis(PROTO, "analytic", 2)
    assert b2.n_modes == 2 and b2.wbar.shape == (2, len(b6.stations))
    np.testing.assert_array_equal(b2.omega, b6.omega[:2])
    with pytest.raises(ValueError):
        b6.omega[0] = 1.0
    # the width-mean deflection of a beam is its deflection (exact E-B shapes, max |w| = 1 at the tip)
    from lumped.reed import euler_bernoulli as reed_beam

    modes = reed_beam.modes(PROTO, 6)
    keep = np.append(np.diff(modes.s) > 1e-9, True)
    for i in range(6):
        w = CubicSpline(modes.s[keep], modes.shapes[keep, i])(b6.stations)
        np.testing.assert_allclose(b6.wbar[i], w * np.sign(modes.shapes[-1, i]), atol=1e-6)
    assert b6.stations.min() > 0 and b6.stations.max() < PROTO.length
    assert (b6.weights * b6.widths).sum() == pytest.approx(PROTO.face_area, rel=1e-6)


# ------------------------------------------------------------------------------ plate and solid
@pytest.mark.slow
def test_plate_fe_reed_and_basis_agree_and_an_off_axis_port_loads_torsion():
    fe = rm.fe_reed(PROTO, OFF_AXIS, "plate")
    b = rm.modal_basis(PROTO, "plate", 6, port=OFF_AXIS, mesh_size=fe.mesh_size)
    omega, _ = fe.modes()
    np.testing.assert_allclose(omega[:6], b.omega, rtol=1e-8)
    assert b.kinds[:2] == ("bending 1", "torsion 1")
    rows = rm.static_convergence(b, fe)["rows"]
    x = [abs(r["opening_error"]) for r in rows]
    assert x[0] > 0.05                  # one mode misses the twist: 8 % of the opening
    assert x[1] < 0.02 < x[0]           # torsion 1 takes most of it
    assert x[-1] < 1e-3
    assert abs(b.theta[1]).max() > 100 * abs(b.theta[0]).max()
    # on the whole face of a symmetric reed torsion is not loaded, and does not open the tip
    whole = rm.modal_basis(PROTO, "plate", 6)
    assert abs(whole.load[1]) < 1e-5 * whole.load[0] and abs(whole.tip[1]) < 1e-4


@pytest.mark.slow
def test_plate_free_release_needs_the_modes_past_torsion():
    fe = rm.fe_reed(PROTO, None, "plate")
    b = rm.modal_basis(PROTO, "plate", 6, mesh_size=fe.mesh_size)
    err = [r["tip_error"] for r in rm.release_errors(b, fe, periods=20)["rows"]]
    assert err[1] == pytest.approx(err[0], rel=1e-3)    # torsion 1 adds nothing on the axis
    assert err[3] > 1e-3 > err[4]                        # bending 3 (mode 5) brings it within 0.1 %


@pytest.mark.slow
def test_solid_basis_out_of_plane_modes_and_static_tip():
    from fea import solid
    from lumped.reed.fidelities import reed_properties

    b = rm.modal_basis(PROTO, "solid", 6)
    r = solid.modes(PROTO, 6)
    out_of_plane = [w for w, kind in zip(r.omega, r.kinds) if kind != "in-plane"][:6]
    np.testing.assert_allclose(b.omega, out_of_plane, rtol=1e-8)
    assert "in-plane" not in " ".join(b.kinds)
    # six modes against the solid's own static uniform-pressure tip (mid-plane vs face: < 0.5 %)
    kappa = reed_properties(PROTO, "solid").kappa
    assert b.static_deflection(1.0)[0] * kappa == pytest.approx(1.0, abs=5e-3)
    off = rm.modal_basis(PROTO, "solid", 2, port=OFF_AXIS)
    assert off.kinds == ("bending 1", "torsion 1") and abs(off.load[1]) > 0.5 * abs(off.load[0])
