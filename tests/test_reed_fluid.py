"""Fluid quantities of the reed model (lumped/reed/fluid.py) against the thesis and the equations they solve."""

import numpy as np
import pytest
from scipy.integrate import dblquad
from scipy.optimize import minimize_scalar

from geometry import load_reed
from lumped.reed import euler_bernoulli as rb
from lumped.reed import fluid as rf
from studies.tables.thesis import thesis_values

TV = thesis_values()
T13 = TV["table_3_13"]


def rel(a, b):
    return abs(a - b) / abs(b)


# -- added mass ---------------------------------------------------------------------------


def test_hydrodynamic_function_at_thesis_mode_number():
    assert rf.hydrodynamic_function(T13["kappa_n"]) == pytest.approx(T13["Gamma_f"], abs=5e-5)


def test_hydrodynamic_function_limits_and_monotone():
    assert rf.hydrodynamic_function(0.0) == 1.0  # infinitely long beam (W / L -> 0)
    k = np.linspace(0, 50, 501)
    g = rf.hydrodynamic_function(k)
    assert np.all(np.diff(g) < 0) and g[-1] < 0.06  # short beams: Gamma_f -> 0


def test_normalised_mode_number_of_prototype():
    """eq 3.14 with Table 3.11's alpha = 1.845 and the face area gives the printed 0.9677."""
    p = load_reed("prototype")
    kn = rf.normalised_mode_number_area(TV["table_3_11"]["prototype"]["alpha_fea"], p.face_area, p.length)
    assert kn == pytest.approx(T13["kappa_n"], abs=1e-4)
    # eq 3.14 reduces to eq 3.12 for a rectangle
    assert rf.normalised_mode_number_area(1.9, 0.02 * 0.1, 0.1) == pytest.approx(
        rf.normalised_mode_number(1.9, 0.02, 0.1))


def test_added_mass_consistent_with_frequency_in_fluid():
    """eqs 3.11, 3.16, 3.17: (omega_vac / omega_f)^2 - 1 = m_f / m_c with m_c = rho_c W h."""
    rho, W, rho_c, h, gf = 876.0, 15.875e-3, 1410.0, 1.35e-3, 0.885
    wf = rf.frequency_in_fluid(1000.0, rho, W, rho_c, h, gf)
    mf = rf.added_mass_per_length(rho, W, gf)
    assert (1000.0 / wf) ** 2 - 1 == pytest.approx(mf / (rho_c * W * h), rel=1e-12)
    assert rf.added_mass_coefficient(1.0, rho, W, gf) == pytest.approx(mf / W, rel=1e-12)


def test_air_mass_ratio_near_thesis():
    """eq 3.76 ~ 0.0062; the thesis does not give the air density, 1.204 kg/m^3 is assumed (2.5 %)."""
    p = load_reed("prototype")
    r = rf.added_to_reed_mass_ratio(TV["table_3_8"]["stepped2/load"]["gamma3"], rf.fluid_data()["air"]["density"],
                                    p.width_tip, T13["Gamma_f"], p.material.density, p.thickness)
    assert rel(r, T13["air_mass_ratio"]) < 0.03


# -- damping -------------------------------------------------------------------------------


def test_oil_viscosity_at_room_temperature():
    rho, mu = rf.oil_properties()
    assert rho == 876.0
    assert mu == pytest.approx(TV["oil"]["mu_22C"], rel=1e-3)
    _, mu40 = rf.oil_properties(313.15)
    assert mu40 == pytest.approx(876.0 * 44.2e-6, rel=1e-12)  # Table A.1 point


def test_kinetic_reynolds_2250():
    p = load_reed("prototype")
    Rk = rf.kinetic_reynolds(876.0, TV["table_3_10"]["omega_n_mean"], p.width_tip, TV["oil"]["mu_22C"])
    assert rel(Rk, T13["R_k"]) < 1e-3


