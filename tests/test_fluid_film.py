"""The Reynolds thin-film FE (fea.fluid.reynolds, fea.fluid.disc_film) against closed forms.

Independent references: plane Poiseuille and squeeze flow between parallel plates (Hamrock
et al. 2004, ch. 7), the disc's C1 and C2 (eqs 2.14-2.15, lumped.valves.disc), the viscous log
law of radial flow, the closed-form cavitating film of lumped.valves.disc.film_force (Reynolds
condition at the cavity edges), conservation of volume, and the GCI's estimate against the
true error of three meshes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from skfem import MeshTri

from fea.fluid.disc_film import DiscFilm, annulus_mesh, closed_form, film_coefficients, film_ladder, thin_film_point
from fea.fluid.point import load_fluid_valve
from fea.fluid.reynolds import FilmOptions, solve_film
from geometry.errors import InputError
from lumped.valves.disc import film_force

MU = 0.0683
#: the thesis disc (section 2.4.2) and two others: a wide 45 deg seat and a narrow flat one
DISCS = {"thesis": DiscFilm(5.24e-3, 7.5e-3, math.radians(54.0)),
         "wide_45deg": DiscFilm(3.0e-3, 6.0e-3, math.radians(45.0)),
         "narrow_flat": DiscFilm(10.0e-3, 11.0e-3, math.radians(90.0))}


def channel(length=1e-3, width=2e-3, nx=8, ny=4):
    m = MeshTri.init_tensor(np.linspace(0, length, nx + 1), np.linspace(0, width, ny + 1))
    return m.with_boundaries({"in": lambda x: x[0] < 1e-12, "out": lambda x: x[0] > length - 1e-12})


@pytest.mark.parametrize("order", [1, 2])
def test_plane_poiseuille_flow_is_exact(order):
    h, dp, L, W = 20e-6, 2e5, 1e-3, 2e-3
    s = solve_film(channel(L, W), h, MU, {"in": dp, "out": 0.0}, options=FilmOptions(order=order))
    q = h**3 * W * dp / (12 * MU * L)
    assert s.flows["out"] == pytest.approx(q, rel=1e-10)
    assert s.flows["in"] == pytest.approx(-q, rel=1e-10)
    assert s.force == pytest.approx(0.5 * dp * L * W, rel=1e-10)       # linear pressure


def test_squeeze_between_plates_matches_closed_form():
    # d/dx(h^3/(12 mu) dp/dx) = hdot, p = 0 at both ends: p = 6 mu hdot x (x - L) / h^3,
    # force per width -mu hdot L^3 / h^3, half the swept volume out of each end
    h, hdot, L, W = 20e-6, 1e-3, 1e-3, 2e-3
    m = channel(L, W, nx=16).with_boundaries({"a": lambda x: x[0] < 1e-12, "b": lambda x: x[0] > L - 1e-12})
    s = solve_film(m, h, MU, {"a": 0.0, "b": 0.0}, wall_velocity=hdot, options=FilmOptions(order=2))
    assert s.force == pytest.approx(-MU * hdot * L**3 / h**3 * W, rel=1e-10)   # P2 holds the parabola
    assert s.flows["a"] == pytest.approx(-0.5 * hdot * L * W, rel=1e-10)
    assert s.force_poiseuille == 0.0 and s.force_squeeze == s.force


def test_volume_is_conserved_with_a_varying_gap():
    m = annulus_mesh(2e-3, 5e-3, 8)
    s = solve_film(m, lambda x, y: 10e-6 * (1 + 0.3 * x / 5e-3), MU, {"inner": 1e5, "outer": 2e4},
                   wall_velocity=lambda x, y: 1e-3 * (1 + y / 5e-3))
    swept = 1e-3 * s.area                     # int hdot dA: the y term integrates to zero
    assert sum(s.flows.values()) + swept == pytest.approx(0.0, abs=1e-9 * swept)


def test_weighted_force_uses_the_mode_function():
    # linear pressure dp (1 - x/L) weighted by psi = x/L: int = dp L W / 6
    L, W, dp = 1e-3, 2e-3, 1e5
    s = solve_film(channel(L, W), 20e-6, MU, {"in": dp, "out": 0.0},
                   options=FilmOptions(order=2, weight=lambda x, y: x / L))
    assert s.force == pytest.approx(dp * L * W / 6, rel=1e-10)


@pytest.mark.parametrize("name", list(DISCS))
def test_c1_c2_of_three_discs_within_half_a_percent(name):
    film = DISCS[name]
    exact = closed_form(film, MU)
    c = film_coefficients(film, MU, divisions=16)
    assert c.c1 == pytest.approx(exact["c1"], rel=5e-3)
    assert c.c2 == pytest.approx(exact["c2"], rel=5e-3)
    assert c.conductance == pytest.approx(exact["conductance"], rel=5e-3)    # the viscous log law


@pytest.mark.parametrize("name", list(DISCS))
def test_gci_estimates_the_true_error_within_a_factor_1_5(name):
    film = DISCS[name]
    exact = closed_form(film, MU)
    lad = film_ladder(film, MU, divisions=8)
    fine = lad["levels"][2]
    for key in ("c1", "c2", "conductance"):
        g = lad["gci"][key]
        true = abs(getattr(fine, key) - exact[key])
        estimate = abs(getattr(fine, key) - g.extrapolated)
        assert g.converging
        assert 1 / 1.5 <= estimate / true <= 1.5, (key, estimate, true)
        assert 1 / 1.5 <= g.u_fine / true <= 1.5, (key, g.u_fine, true)      # the GCI band itself


def test_p2_is_more_accurate_than_p1():
    film = DISCS["thesis"]
    exact = closed_form(film, MU)["c2"]
    e1 = abs(film_coefficients(film, MU, 8, order=1).c2 / exact - 1)
    e2 = abs(film_coefficients(film, MU, 8, order=2).c2 / exact - 1)
    assert e2 < 0.2 * e1


def test_cavitating_film_matches_the_closed_form():
    # separating disc: the film falls to the floor over part of the annulus; lumped.valves.disc's
    # film_force solves the same problem (Reynolds condition at the cavity edges) in closed form
    film = DISCS["thesis"]
    s_th = math.sin(film.bevel_angle)
    x, u, p_up, p_down, p_lim = 20e-6, 0.05, 3e5, 1e5, 1e3
    sol = solve_film(annulus_mesh(*film.slant_radii, 64), x * s_th, MU, {"inner": p_up, "outer": p_down},
                     wall_velocity=u * s_th, options=FilmOptions(cavitation_pressure=p_lim, reference_pressure=p_down))
    force = math.pi * film.inner_radius**2 * (p_up - p_down) + s_th**2 * sol.force
    k = 3 * MU * u / (x**3 * s_th**4)
    assert sol.cavitated_area > 0.1 * sol.area
    assert force == pytest.approx(film_force(p_up, p_down, p_lim, k, film.inner_radius, film.outer_radius), rel=5e-3)
    assert sol.pressure.min() >= p_lim - 1e-6


def test_thin_film_point_of_the_thesis_disc():
    v = load_fluid_valve("thesis-disc:inlet")
    p = thin_film_point(v, 0.05e-3, 5.0, {"squeeze": True, "displacement": True, "gci": True})
    exact = closed_form(DISCS["thesis"], v.viscosity)
    assert p.dp == pytest.approx(p.flow / (exact["conductance"] * 0.05e-3**3), rel=1e-3)
    assert p.force_coefficient == pytest.approx(exact["c1"], rel=1e-3)
    assert p.extra["film"]["C2"] == pytest.approx(exact["c2"], rel=5e-3)
    assert 0.0 < p.extra["displacement"]["f1"] < 1.0
    assert set(p.u_num) == {"dp", "cd", "force"} and all(u >= 0 for u in p.u_num.values())


@pytest.mark.parametrize("bad, field", [
    (dict(gap=-1e-6), "gap"), (dict(pressures={"nowhere": 1.0}), "pressures"),
    (dict(options=FilmOptions(order=3)), "order"), (dict(viscosity=0.0), "viscosity"),
    (dict(gap=np.ones(7)), "gap")])
def test_bad_film_input_names_the_field(bad, field):
    args = dict(gap=1e-5, viscosity=MU, pressures={"in": 1.0, "out": 0.0})
    args.update(bad)
    with pytest.raises(InputError) as err:
        solve_film(channel(), args["gap"], args["viscosity"], args["pressures"], options=args.get("options", FilmOptions()))
    assert err.value.field == field
