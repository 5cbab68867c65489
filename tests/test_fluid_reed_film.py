"""The reed's sealing film (fea.fluid.reed_film) against closed forms and the thesis's Table 3.12.

Closed forms: the side land's mean pressure fraction 1/2 (eq 3.53) and its squeeze pressure
(eq 3.51) on a straight strip, the tip land's fraction (eq 3.59) on an annulus, where they
hold exactly; the prototype's X in the Poiseuille regime inside Table 3.12's band with the
base fraction F4 computed from the flow instead of assumed.
"""

from __future__ import annotations

import numpy as np
import pytest
from skfem import MeshTri

from fea.fluid import reed_film
from fea.fluid.disc_film import annulus_mesh
from fea.fluid.reynolds import FilmOptions, solve_film
from lumped.reed.fluid import annulus_pressure_fraction

MU = 0.0683
STRIP = MeshTri.init_tensor(np.linspace(0.0, 10e-3, 41), np.linspace(0.0, 1.5875e-3, 9)).with_boundaries(
    {"up": lambda x: x[1] < 1e-12, "down": lambda x: x[1] > 1.5875e-3 - 1e-12})


def test_side_land_fraction_is_one_half():
    sol = solve_film(STRIP, 50e-6, MU, {"up": 1.0, "down": 0.0}, options=FilmOptions(order=2))
    F2 = reed_film.mean_fraction(sol.basis, sol.pressure, 1.0, lambda s, y: np.ones_like(s))
    assert F2 == pytest.approx(0.5, rel=5e-3)


def test_side_land_squeeze_matches_eq_3_51():
    # eq 3.51 with dP = 0: dP(y) = -6 mu W y u / x^3 (1 - y / W), mean -mu u W^2 / x^3
    W, x, u = 1.5875e-3, 50e-6, 1e-3
    sol = solve_film(STRIP, x, MU, {"up": 0.0, "down": 0.0}, wall_velocity=u, options=FilmOptions(order=2))
    mean = reed_film.mean_fraction(sol.basis, sol.pressure, 1.0, lambda s, y: np.ones_like(s))
    assert mean == pytest.approx(-MU * u * W**2 / x**3, rel=5e-3)


@pytest.mark.parametrize("r_in, r_out", [(6.35e-3, 7.9375e-3), (3e-3, 7.9375e-3)])
def test_tip_land_fraction_matches_eq_3_59(r_in, r_out):
    sol = solve_film(annulus_mesh(r_in, r_out, 8), 50e-6, MU, {"inner": 1.0, "outer": 0.0},
                     options=FilmOptions(order=2))
    F3 = reed_film.mean_fraction(sol.basis, sol.pressure, 1.0, lambda s, y: np.ones_like(s))
    assert F3 == pytest.approx(annulus_pressure_fraction(r_in, r_out), rel=5e-3)


@pytest.fixture(scope="module")
def prototype():
    from fea.fluid.reed3d import prototype_valve

    return prototype_valve()


def test_prototype_multiplier_in_table_3_12_band_with_computed_f4(prototype):
    film = reed_film.reed_film(prototype, 0.05e-3)
    assert 0.0 <= film.base_fraction <= 1.0
    assert 0.824 <= film.multiplier <= 0.845           # Table 3.12: F4 from 0 to 1
    # the side land is a straight strip away from its ends: eq 3.53 within 1 %
    assert film.side_fraction == pytest.approx(0.5, abs=0.005)


def test_prototype_film_converges_with_the_mesh(prototype):
    coarse = reed_film.reed_film(prototype, 0.05e-3, size=0.4e-3)
    fine = reed_film.reed_film(prototype, 0.05e-3, size=0.2e-3)
    assert fine.multiplier == pytest.approx(coarse.multiplier, rel=1e-3)
    assert fine.flow == pytest.approx(coarse.flow, rel=5e-3)


def test_squeeze_resistance_grows_as_the_gap_closes(prototype):
    # a film without grooves would scale exactly as x^-3; the grooves' depth does not shrink
    a = reed_film.reed_film(prototype, 0.05e-3, size=0.4e-3)
    b = reed_film.reed_film(prototype, 0.1e-3, size=0.4e-3)
    assert a.squeeze_coefficient > 0.0
    assert 4.0 < a.squeeze_coefficient / b.squeeze_coefficient <= 8.0 * 1.001