def test_fluid_damping_1650_and_combined_1727():
    s2 = load_reed("stepped2")
    bm = rb.BeamModel.of(s2)
    psi = rb.three_section_shape(s2, bm.quad.s)
    _, mu = rf.oil_properties()
    assert rel(rf.damping_per_length(mu), T13["R_f"]) < 1e-3
    c_f = rf.fluid_damping(bm.quad.s, psi, bm.W, mu, weights=bm.quad.weights)
    assert rel(c_f, T13["c_f"]) < 0.01
    from lumped.model.model_file import load_model
    c_c = load_model("thesis-reed").inlet.internal_damping
    assert rel(c_c + c_f, T13["c"]) < 0.01
    # with Simpson's rule on a dense uniform grid: the same to 1e-4
    s = np.linspace(0, s2.length, 2001)
    c_s = rf.fluid_damping(s, rb.three_section_shape(s2, s), s2.width(s), mu)
    assert rel(c_s, c_f) < 1e-3


def test_fluid_damping_takes_the_nondimensional_damping_as_input():
    s = np.linspace(0, 1, 101)
    psi, W = s**2, np.ones_like(s)
    assert rf.fluid_damping(s, psi, W, 0.1, cv_over_mu=1000.0) == pytest.approx(
        2 * rf.fluid_damping(s, psi, W, 0.1, cv_over_mu=500.0))
    assert rf.fluid_damping(s, psi, W, 0.1) == pytest.approx(rf.fluid_damping(s, psi, W, 0.1, cv_over_mu=500.0))
    with pytest.raises(ValueError):
        rf.damping_per_length(0.1, -1.0)


def test_fluid_displacement_area_eq_3_29_vs_printed_face_area():
    """Table 3.13's A2 = 338.4 mm^2 is the face area; eq 3.29 gives 145.5 mm^2."""
    s2 = load_reed("stepped2")
    bm = rb.BeamModel.of(s2)
    A2 = rf.fluid_displacement_area(bm.quad.s, rb.three_section_shape(s2, bm.quad.s), bm.W, bm.quad.weights)
    assert A2 == pytest.approx(145.5e-6, rel=1e-3)
    assert s2.face_area == pytest.approx(T13["A2"], rel=2e-4)


# -- Poiseuille regime ---------------------------------------------------------------------


def test_plate_pressure_solves_reynolds_equation():
    W, dp, mu, u, x = 1.5875e-3, 1e5, 0.0683, 0.01, 50e-6
    y = np.linspace(0, W, 2001)
    P = rf.plate_pressure(y, W, dp, mu, u, x)
    assert P[0] == pytest.approx(dp) and abs(P[-1]) < 1e-9
    d2 = np.gradient(np.gradient(P, y), y)
    assert np.allclose(d2[5:-5], 12 * mu * u / x**3, rtol=1e-6)  # eq 3.50
    mean = np.trapezoid(rf.plate_pressure(y, W, dp), y) / W  # eq 3.53
    assert mean / dp == pytest.approx(rf.side_pressure_fraction(), rel=1e-9)


def test_annulus_pressure_eq_3_55_corrected_solves_eq_3_54():
    Ri, Ro, dp, mu, u, x = 6.35e-3, 7.9375e-3, 1e5, 0.0683, 0.01, 50e-6
    r = np.linspace(Ri, Ro, 4001)
    P = rf.annulus_pressure(r, Ri, Ro, dp, mu, u, x)
    assert P[0] == pytest.approx(dp, rel=1e-12) and abs(P[-1]) < 1e-6
    lhs = np.gradient(r * x**3 * np.gradient(P, r), r)
    assert np.allclose(lhs[5:-5], 12 * mu * r[5:-5] * u, rtol=1e-5)
    # the printed form (R_i, R_o not squared) misses the boundary condition P(R_i) = P_up
    k = 3 * mu * u / x**3
    printed_Ri = (dp * np.log(Ro / Ri) - k * (Ri**2 * np.log(Ri / Ro) + Ri * np.log(Ro / Ri))) / np.log(Ro / Ri)
    assert abs(printed_Ri - dp) / dp > 0.1


def test_annulus_fraction_eq_3_59_is_mean_of_eq_3_56():
    Ri, Ro = 6.35e-3, 7.9375e-3
    F3 = rf.annulus_pressure_fraction(Ri, Ro)
    assert F3 == pytest.approx(TV["table_3_12"]["F3"], abs=5e-4)
    val, _ = dblquad(lambda r, th: rf.annulus_pressure(r, Ri, Ro, 1.0) * r, 0, np.pi, Ri, Ro)
    assert val / (np.pi * (Ro**2 - Ri**2) / 2) == pytest.approx(F3, rel=1e-9)


