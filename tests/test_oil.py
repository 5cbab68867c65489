"""Oil: viscosity of Appendix A, eq 4.11 density and its Newton inversion (eqs 4.12-4.16)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lumped.fluid import oil
from lumped.model.model_file import load_model
from studies.tables.thesis import thesis_values

RHO0, P0, BETA = 876.0, 101325.0, 1.84e9


def test_viscosity_parameters_reproduce_appendix_a():
    # Table A.1: 44.2 and 6.65 cSt at 40 and 100 C, 876 kg/m^3 (typed in here, independently of the data file)
    mu0, b = oil.viscosity_parameters(44.2e-6, 313.15, 6.65e-6, 373.15, 876.0)
    th = thesis_values()["oil"]
    # eq A.2 in the thesis's sign convention prints b = -0.03157 1/K for the decay rate 0.03157
    assert -b == pytest.approx(th["b"], rel=2e-4)
    assert mu0 == pytest.approx(th["mu_0"], rel=1e-3)          # 761.1 Pa s (760.7 unrounded)
    assert oil.viscosity(295.15, mu0, b) == pytest.approx(th["mu_22C"], rel=2e-3)
    # the model goes through both data points of Table A.1
    assert oil.viscosity(313.15, mu0, b) == pytest.approx(876.0 * 44.2e-6, rel=1e-12)
    assert oil.viscosity(373.15, mu0, b) == pytest.approx(876.0 * 6.65e-6, rel=1e-12)
    assert oil.thesis_oil_viscosity()[1] == pytest.approx(0.0683, rel=2e-3)
    # the shipped thesis models carry eq A.3 at 22 C to round-off (their viscosity key is that number)
    for name in ("thesis-disc", "thesis-reed"):
        assert load_model(name).oil.viscosity == pytest.approx(oil.viscosity(295.15, mu0, b), rel=1e-12)


def test_density_limits():
    # at P0 the mixture has its atmospheric density for any air content
    for air in (0.0, 0.008, 0.013, 0.3):
        assert oil.density(P0, RHO0, P0, BETA, 1.4, air) == pytest.approx(RHO0, rel=1e-15)
    # air-free oil: the bulk modulus at P0 is beta
    slope = oil.density_slope(P0, RHO0, P0, BETA, 1.4, 0.0)
    assert RHO0 / slope == pytest.approx(BETA, rel=1e-12)
    # with air, the isentropic mixture modulus at P0: 1/B = (1-R)/beta + R/(gamma P0)
    air = 0.01
    b_mix = 1.0 / ((1 - air) / BETA + air / (1.4 * P0))
    assert RHO0 / oil.density_slope(P0, RHO0, P0, BETA, 1.4, air) == pytest.approx(b_mix, rel=1e-12)


def test_density_slope_is_the_derivative():
    for air in (0.0, 0.013, 0.5):
        for p in (2e3, 1e5, 2.76e6, 3e7):
            h = p * 1e-3

            def f(q):
                return oil.density(q, RHO0, P0, BETA, 1.4, air)
            fd = (f(p - 2 * h) - 8 * f(p - h) + 8 * f(p + h) - f(p + 2 * h)) / (12 * h)   # O(h^4)
            assert oil.density_slope(p, RHO0, P0, BETA, 1.4, air) == pytest.approx(fd, rel=1e-7)


def test_air_lowers_density_at_load_pressure_by_the_ideal_gas_volume():
    # at 2.76 MPa the air of R = 0.013 occupies R (P0/P)^(1/gamma) of the oil volume
    p = 2.76e6
    rho = oil.density(p, RHO0, P0, BETA, 1.4, 0.013)
    expect = RHO0 / (0.013 * (P0 / p) ** (1 / 1.4) + 0.987 * math.exp(-(p - P0) / BETA))
    assert rho == pytest.approx(expect, rel=1e-15)
    assert rho < oil.density(p, RHO0, P0, BETA, 1.4, 0.0) / 0.987


@pytest.mark.parametrize("air", [0.0, 1e-6, 1e-4, 0.008, 0.013, 0.05, 0.2, 0.5, 0.9])
@pytest.mark.parametrize("gamma", [1.0, 1.4])
def test_pressure_inverts_density_over_the_whole_pump_range(air, gamma):
    # from deep cavitating suction (100 Pa absolute) to far beyond the load (100 MPa)
    worst, most = 0.0, 0
    for p in np.geomspace(1e2, 1e8, 300):
        rho = oil.density(p, RHO0, P0, BETA, gamma, air)
        q, it = oil.pressure_iterations(rho, RHO0, P0, BETA, gamma, air)
        # the inverse is conditioned to ~beta * eps in absolute terms (liquid term)
        worst = max(worst, abs(q - p) / (1e-10 * p + 1e-15 * BETA))
        most = max(most, it)
    assert worst < 1.0
    assert most <= 20          # monotone Newton from a lower bound: never the 60-iteration cap


def test_newton_iterates_rise_monotonically_from_below():
    # convex decreasing f: started left of the root Newton never overshoots; check the iterates
    air, gamma = 0.013, 1.4
    p_true = 1.7e6
    rho = oil.density(p_true, RHO0, P0, BETA, gamma, air)
    seen = []
    for n in range(1, 12):
        q, it = oil.pressure_iterations(rho, RHO0, P0, BETA, gamma, air, rtol=0.0, maxiter=n)
        seen.append(q)
        if it < n:
            break
    assert all(b >= a - 1e-9 * p_true for a, b in zip(seen, seen[1:]))
    assert all(q <= p_true * (1 + 1e-12) for q in seen)
    assert seen[-1] == pytest.approx(p_true, rel=1e-12)


@settings(max_examples=300, deadline=None)
@given(p=st.floats(1e3, 5e7), air=st.floats(0.0, 0.6), gamma=st.floats(1.0, 1.67))
def test_pressure_round_trip_property(p, air, gamma):
    rho = oil.density(p, RHO0, P0, BETA, gamma, air)
    q, it = oil.pressure_iterations(rho, RHO0, P0, BETA, gamma, air)
    assert abs(q - p) <= 1e-9 * p + 1e-15 * BETA
    assert it < 60


def test_air_free_pressure_is_explicit_and_may_be_tension():
    # R = 0: the liquid root is exact; below rho_0 exp(-P0/beta) the pressure is negative
    rho = RHO0 * math.exp(-(P0 + 1e5) / BETA)
    q, it = oil.pressure_iterations(rho, RHO0, P0, BETA, 1.4, 0.0)
    assert it == 0 and q == pytest.approx(-1e5, abs=1e-6 * BETA * 1e-6 + 1e-3)


def test_oil_dataclass_air_content():
    from dataclasses import replace
    o = load_model("thesis-disc").oil
    assert o.air_content == 0.013
    off = replace(o, air_content=0.0)
    # both mixtures weigh rho_0 at P0; the one with air compresses more
    assert o.density_at(2.76e6) > off.density_at(2.76e6)
    assert o.density_at(P0) == pytest.approx(off.density_at(P0), rel=1e-12)
    assert off.pressure_at(off.density_at(2.76e6)) == pytest.approx(2.76e6, rel=1e-12)


@pytest.mark.parametrize("air", [0.008, 0.013, 0.03])
def test_pressure_inversion_is_cheap_over_the_pump_range(air):
    """Closed-form start and an error-bound stop: at most about 3.5 Newton iterations on average
    from 1 kPa to 5 MPa and never more than 12 (the start from the single-term lower bounds
    needed 3.6-3.9 and up to 16), each result within 1e-13 of the pressure that made the density."""
    ps = np.concatenate([np.geomspace(1e3, 1e5, 40), np.geomspace(1e5, 5e6, 80)])
    its = []
    for p in ps:
        rho = oil.density(p, RHO0, P0, BETA, 1.4, air)
        q, it = oil.pressure_iterations(rho, RHO0, P0, BETA, 1.4, air)
        assert abs(q - p) <= 1e-13 * p + 4e-16 * BETA
        its.append(it)
    assert np.mean(its) <= 3.5 and max(its) <= 12


def test_pressure_start_far_right_of_the_root_still_converges_from_below():
    """A Newton step from the right lands left of the root (convexity), then rises monotonically:
    even with an upper-bound start the iterates after the first never exceed the root."""
    air, gamma = 0.008, 1.4
    p_true = 2.5e6
    rho = oil.density(p_true, RHO0, P0, BETA, gamma, air)
    seen = [oil.pressure_iterations(rho, RHO0, P0, BETA, gamma, air, rtol=0.0, maxiter=n)[0] for n in range(1, 7)]
    assert all(q <= p_true * (1 + 1e-12) for q in seen)
    assert all(b >= a - 1e-9 * p_true for a, b in zip(seen, seen[1:]))


@pytest.mark.parametrize("air", [0.008, 0.013, 0.05])
def test_warm_start_gives_the_same_root_in_fewer_iterations(air):
    """A start at a neighbouring state's pressure (as an integrator's stages give it) returns the pressure
    that made the density to the same 1e-13, in no more Newton steps than the closed-form start and in at
    most 3 when the start is within 0.1 % (2 within 1 ppm); a start anywhere in (0, 100 MPa] still converges (convexity)."""
    for p_true in np.geomspace(2e3, 5e6, 25):
        rho = oil.density(p_true, RHO0, P0, BETA, 1.4, air)
        cold, it_cold = oil.pressure_iterations(rho, RHO0, P0, BETA, 1.4, air)
        for start in (p_true * (1 + 1e-3), p_true * (1 - 1e-3), p_true * (1 + 1e-6)):
            warm, it_warm = oil.pressure_iterations(rho, RHO0, P0, BETA, 1.4, air, p_start=start)
            assert abs(warm - p_true) <= 1e-13 * p_true + 4e-16 * BETA
            assert it_warm <= min(it_cold, 3 if abs(start / p_true - 1) > 1e-5 else 2)
        for start in (1.0, 1e3, 1e8):
            far, _ = oil.pressure_iterations(rho, RHO0, P0, BETA, 1.4, air, p_start=start)
            assert abs(far - p_true) <= 1e-13 * p_true + 4e-16 * BETA
