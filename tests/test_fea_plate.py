"""Kirchhoff plate (fea.plate, Argyris) against the beam and cylindrical-bending limits."""

from dataclasses import replace

import numpy as np
import pytest

from fea import beam, plate
from geometry import Material, Reed, load_reed


def _rect(length, width, nu, thickness=1.35e-3):
    return Reed(length=length, thickness=thickness, width_root=width, width_tip=width, step_fraction=0.0,
                tip_radius=0.0, material=Material(2.9e9, 1410.0, nu), name="rect")


def test_uniform_reed_with_nu_zero_is_exactly_a_beam():
    """With nu = 0 the 1-D beam deflection satisfies the plate equations and free-edge conditions."""
    reed = replace(load_reed("uniform"), material=Material(2.9e9, 1410.0, 0.0))
    p, b = plate.solve(reed, 3e-3), beam.solve(reed)
    assert p.kappa == pytest.approx(b.kappa, rel=1e-4)
    assert p.omega_n == pytest.approx(b.omega_n, rel=1e-4)
    assert np.max(np.abs(p.psi_static - np.interp(p.s, b.s, b.psi_static))) < 1e-4


def test_narrow_plate_tends_to_the_beam():
    reed = _rect(40e-3, 2e-3, 0.35, thickness=0.5e-3)
    p, b = plate.solve(reed, 1e-3), beam.solve(reed)
    assert p.kappa == pytest.approx(b.kappa, rel=0.01)
    assert p.omega_n == pytest.approx(b.omega_n, rel=0.01)


def test_wide_plate_tends_to_cylindrical_bending():
    """W >> L: the centre strip bends with D = E h^3 / 12 (1 - nu^2): kappa = 8 D / L^4 per unit width."""
    nu = 0.35
    reed = _rect(10e-3, 100e-3, nu)
    p = plate.solve(reed, 2.5e-3)
    E, h, L = 2.9e9, reed.thickness, reed.length
    assert p.kappa == pytest.approx(8 * E * h**3 / (12 * (1 - nu**2)) / L**4, rel=0.01)


def test_plate_modes_are_classified_and_converge_from_above():
    reed = load_reed("uniform")
    rs = [plate.solve(reed, h) for h in (4e-3, 3e-3, 2e-3)]
    assert rs[-1].kinds[:3] == ["bending", "torsion", "bending"]
    w = [r.omega_n for r in rs]
    assert w[0] >= w[1] >= w[2]  # conforming (C1) elements: Rayleigh-Ritz upper bounds
    # and the plate lies above the beam (anticlastic curvature restrained), below the cylindrical limit
    b = beam.solve(reed).omega_n
    assert b < w[-1] < b / np.sqrt(1 - 0.35**2)


def test_grooves_soften_the_plate():
    proto, s2 = plate.solve(load_reed("prototype")), plate.solve(load_reed("stepped2"))
    assert proto.kappa < s2.kappa