def _table_3_12_X(base_length, F4, shape="three_section"):
    s2 = load_reed("stepped2")
    lay = rf.SealingLayout(land_width=rf.fluid_data()["sealing"]["land_width"], base_length=base_length)
    return rf.poiseuille_multiplier(s2, lambda s: rb.shape(s2, shape, s)[1], F4, lay)


def test_table_3_12_within_0_002():
    lay = rf.SealingLayout.thesis()
    for F4, X_t in zip(TV["table_3_12"]["F4"], TV["table_3_12"]["X"]):
        assert abs(_table_3_12_X(lay.base_length, F4) - X_t) < 0.002
        assert abs(_table_3_12_X(lay.base_length, F4, "load") - X_t) < 0.002  # exact shape too


def test_base_length_reproduces_table_3_12():
    """The stored section-4 length is the least-squares fit of eq 3.60 to the printed X(F4)."""
    F4s, Xs = TV["table_3_12"]["F4"], TV["table_3_12"]["X"]

    def sq(b):
        return sum((_table_3_12_X(b, f) - x) ** 2 for f, x in zip(F4s, Xs))

    fit = minimize_scalar(sq, bounds=(3e-3, 9e-3), method="bounded", options={"xatol": 1e-7}).x
    assert abs(fit - rf.SealingLayout.thesis().base_length) < 0.1e-3
    assert np.sqrt(sq(fit) / 3) < 5e-4  # one length fits all three printed values to their rounding


def test_poiseuille_multiplier_linear_in_F4_and_uniform_limit():
    s2 = load_reed("stepped2")
    psi = lambda s: rb.shape(s2, "load", s)[1]  # noqa: E731
    X = [rf.poiseuille_multiplier(s2, psi, f) for f in (0.0, 0.25, 1.0)]
    assert X[1] == pytest.approx(0.75 * X[0] + 0.25 * X[2], rel=1e-12)
    # no land and no base: the pressure is uniform and X = 1 (definition of X, Table 3.4)
    lay = rf.SealingLayout(land_width=0.0, base_length=0.0)
    assert rf.poiseuille_multiplier(s2, psi, 0.3, lay) == pytest.approx(1.0, rel=1e-12)


# -- orifice regime -----------------------------------------------------------------------


def test_orifice_multiplier_eq_3_83_capped_at_first_zero():
    fit = rf.PressureMultiplierFit.thesis()
    assert fit.closing_opening == pytest.approx(0.07158 / 52.28, rel=1e-12)  # 1.369 mm
    assert rf.orifice_multiplier(0.0) == pytest.approx(0.835)  # Poiseuille plateau
    assert rf.orifice_multiplier(1e-3) == pytest.approx(
        (-52.28e-3 + 0.07158) / (1e-9 + 0.8145e-6 - 50.23e-3 + 0.08292), rel=1e-12)
    # the printed formula climbs back to 0.835 past its pole at 1.651 mm; the capped one stays 0
    for x in (1.4e-3, 1.7e-3, 1.9e-3, 2.5e-3):
        assert np.clip(fit.rational(x), 0, 0.835) > 0 or x < 1.65e-3
        assert rf.orifice_multiplier(x) == 0.0
    x = np.linspace(-0.5e-3, 2.5e-3, 3001)
    X = rf.orifice_multiplier(x)
    assert np.all(np.diff(X) <= 1e-15) and np.all((X >= 0) & (X <= 0.835))
    assert rf.orifice_multiplier(fit.closing_opening * (1 - 1e-9)) < 1e-6  # continuous at the cap


def test_orifice_reynolds_eq_3_87_coefficient():
    """Re = 4 rho Q / (p_o mu): 5.625e5 s/m^3 for the prototype, the reciprocal of the printed 1.778e-6."""
    coef = rf.orifice_reynolds(1.0, 876.0, 91.2e-3, 0.0683)
    assert coef == pytest.approx(5.625e5, rel=1e-3)
    assert 1 / coef == pytest.approx(1.778e-6, rel=1e-3)
