"""Richardson extrapolation with its asymptotic-range checks (fea.convergence) on sequences with
known limits, and the convergence study of a real model against its exact converged value."""

import math

import pytest

from fea.convergence import ELEMENT_ORDER, convergence_study, default_sizes, richardson
from geometry import load_reed


@pytest.mark.parametrize("p", [1.2, 2.0, 4.0])
def test_recovers_order_and_limit_of_a_power_law(p):
    f_inf, C = 2400.0, 37.0
    h = default_sizes(1.0e-3)
    r = richardson(h, [f_inf + C * (x / 1e-3) ** p for x in h], theoretical_order=4.0)
    assert r.monotonic and r.converging and r.asymptotic and r.reliable
    assert r.order == pytest.approx(p, rel=1e-9)
    assert r.extrapolated == pytest.approx(f_inf, rel=1e-12)
    # error of each mesh is exactly its distance to the limit
    for x, e in zip(h, r.error_pct):
        assert e == pytest.approx(C * (x / 1e-3) ** p / f_inf * 100, rel=1e-9)


def test_non_monotonic_sequence_is_flagged_with_a_conservative_bound():
    r = richardson((2e-3, 1.4e-3, 1e-3), [10.0, 9.0, 9.5])
    assert not r.monotonic and not r.converging and r.order is None
    assert not r.asymptotic and not r.reliable and "not monotonic" in r.note
    assert r.extrapolated == 9.5
    assert min(r.error_pct) >= abs(9.0 - 10.0) / 9.5 * 100 - 1e-12


def test_monotonic_but_not_shrinking_changes_give_no_order():
    r = richardson((2e-3, 1e-3, 0.5e-3), [10.0, 9.9, 9.7])
    assert r.monotonic and not r.converging and r.order is None and not r.reliable
    # first order assumed from the last change (r = 2: the remaining error equals it)
    assert r.error_pct[2] == pytest.approx(0.2 / 9.7 * 100)
    assert r.error_pct[1] == pytest.approx((0.2 + 0.2) / 9.7 * 100)


@pytest.mark.parametrize("p,asymptotic", [(0.6, False), (1.3, True), (4.0, True), (6.0, False)])
def test_observed_order_must_be_plausible_for_the_element(p, asymptotic):
    """Orders below 1 (pre-asymptotic) or above 1.25 x the element's (noise) are not trusted."""
    h = default_sizes(1.0)
    r = richardson(h, [1.0 + 0.01 * x**p for x in h], theoretical_order=4.0)
    assert r.converging and r.asymptotic == asymptotic and r.reliable == asymptotic
    if not asymptotic:
        assert "asymptotic" in r.note and r.error_pct[1] >= abs(r.values[1] - r.values[2]) / r.values[2] * 100


def test_sizes_ratio():
    h = default_sizes(1.0)
    assert h[0] / h[1] == pytest.approx(2.0) and h[1] / h[2] == pytest.approx(2.0)
    assert default_sizes(1.0, math.sqrt(2))[0] == pytest.approx(math.sqrt(2))
    with pytest.raises(ValueError):
        richardson((1.0, 2.0, 3.0), (1, 2, 3))


def test_study_of_the_beam_estimates_its_true_error():
    """Known converged value: the exact E-B model (lumped.reed.euler_bernoulli, 1e-10) is the beam's limit.

    On meshes L/16, L/32, L/64 of stepped reed #2 the Hermite beam is in its asymptotic range
    (order 1.5: the rounded tip's square-root width); the estimated error of the middle mesh is
    within a factor 1.5 of its actual error against the exact value (measured: 1.00).
    """
    from lumped.reed import euler_bernoulli as rb

    reed = load_reed("stepped2")
    exact = rb.reed_properties(reed)
    L = reed.length
    study = convergence_study(reed, "beam", sizes=(L / 16, L / 32, L / 64), quantities=("omega_n", "kappa"),
                              progress=False, max_extra=0)
    assert study["reliable"] and study["default_index"] == 1
    for q in ("omega_n", "kappa"):
        c = study["quantities"][q]
        assert c["asymptotic"] and c["theoretical_order"] == ELEMENT_ORDER["beam"]
        true = abs(c["values"][1] - getattr(exact, q)) / getattr(exact, q) * 100
        assert true > 1e-6  # a measurable error, not round-off
        assert true / 1.5 <= c["default_error_pct"] <= 1.5 * true, (q, c, true)

