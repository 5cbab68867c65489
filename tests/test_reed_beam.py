"""Euler-Bernoulli reed models (lumped/reed/euler_bernoulli.py) against the thesis, closed forms and independent solvers."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from geometry import load_reed, parse_reed
from lumped.reed import euler_bernoulli as rb
from lumped.reed.mode_function import effective_thickness, gamma1_alternative
from lumped.reed.quadrature import NODES_PER_PIECE, profile_breaks
from studies.tables.thesis import thesis_values

TV = thesis_values()


def rel(a, b):
    return abs(a - b) / abs(b)


def make_reed(L=30e-3, h=0.8e-3, W1=10e-3, W2=20e-3, Rl=0.3, R=0.0, E=200e9, rho=7850.0, grooves=()):
    """A reed of any shape through the user-file parser (default: the brief's steel reed)."""
    d = {"reed": {"length": L, "thickness": h, "width_root": W1, "width_tip": W2, "step_fraction": Rl,
                  "tip_radius": R, "material": {"youngs_modulus": E, "density": rho, "poisson_ratio": 0.3},
                  "grooves": list(grooves)}}
    return parse_reed(d)


# -- independent references (not the code under test) -----------------------------------


def quad_stiffness(reed):
    """kappa by the unit-load method with adaptive quadrature: x = int (L - xi) M(xi) / EI(xi) dxi."""
    L, E = reed.length, reed.material.youngs_modulus
    pts = sorted(set(np.round(profile_breaks(reed), 15)))

    def M(xi):  # moment of the uniform pressure outboard of xi, per unit pressure
        inner = [p for p in pts if xi < p < L]
        return quad(lambda e: (e - xi) * reed.width(e), xi, L, points=inner or None,
                    epsabs=0, epsrel=1e-12, limit=200)[0]

    x = quad(lambda xi: (L - xi) * M(xi) / (E * float(reed.section(xi)[1])), 0, L,
             points=pts[1:-1] or None, epsabs=0, epsrel=1e-11, limit=200)[0]
    return 1.0 / x


def staircase_omega(reed, N, guess):
    """omega_n of the profile cut into N graded uniform pieces (midpoint sections), exact transfer matrices."""
    br = np.unique(profile_breaks(reed))
    segs = []
    for a, b in zip(br[:-1], br[1:]):
        n = max(int(N * (b - a) / reed.length), 4)
        x = a + (b - a) * (1 - np.cos(np.linspace(0, np.pi, n + 1))) / 2
        A, I = reed.section((x[1:] + x[:-1]) / 2)
        segs += [rb.Segment(l, reed.material.youngs_modulus * i, reed.material.density * aa)
                 for l, aa, i in zip(np.diff(x), A, I)]
    return brentq(lambda w: rb.cantilever_characteristic(w, segs), 0.95 * guess, 1.05 * guess, xtol=1e-12)


def richardson_omega(reed):
    guess = rb.natural_frequency(reed)
    o1, o2 = staircase_omega(reed, 400, guess), staircase_omega(reed, 800, guess)
    return o2 + (o2 - o1) / 3  # midpoint staircase converges as N^-2


# -- uniform and stepped closed forms -----------------------------------------------------


def test_uniform_frequency_parameter_roots_of_eq_3_2():
    a1, a2 = rb.uniform_frequency_parameter(1), rb.uniform_frequency_parameter(2)
    assert a1 == pytest.approx(1.8751040687, abs=1e-9)  # classical value
    assert a2 == pytest.approx(4.6940911330, abs=1e-9)
    for a in (a1, a2):
        assert abs(np.cosh(a) * np.cos(a) + 1) < 1e-10


def test_uniform_reed_omega_3046():
    r = load_reed("uniform")
    m = r.material
    w = rb.uniform_natural_frequency(m.youngs_modulus, m.density, r.thickness, r.length)
    assert rel(w, TV["table_3_3"]["uniform"]["omega_eb"]) < 1e-3
    assert rel(rb.natural_frequency(r), w) < 1e-12
    assert rel(rb.free_vibration(r)[0], w) < 1e-10  # spectral solver, independent of eq 3.2


def test_stepped1_alpha_and_omega_2427():
    r = load_reed("stepped1")
    alpha = rb.stepped_frequency_parameter(r.step_fraction, r.width_ratio)
    assert rel(alpha, TV["table_3_11"]["stepped1"]["alpha_analytic"]) < 1e-3
    m = r.material
    w = rb.uniform_natural_frequency(m.youngs_modulus, m.density, r.thickness, r.length, alpha)  # eq 3.7
    assert rel(w, TV["table_3_3"]["stepped1"]["omega_eb"]) < 1e-3
    assert rel(rb.natural_frequency(r), w) < 1e-12


@pytest.mark.parametrize("Rl,W21", [(0.1875, 2.0), (0.3, 2.0), (0.5, 0.5), (0.2, 4.0), (0.7, 1.5)])
def test_stepped_determinant_matches_spectral_eigensolver(Rl, W21):
    alpha = rb.stepped_frequency_parameter(Rl, W21)
    r = make_reed(L=1.0, h=0.01, W1=0.05, W2=0.05 * W21, Rl=Rl, E=2.9e9, rho=1410.0)  # any material: the check is of alpha
    m = r.material
    w_spec = rb.free_vibration(r)[0]
    w_det = rb.uniform_natural_frequency(m.youngs_modulus, m.density, r.thickness, r.length, alpha)
    assert rel(w_spec, w_det) < 1e-9


def test_stepped_formulas_collapse_to_uniform():
    a_u = rb.uniform_frequency_parameter()
    assert rb.stepped_frequency_parameter(0.4, 1.0) == pytest.approx(a_u, rel=1e-12)
    assert rb.stepped_frequency_parameter(0.0, 3.0) == pytest.approx(a_u, rel=1e-12)
    E, h, L, W = 2.9e9, 1.35e-3, 25.4e-3, 15.875e-3
    k_u = 2 * E * h**3 / (3 * L**4)
    assert rb.uniform_stiffness(E, h, L) == pytest.approx(k_u, rel=1e-15)
    for L1 in (0.0, 0.3 * L, 0.9 * L):
        assert rb.stiffness_eq_3_40(E, h, W, W, L1, L - L1) == pytest.approx(k_u, rel=1e-12)


def test_eq_3_40_printed_form_holds_only_for_width_ratio_2():
    """Erratum: the printed last term (3/2) W2 L2^4 equals 3 W1 L2^4 only when W2 = 2 W1."""
    E, h, L = 2.9e9, 1.35e-3, 25.4e-3

    def printed(W1, W2, L1, L2):
        I1 = W1 * h**3 / 12
        return 24 * E * I1 / (3 * W1 * L1**4 + (4 * W1 + 8 * W2) * L1**3 * L2 + 18 * W2 * L1**2 * L2**2
                              + 12 * W2 * L1 * L2**3 + 1.5 * W2 * L2**4)

    L1, L2 = 0.1875 * L, 0.8125 * L
    W1 = 5 / 16 * 25.4e-3
    assert printed(W1, 2 * W1, L1, L2) == pytest.approx(rb.stiffness_eq_3_40(E, h, W1, 2 * W1, L1, L2), rel=1e-14)
    # uniform limit: the printed form misses 2 E h^3 / (3 L^4); the corrected one does not
    assert rel(printed(W1, W1, L1, L2), rb.uniform_stiffness(E, h, L)) > 0.1
    r = make_reed(W1=7e-3, W2=21e-3, Rl=0.25)  # W21 = 3: eq 3.40 as implemented is exact E-B
    k = rb.stiffness_eq_3_40(200e9, r.thickness, 7e-3, 21e-3, r.step_location, r.length - r.step_location)
    assert rel(k, rb.exact_stiffness(r)) < 1e-11


# -- stiffness -----------------------------------------------------------------------------


def test_kappa_stepped1_eq_3_40_and_stepped2_three_section():
    s1, s2 = load_reed("stepped1"), load_reed("stepped2")
    E = s1.material.youngs_modulus
    k1 = rb.stiffness_eq_3_40(E, s1.thickness, s1.width_root, s1.width_tip, s1.step_location,
                              s1.length - s1.step_location)
    assert rel(k1, TV["table_3_13"]["kappa_eq_3_40_stepped1"]) < 1e-3
    assert rel(rb.three_section_stiffness(s1), k1) < 1e-12  # square tip: three sections = eq 3.40
    assert rel(rb.exact_stiffness(s1), k1) < 1e-12          # and both are exact E-B
    k2 = rb.three_section_stiffness(s2)
    assert rel(k2, TV["table_3_13"]["kappa_three_section_stepped2"]) < 1e-3
    # the rigid-tip approximation is stiffer than the exact flexible-tip solution
    assert rb.exact_stiffness(s2) < k2


QUAD_CASES = {
    "stepped2": lambda: load_reed("stepped2"),
    "rounded_steel": lambda: make_reed(R=6e-3),
    "grooved_rect": lambda: make_reed(grooves=[
        {"s_start": 0.0, "s_end": 15e-3, "y_center": 0.0, "width": 3e-3, "depth": 0.2e-3},
        {"s_start": 12e-3, "s_end": 28e-3, "y_center": 6e-3, "width": 2e-3, "depth": 0.5e-3}]),
    "grooved_ring": lambda: make_reed(R=10e-3, grooves=[
        {"s_start": 0.0, "s_end": 15e-3, "y_center": 0.0, "width": 3e-3, "depth": 0.2e-3},
        {"kind": "half_ring", "s_center": 20e-3, "r_inner": 4e-3, "r_outer": 6e-3, "depth": 0.3e-3}]),
    "prototype": lambda: load_reed("prototype"),
}


@pytest.mark.parametrize("name", [
    "stepped2", "rounded_steel", "grooved_rect",
    pytest.param("grooved_ring", marks=pytest.mark.slow), pytest.param("prototype", marks=pytest.mark.slow),
])
def test_exact_stiffness_matches_adaptive_quadrature(name):
    reed = QUAD_CASES[name]()
    assert rel(rb.exact_stiffness(reed), quad_stiffness(reed)) < 1e-8


def test_uniform_load_shape_is_table_3_7():
    r = load_reed("uniform")
    s = np.linspace(0, r.length, 53)
    _, psi = rb.shape(r, "load", s)
    L = r.length
    ref = s**2 * (s**2 + 6 * L**2 - 4 * L * s) / (3 * L**4)  # q s^2 (..) / 24 EI over q L^4 / 8 EI
    assert np.max(np.abs(psi - ref)) < 1e-12


def test_three_section_method_refuses_an_all_tip_reed():
    r = make_reed(L=10e-3, W1=20e-3, W2=20e-3, Rl=0.0, R=10e-3)  # the semicircle is the whole reed
    with pytest.raises(ValueError):
        rb.three_section_stiffness(r)
    assert rb.exact_stiffness(r) > 0  # exact E-B still bends the tip


def test_three_section_shape_is_exact_for_square_tip():
    r = load_reed("stepped1")
    s = np.linspace(0, r.length, 101)
    _, psi = rb.shape(r, "load", s)
    assert np.max(np.abs(rb.three_section_shape(r, s) - psi)) < 1e-12


# -- frequency of general profiles ---------------------------------------------------------


@pytest.mark.parametrize("name", ["stepped2", "prototype"])
def test_rounded_and_grooved_omega_matches_staircase_transfer_matrices(name):
    r = load_reed(name)
    assert rel(rb.natural_frequency(r), richardson_omega(r)) < 1e-6


def test_spectral_solution_converged():
    r = load_reed("prototype")
    for f in (rb.exact_stiffness, lambda rr, n: rb.free_vibration(rr, n)[0]):
        a, b = f(r, 16), f(r, 48)
        assert rel(a, b) < 1e-8
        assert rel(f(r, NODES_PER_PIECE), b) < 1e-11


def test_free_mode_shape_matches_exact_stepped_mode():
    r = load_reed("stepped1")
    segs = rb.stepped_segments(r)
    w = rb.cantilever_frequencies(segs)[0]
    s = np.linspace(0, r.length, 77)
    exact = rb.cantilever_mode_shape(segs, w, s)
    _, psi = rb.shape(r, "free", s)
    assert np.max(np.abs(psi - exact)) < 1e-9
    # uniform: the classical mode function
    u = load_reed("uniform")
    a = rb.uniform_frequency_parameter()
    x = a * s / u.length
    sig = (np.cosh(a) + np.cos(a)) / (np.sinh(a) + np.sin(a))
    phi = np.cosh(x) - np.cos(x) - sig * (np.sinh(x) - np.sin(x))
    _, psi_u = rb.shape(u, "free", s)
    assert np.max(np.abs(psi_u - phi / phi[-1])) < 1e-9


def test_second_mode_of_uniform_chain():
    segs = [rb.Segment(0.4, 2.0, 3.0), rb.Segment(0.6, 2.0, 3.0)]  # a uniform beam in two pieces
    w = rb.cantilever_frequencies(segs, 2)
    scale = np.sqrt(2.0 / 3.0)
    assert w[0] == pytest.approx(rb.uniform_frequency_parameter(1) ** 2 * scale, rel=1e-12)
    assert w[1] == pytest.approx(rb.uniform_frequency_parameter(2) ** 2 * scale, rel=1e-12)


# -- mode-function parameters (Table 3.8, 3.9) ----------------------------------------------


@pytest.mark.parametrize("case,name,kind", [
    ("uniform/free", "uniform", "free"), ("uniform/load", "uniform", "load"),
    ("stepped1/free", "stepped1", "free"), ("stepped1/load", "stepped1", "load"),
    ("stepped2/load", "stepped2", "three_section"),
])
def test_table_3_8_within_0_1_percent(case, name, kind):
    g = rb.shape_mode_parameters(load_reed(name), kind)
    for i in range(3):
        assert rel(g[i], TV["table_3_8"][case][f"gamma{i + 1}"]) < 1e-3


def test_eq_3_44_as_printed_does_not_reproduce_table_3_8():
    """Erratum: with (s - L1) theta1 in eq 3.44 gamma1 of stepped #2 is far from the printed 1.640."""
    r = load_reed("stepped2")
    ts = rb.ThreeSection.from_reed(r)
    x1, t1, x2, t2 = ts.ends()
    bm = rb.BeamModel.of(r)
    s = bm.quad.s
    v = ts.deflection(s)
    v = np.where(s > ts.L1 + ts.L2, x1 + (s - ts.L1) * t1 + x2 + (s - ts.L1 - ts.L2) * (t1 + t2), v)
    v_tip = x1 + (r.length - ts.L1) * t1 + x2 + ts.L3 * (t1 + t2)
    g_printed = rb.mode_integrals(bm.quad, v / v_tip, bm.W, r.width_tip)
    assert rel(g_printed[0], TV["table_3_8"]["stepped2/load"]["gamma1"]) > 0.05
    # the corrected shape is continuous with slope at the start of the tip
    s3 = np.array([ts.L1 + ts.L2 - 1e-9, ts.L1 + ts.L2 + 1e-9])
    assert abs(np.diff(ts.deflection(s3))[0]) < 1e-12


def test_table_3_9_eb_rows_within_0_2_percent():
    r = load_reed("stepped1")
    m = r.material
    w = rb.natural_frequency(r)
    k = rb.exact_stiffness(r)
    g_direct = rb.shape_mode_parameters(r, "load")[0]
    g_alt = gamma1_alternative(m.density, r.thickness, w, k)
    assert rel(g_direct, TV["table_3_9"]["eb_direct"]["gamma1"]) < 2e-3
    assert rel(g_alt, TV["table_3_9"]["eb_alternative"]["gamma1"]) < 2e-3


def test_reed_properties_contract_and_eq_3_62():
    r = load_reed("stepped1")
    p = rb.reed_properties(r)
    assert p.fidelity == "analytic" and p.dofs is None and p.mesh_size is None
    assert rel(p.omega_n, 2427.0) < 1e-3 and rel(p.kappa, 7.345e6) < 1e-3
    assert p.h_eff == pytest.approx(effective_thickness(p.gamma1, p.kappa, r.material.density, p.omega_n))
    assert abs(p.psi[0]) < 1e-15 and p.psi[-1] == pytest.approx(1.0, abs=1e-12)
    assert np.all(np.diff(p.psi) > 0)
    c = p.as_contract("stepped1")
    assert set(c) >= {"geometry", "fidelity", "omega_n", "kappa", "gamma1", "gamma2", "gamma3", "dofs", "mesh_size"}


def test_brief_steel_reed_consistent_with_closed_forms():
    """30 mm long, 0.8 mm thick steel reed, 10/20 mm step at 30 %: exact E-B = closed forms."""
    r = make_reed()
    p = rb.reed_properties(r)
    m = r.material
    alpha = rb.stepped_frequency_parameter(0.3, 2.0)
    w = rb.uniform_natural_frequency(m.youngs_modulus, m.density, r.thickness, r.length, alpha)
    assert rel(p.omega_n, w) < 1e-12
    assert rel(rb.free_vibration(r)[0], w) < 1e-9
    k = rb.stiffness_eq_3_40(m.youngs_modulus, r.thickness, 10e-3, 20e-3, 9e-3, 21e-3)
    assert rel(p.kappa, k) < 1e-11
    g3 = rb.shape_mode_parameters(r, "three_section")  # eqs 3.42-3.43, exact for a square tip
    assert np.allclose((p.gamma1, p.gamma2, p.gamma3), g3, rtol=1e-10)
    # rounded version: the rigid-tip method overestimates kappa, exact E-B is the reference
    rr = make_reed(R=10e-3)
    assert rb.three_section_stiffness(rr) > rb.exact_stiffness(rr) > rb.exact_stiffness(r)


@pytest.mark.parametrize("name", ["stepped1", "stepped2", "prototype"])
def test_sampled_shape_gammas_agree_with_spectral(name):
    """mode_parameters on a shape sampled like FEA output (201 uniform points) reproduces the
    spectral gammas: the piecewise integration does not lose accuracy at the step or tip."""
    from lumped.reed.mode_function import mode_parameters

    r = load_reed(name)
    p = rb.reed_properties(r)
    s = np.linspace(0, r.length, 201)
    _, psi = rb.shape(r, "load", s)
    g = mode_parameters(r, s, 3.0 * psi)  # any normalisation
    assert np.allclose(g, (p.gamma1, p.gamma2, p.gamma3), rtol=2e-6)
