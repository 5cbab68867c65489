"""Seat and stop stiffness (fea.seat_stop) and the reed stress check (fea.reed_stress)."""

import math
from dataclasses import replace

import numpy as np
import pytest

from fea import reed_stress
from fea.seat_stop import _revolved_mesh, _facet_geometry, _static_stiffness, seat_stiffness, stop_stiffness
from geometry import load_reed
from geometry.reed import Material
from geometry.seat_stop import load_housing_stop, load_seat_ring
from studies.tables.thesis import thesis_values


def test_ring_in_compression_is_EA_over_H():
    """nu = 0, load on the whole top face, base bonded: uniaxial stress, k = E A / H exactly."""
    ri, ro, H = 5e-3, 9e-3, 5e-3
    mesh = _revolved_mesh([(ri, 0.0), (ro, 0.0), (ro, H), (ri, H)], 1.5e-3)
    bf = mesh.boundary_facets()
    mid, n = _facet_geometry(mesh, bf)
    top = bf[(np.abs(mid[2] - H) < 1e-9) & (np.abs(n[2]) > 0.99)]
    bottom = bf[(np.abs(mid[2]) < 1e-9) & (np.abs(n[2]) > 0.99)]
    mat = Material(youngs_modulus=200e9, density=8000.0, poisson_ratio=0.0)
    k = _static_stiffness(mesh, mat, top, bottom, 100.0, 1.5e-3, "ring", 1e-3)
    area = math.pi * (ro**2 - ri**2)
    # the revolved mesh is polygonal: its area is a little below pi (ro^2 - ri^2)
    assert k.stiffness == pytest.approx(200e9 * area / H, rel=0.01)
    assert k.damping == pytest.approx(2 * math.sqrt(k.stiffness * 1e-3))


def test_seat_and_stop_of_the_documented_geometry():
    tv = thesis_values()["table_2_3"]
    seat, stop = seat_stiffness(mesh_size=1.5e-3), stop_stiffness(mesh_size=1.5e-3)
    # documented plausible geometry, not the thesis's drawing: same order of magnitude
    assert 0.5 < seat.stiffness / tv["k_seat_rigid"] < 3.0
    assert 0.5 < stop.stiffness / tv["k_stop"] < 5.0
    # eq 2.23 with the mass the thesis used (3.9 g)
    assert seat.damping == pytest.approx(2 * math.sqrt(seat.stiffness * 3.9e-3))
    # steel seat >> plastic stop, as in Table 2.3
    assert seat.stiffness > 100 * stop.stiffness
    # a stiffer material scales k linearly (linear elasticity)
    s1 = load_seat_ring()
    s2 = replace(s1, material=replace(s1.material, youngs_modulus=2 * s1.material.youngs_modulus))
    k1, k2 = seat_stiffness(s1, mesh_size=2e-3), seat_stiffness(s2, mesh_size=2e-3)
    assert k2.stiffness == pytest.approx(2 * k1.stiffness, rel=1e-6)
    assert k1.stiffness == pytest.approx(seat.stiffness, rel=0.02)  # 2 mm is within 2 % of 1.5 mm
    assert load_housing_stop().load == 125.0 and load_seat_ring().load == 600.0


def test_von_mises_closed_forms():
    lam, mu = 1.0e9, 0.5e9  # nu = 1/3
    g = np.zeros((3, 3))
    g[0, 0] = 1e-3
    g[1, 1] = g[2, 2] = -lam / (2 * (lam + mu)) * 1e-3  # uniaxial stress state
    E = mu * (3 * lam + 2 * mu) / (lam + mu)
    assert reed_stress.von_mises(g, lam, mu) == pytest.approx(E * 1e-3, rel=1e-12)
    g = np.zeros((3, 3))
    g[0, 1] = 1e-3  # simple shear: tau = mu gamma, von Mises sqrt(3) tau
    assert reed_stress.von_mises(g, lam, mu) == pytest.approx(math.sqrt(3) * mu * 1e-3, rel=1e-12)


def test_maximum_opening_stress_of_a_plain_reed_matches_beam_theory():
    reed = load_reed("stepped1")
    r = reed_stress.max_opening_stress(reed, x_stop=1.0e-3, mesh_size=1.4e-3)
    assert r.tip_deflection == 1.0e-3
    # away from the clamp singularity, bending stress M c / I governs: the maximum beyond the excluded
    # zone (s > 2 h) lies between the beam stress there and at the clamp; the clamp edge is higher (singular)
    lo = reed_stress.beam_bending_stress(reed, r.pressure, 2 * reed.thickness)
    hi = reed_stress.beam_bending_stress(reed, r.pressure, 0.0)
    assert 0.95 * lo < r.max_von_mises_away_from_clamp < 1.05 * hi
    assert r.max_von_mises >= r.max_von_mises_away_from_clamp
    # linearity: twice the opening, twice the stress
    r2 = reed_stress.max_opening_stress(reed, x_stop=2.0e-3, mesh_size=1.4e-3)
    assert r2.max_von_mises == pytest.approx(2 * r.max_von_mises, rel=1e-9)


def test_prototype_design_check_is_below_yield_and_near_the_thesis():
    reed = load_reed("prototype")
    r = reed_stress.max_opening_stress(reed, mesh_size=1.4e-3)
    thesis = thesis_values()["table_3_13"]["von_mises_max"]
    assert r.max_von_mises_away_from_clamp < reed_stress.YIELD_STRESS_DELRIN
    assert r.max_von_mises_away_from_clamp == pytest.approx(thesis, rel=0.3)
    s = reed_stress.seat_reverse_stress(reed, mesh_size=1.4e-3)
    assert s.pressure == pytest.approx(3.78e6)
    assert s.tip_deflection < 0 and abs(s.tip_deflection) < 1e-5  # supported: pushed only into the slots
    assert s.max_von_mises > 0
