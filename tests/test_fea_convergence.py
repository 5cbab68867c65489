"""Richardson extrapolation (fea.convergence) on sequences with known limits."""

import math

import pytest

from fea.convergence import default_sizes, richardson


@pytest.mark.parametrize("p", [1.0, 2.0, 4.0])
def test_recovers_order_and_limit_of_a_power_law(p):
    f_inf, C = 2400.0, 37.0
    h = default_sizes(1.0e-3)
    r = richardson(h, [f_inf + C * (x / 1e-3) ** p for x in h])
    assert r.monotonic and r.converging
    assert r.order == pytest.approx(p, rel=1e-9)
    assert r.extrapolated == pytest.approx(f_inf, rel=1e-12)
    # error of each mesh is exactly its distance to the limit
    for x, e in zip(h, r.error_pct):
        assert e == pytest.approx(C * (x / 1e-3) ** p / f_inf * 100, rel=1e-9)


def test_non_monotonic_sequence_is_flagged_with_a_conservative_bound():
    r = richardson((2e-3, 1.4e-3, 1e-3), [10.0, 9.0, 9.5])
    assert not r.monotonic and not r.converging and r.order is None
    assert r.extrapolated == 9.5
    assert min(r.error_pct) >= abs(9.0 - 10.0) / 9.5 * 100 - 1e-12


def test_monotonic_but_not_shrinking_changes_give_no_order():
    r = richardson((2e-3, 1.4e-3, 1e-3), [10.0, 9.9, 9.7])
    assert r.monotonic and not r.converging and r.order is None
    assert r.error_pct[1] == pytest.approx(0.2 / 9.7 * 100)


def test_sizes_ratio():
    h = default_sizes(1.0)
    assert h[0] / h[1] == pytest.approx(math.sqrt(2)) and h[1] / h[2] == pytest.approx(math.sqrt(2))
    with pytest.raises(ValueError):
        richardson((1.0, 2.0, 3.0), (1, 2, 3))
