"""The reed's compact forms (fea.fluid.reed_compact) from given points: the operating line and the X table.

Synthetic points with known laws (a Stokes film: Q = G dP; X constant or linear in x), so each
output has an independent closed form; the 3-D points themselves are computed by the slow studies.
"""

from __future__ import annotations

import numpy as np
import pytest

from fea.fluid import ns3d, reed_compact
from fea.fluid.reed3d import ReedValveFlow
from fea.fluid.reed_mesh import ReedSeat

KAPPA, RHO, MU = 7.709e6, 876.0, 0.0683


@pytest.fixture(scope="module")
def valve():
    from geometry.reed_io import load_reed

    reed = load_reed("prototype")
    s = np.linspace(0, reed.length, 11)
    return ReedValveFlow(reed=reed, seat=ReedSeat(), shape=(s, (s / reed.length) ** 2), fluid=ns3d.Fluid(RHO, MU),
                         orifice_length=19.4e-3, orifice_perimeter=91.2e-3, area_min=55.1e-6, area_max=338.4e-6,
                         stiffness=KAPPA)


def _rows(x: float, G: float, X: float) -> list[dict]:
    return [{"opening": x, "dp": dp, "flow": G * dp, "multiplier": X, "reynolds": 0.0, "cd": 0.0}
            for dp in (1.0, 1e3, 1e4, 1e5)]


def test_operating_line_of_a_linear_film(valve):
    x, G, X, x0 = 0.3e-3, 2.5e-10, 0.8, -0.18e-3
    (p,) = reed_compact.equilibrium_points(_rows(x, G, X), valve, x0)
    dp = KAPPA * (x - x0) / X                                      # eq 3.82
    assert p["dp"] == pytest.approx(dp, rel=1e-12)
    assert p["flow"] == pytest.approx(G * dp, rel=1e-9)            # log-log interpolation is exact for Q ~ dP
    assert p["cd"] == pytest.approx(G * dp / (19.4e-3 * x * np.sqrt(2 * dp / RHO)), rel=1e-9)
    assert p["reynolds"] == pytest.approx(4 * RHO * G * dp / (91.2e-3 * MU), rel=1e-9)


def test_operating_line_beyond_the_points_is_left_out(valve):
    assert reed_compact.equilibrium_points(_rows(0.3e-3, 2.5e-10, 0.001), valve) == []


def test_multiplier_table_finds_the_zero():
    rows = [{"opening": x, "dp": 1e3, "reynolds": 10.0, "multiplier": 0.8 - 500.0 * x} for x in (0.5e-3, 1.0e-3, 2.0e-3)]
    table = reed_compact.multiplier_table(rows, 0.835)
    assert table["X"][0] == 0.835 and table["opening"][0] == 0.0
    assert table["zero_opening"] == pytest.approx(1.6e-3, rel=1e-12)     # 0.8 - 500 x = 0
