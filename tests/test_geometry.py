"""Reed geometry: outline, areas, sections, presets and validation of user files."""

import math
import tomllib

import numpy as np
import pytest
from scipy.integrate import quad

from geometry import PRESETS, InputError, load_reed, parse_reed, reed_to_toml

INCH = 25.4e-3


def shoelace(poly):
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


@pytest.mark.parametrize("name", PRESETS)
def test_face_area_matches_outline_and_width_integral(name):
    reed = load_reed(name)
    pts = reed.breakpoints()
    integral = sum(quad(reed.width, a, b, limit=200)[0] for a, b in zip(pts[:-1], pts[1:]))
    assert integral == pytest.approx(reed.face_area, rel=1e-7)  # quad vs sqrt end singularity
    # polygon with 2000 arc points converges to the exact area from below
    assert shoelace(reed.outline(n_arc=2000)) == pytest.approx(reed.face_area, rel=1e-6)


def test_presets_are_exact_inch_values():
    r = load_reed("prototype")
    assert r.length == pytest.approx(INCH, rel=1e-12)
    assert r.width_root == pytest.approx(5 / 16 * INCH, rel=1e-12)
    assert r.width_tip == pytest.approx(5 / 8 * INCH, rel=1e-12)
    assert r.tip_radius == pytest.approx(5 / 16 * INCH, rel=1e-12)
    assert r.grooves[0].depth == pytest.approx(0.020 * INCH, rel=1e-12)
    assert r.grooves[0].width == pytest.approx(INCH / 16, rel=1e-12)
    # Table 3.13 A2 = 338.4 mm^2 is the face area of the round-tipped reed
    assert load_reed("stepped2").face_area == pytest.approx(338.4e-6, abs=0.05e-6)


def test_width_profile_of_stepped_round_tip():
    r = load_reed("stepped2")
    assert r.width(0.5 * r.step_location) == pytest.approx(r.width_root)
    assert r.width(r.step_location + 1e-6) == pytest.approx(r.width_tip)
    assert r.width(r.length) == pytest.approx(0.0, abs=1e-12)
    d = 0.6 * r.tip_radius
    assert r.width(r.tip_start + d) == pytest.approx(2 * math.sqrt(r.tip_radius**2 - d**2))


def test_ungrooved_section_is_rectangle():
    r = load_reed("stepped1")
    A, I = r.section(0.01)
    assert A == pytest.approx(r.width_tip * r.thickness)
    assert I == pytest.approx(r.width_tip * r.thickness**3 / 12)


def test_grooved_section_by_parallel_axis_theorem():
    r = load_reed("prototype")
    s = 0.010  # four 1/16 in pockets across the 5/8 in section
    A, I = r.section(s)
    h, W, d, w = r.thickness, r.width_tip, r.grooves[0].depth, 4 * r.grooves[0].width
    # independent: strip the section into a full-width layer d..h and 'lands' 0..d
    parts = [(W * (h - d), (h + d) / 2, W * (h - d) ** 3 / 12), ((W - w) * d, d / 2, (W - w) * d**3 / 12)]
    a = sum(p[0] for p in parts)
    zc = sum(p[0] * p[1] for p in parts) / a
    assert A == pytest.approx(a)
    assert I == pytest.approx(sum(p[2] + p[0] * (p[1] - zc) ** 2 for p in parts))
    assert r.local_thickness(s, r.grooves[1].y_center) == pytest.approx(h - d)
    assert r.local_thickness(s, 0.0) == pytest.approx(h)


def test_toml_round_trip():
    for name in PRESETS:
        r = load_reed(name)
        assert parse_reed(tomllib.loads(reed_to_toml(r))) == r


GOOD = """
[reed]
length = 25.4e-3
thickness = 1.35e-3
width_root = 7.94e-3
width_tip = 15.9e-3
step_fraction = 0.1875
tip_radius = 7.94e-3
[reed.material]
youngs_modulus = 2.9e9
density = 1410.0
poisson_ratio = 0.35
"""


@pytest.mark.parametrize(
    "old,new,field",
    [
        ("thickness = 1.35e-3", "thickness = -1.35e-3", "reed.thickness"),
        ("tip_radius = 7.94e-3", "tip_radius = 9.0e-3", "reed.tip_radius"),
        ("step_fraction = 0.1875", "step_fraction = 1.0", "reed.step_fraction"),
        ("density = 1410.0", 'density = "heavy"', "reed.material.density"),
        ("poisson_ratio = 0.35", "poisson_ratio = 0.6", "reed.material.poisson_ratio"),
        ("length = 25.4e-3", "length = nan", "reed.length"),
        ("length = 25.4e-3", "lenght = 25.4e-3", "reed.lenght"),
    ],
)
def test_bad_fields_are_named(old, new, field):
    with pytest.raises(InputError) as exc:
        parse_reed(tomllib.loads(GOOD.replace(old, new)))
    assert exc.value.field == field


@pytest.mark.parametrize(
    "groove,field",
    [
        ("s_start = 3e-3\ns_end = 20e-3\ny_center = 0.0\nwidth = 1e-3\ndepth = 2e-3", "reed.grooves[0].depth"),
        ("s_start = 3e-3\ns_end = 30e-3\ny_center = 0.0\nwidth = 1e-3\ndepth = 0.5e-3", "reed.grooves[0].s_end"),
        ("s_start = 1e-3\ns_end = 10e-3\ny_center = 3.5e-3\nwidth = 1e-3\ndepth = 0.5e-3", "reed.grooves[0].y_center"),
        ("s_start = 5e-3\ns_end = 4e-3\ny_center = 0.0\nwidth = 1e-3\ndepth = 0.5e-3", "reed.grooves[0].s_end"),
    ],
)
def test_bad_grooves_are_named(groove, field):
    with pytest.raises(InputError) as exc:
        parse_reed(tomllib.loads(GOOD + "[[reed.grooves]]\n" + groove))
    assert exc.value.field == field


def test_missing_file_is_named(tmp_path):
    with pytest.raises(InputError) as exc:
        load_reed(tmp_path / "nope.toml")
    assert "nope.toml" in exc.value.field
    bad = tmp_path / "bad.toml"
    bad.write_text("[reed\nlength=")
    with pytest.raises(InputError, match="not valid TOML"):
        load_reed(bad)
