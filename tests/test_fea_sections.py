"""Multi-section reeds in the plate and solid models: meshes with thickness steps and tapers, limits
that must hold exactly, and the one-step form giving the same results as its sections."""

import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fea import plate, solid
from fea.mesh import face_mesh, solid_mesh
from fea.solid import _scalar_basis, pressure_load
from geometry import Material, load_reed, parse_reed
from lumped.reed import euler_bernoulli as rb

MATERIAL = "[reed.material]\nyoungs_modulus = 2.9e9\ndensity = 1410.0\npoisson_ratio = 0.35\n"
# the shipped example reed: thickness step, width step, taper, rounded tip
SECTIONS = (Path(__file__).resolve().parents[1] / "geometry" / "data" / "examples"
    / "reed_three_section.toml").read_text()
# constant width, two thickness steps, square tip
THICKNESS_STEPS = """
[reed]
length = 30.0e-3
thickness = 1.0e-3
""" + MATERIAL + """
[[reed.sections]]
s_end = 8.0e-3
width = 6.0e-3
thickness = 1.4e-3
[[reed.sections]]
s_end = 20.0e-3
width = 6.0e-3
[[reed.sections]]
s_end = 30.0e-3
width = 6.0e-3
thickness = 0.7e-3
"""


def _reed(text):
    return parse_reed(tomllib.loads(text))


@pytest.mark.parametrize("half", [False, True])
def test_thickness_steps_are_mesh_lines_and_real_steps(half):
    reed = _reed(SECTIONS)
    fm = face_mesh(reed, 1.5e-3, quad=True, half=half)
    p, t = fm.mesh.p, fm.mesh.t
    lo, hi = p[0, t].min(axis=0), p[0, t].max(axis=0)
    assert not np.any((lo < 6e-3 - 1e-12) & (hi > 6e-3 + 1e-12))   # no quad straddles the step at 6 mm
    cen = p[:, t].mean(axis=1)
    assert np.array_equal(fm.thickness, reed.thickness_profile(cen[0]))
    sm = solid_mesh(reed, 1.5e-3, half=half)
    basis = _scalar_basis(sm.mesh)
    factor = 0.5 if half else 1.0
    # volume: the thick root really is thicker (rho V = mass, sum of h x area per section)
    assert basis.dx.sum() == pytest.approx(factor * reed.mass / reed.material.density, rel=2e-3)
    assert sm.mesh.p[2].max() == pytest.approx(1.5e-3)
    assert np.all(sm.mesh.p[2][sm.mesh.p[0] > 6e-3 + 1e-9] <= 1.0e-3 + 1e-15)
    # the pressure acts on the flat upstream face only: its resultant is p A_face along z
    f = pressure_load(sm, basis)
    assert f[2::3].sum() == pytest.approx(factor * reed.face_area, rel=2e-3)
    assert abs(f[0::3].sum()) < 1e-9 * reed.face_area


def test_plate_with_thickness_steps_and_nu_zero_is_the_beam():
    """nu = 0, constant width: w(s) independent of y satisfies the plate equations and free edges
    exactly, so the plate with thickness per element equals exact E-B with EI(s) stepping."""
    reed = _reed(THICKNESS_STEPS)
    reed = replace(reed, material=Material(2.9e9, 1410.0, 0.0))
    p = plate.solve(reed, 2e-3)
    a = rb.reed_properties(reed)
    assert p.kappa == pytest.approx(a.kappa, rel=1e-4)
    assert p.omega_n == pytest.approx(a.omega_n, rel=1e-4)
    assert p.omega[p.labels.index("bending 2")] == pytest.approx(rb.modes(reed, 2).omega[1], rel=1e-4)


def test_solid_with_thickness_steps_is_softer_than_the_beam_by_the_step_corners():
    """nu = 0: the uniform bar is E-B to 0.07 % (shear), but behind a one-sided thickness step the
    corner of the thicker section carries little stress over about the step height, which E-B
    ignores: extending each thinner section by its step height into the thicker one adds 2.8 %
    to the E-B tip deflection of this reed (integral of (L - s) M / EI); the solid is 1.9-2.2 %
    softer in kappa (1.5 and 0.75 mm meshes) and about half that in omega_n."""
    reed = replace(_reed(THICKNESS_STEPS), material=Material(2.9e9, 1410.0, 0.0))
    s = solid.solve(reed, 1.5e-3)
    a = rb.reed_properties(reed)
    assert 0.965 < s.kappa / a.kappa < 0.99
    assert 0.98 < s.omega_n / a.omega_n < 0.995
    uniform = replace(reed, sections=(), width_root=6e-3, width_tip=6e-3, step_fraction=0.0)
    su, au = solid.solve(uniform, 1.5e-3), rb.reed_properties(uniform)
    assert su.kappa == pytest.approx(au.kappa, rel=2e-3)


def test_one_step_form_and_its_sections_give_the_same_fea():
    one = load_reed("stepped2")
    two = _reed("""
[reed]
length = 25.4e-3
thickness = 1.35e-3
tip_radius = 7.9375e-3
""" + MATERIAL + """
[[reed.sections]]
s_end = 4.7625e-3
width = 7.9375e-3
[[reed.sections]]
s_end = 25.4e-3
width = 15.875e-3
""")
    for mod in (plate, solid):
        a, b = mod.solve(one, 2.5e-3), mod.solve(two, 2.5e-3)
        assert b.dofs == a.dofs
        assert b.omega_n == pytest.approx(a.omega_n, rel=1e-8) and b.kappa == pytest.approx(a.kappa, rel=1e-8)


def test_every_fidelity_runs_on_a_three_section_reed():
    """Thickness step, width step, taper, rounded tip: the theories agree as for the thesis reeds."""
    reed = _reed(SECTIONS)
    a = rb.reed_properties(reed)
    p = plate.solve(reed, 2.5e-3)
    s = solid.solve(reed, 2.5e-3)
    for r in (p, s):
        assert r.omega_n == pytest.approx(a.omega_n, rel=0.04)
        assert r.kappa == pytest.approx(a.kappa, rel=0.06)
        assert r.labels[0] == "bending 1"
