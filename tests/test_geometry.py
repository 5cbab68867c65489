"""Reed geometry: outline, areas, sections, presets and validation of user files."""

import math
import tomllib
from pathlib import Path

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


# -- multi-section reeds ([[reed.sections]], CONTRACT "Multi-section reeds") ----------------

# the shipped example reed: thickness step, width step, taper, rounded tip
SECTIONED = (Path(__file__).resolve().parents[1] / "geometry" / "data" / "examples"
    / "reed_three_section.toml").read_text()

ONE_STEP_AS_SECTIONS = """
[reed]
length = 25.4e-3
thickness = 1.35e-3
tip_radius = 7.9375e-3
[reed.material]
youngs_modulus = 2.9e9
density = 1410.0
poisson_ratio = 0.35
[[reed.sections]]
s_end = 4.7625e-3
width = 7.9375e-3
[[reed.sections]]
s_end = 25.4e-3
width = 15.875e-3
"""


def test_one_step_reed_as_sections_is_the_same_outline():
    """stepped #2 written as two sections: the same width, sections, areas and mass (to round-off)."""
    a, b = load_reed("stepped2"), parse_reed(tomllib.loads(ONE_STEP_AS_SECTIONS))
    s = np.linspace(0.0, a.length, 2001)
    s = s[np.min(np.abs(s[:, None] - a.breakpoints()[None, :]), axis=1) > 1e-12]  # R_l L is 1 ulp off s_end
    assert np.array_equal(a.width(s), b.width(s))
    A1, I1 = a.section(s)
    A2, I2 = b.section(s)
    assert np.array_equal(A1, A2) and np.array_equal(I1, I2)
    assert b.face_area == pytest.approx(a.face_area, rel=1e-14) and b.mass == pytest.approx(a.mass, rel=1e-14)
    assert np.allclose(a.breakpoints(), b.breakpoints(), rtol=0, atol=1e-15)
    # the one-step fields of a sectioned reed hold sensible values (documented on Reed)
    assert (b.width_root, b.width_tip, b.thickness) == (a.width_root, a.width_tip, a.thickness)
    assert b.step_location == pytest.approx(a.step_location, rel=1e-14)


def test_sectioned_profile_by_independent_integration():
    """Face area, mass and h(s) of a three-section reed (thickness step, taper, rounded tip)."""
    r = parse_reed(tomllib.loads(SECTIONED))
    assert [p.h for p in r.pieces()] == [1.5e-3, 1.0e-3, 1.0e-3]
    assert r.width(3e-3) == pytest.approx(8e-3) and r.width(10e-3) == pytest.approx(12e-3)
    assert r.width(15e-3 + 1e-9) == pytest.approx(16e-3, rel=1e-6)      # the taper starts at 16 mm ...
    assert r.width(20.4e-3) == pytest.approx(16e-3 - 4e-3 * 5.4 / 10.4)  # ... and runs to 12 mm
    assert r.width(r.length) == pytest.approx(12e-3 - 2 * 5e-3)        # rounded corners of radius 5 mm
    assert r.thickness_profile(5.9e-3) == 1.5e-3 and r.thickness_profile(6.1e-3) == 1.0e-3
    pts = r.breakpoints()
    area = sum(quad(r.width, a, b, limit=500, epsabs=0, epsrel=1e-12)[0] for a, b in zip(pts[:-1], pts[1:]))
    assert r.face_area == pytest.approx(area, rel=1e-10)
    vol = sum(quad(lambda s: float(r.section(s)[0]), a, b, limit=500, epsabs=0, epsrel=1e-12)[0]
              for a, b in zip(pts[:-1], pts[1:]))
    assert r.mass == pytest.approx(r.material.density * vol, rel=1e-10)
    assert shoelace(r.outline(n_arc=2000)) == pytest.approx(r.face_area, rel=1e-5)
    assert r.is_tapered and r.has_thickness_steps and not r.is_piecewise_uniform
    assert (r.width_root, r.width_tip, r.max_thickness, r.min_thickness) == (8e-3, 12e-3, 1.5e-3, 1.0e-3)


def test_sectioned_toml_round_trip():
    r = parse_reed(tomllib.loads(SECTIONED))
    text = reed_to_toml(r)
    assert "[[reed.sections]]" in text and "width_root" not in text
    assert parse_reed(tomllib.loads(text)) == r


def _sec(edit):
    d = tomllib.loads(SECTIONED)
    edit(d["reed"])
    return d


@pytest.mark.parametrize(
    "edit,field",
    [
        (lambda r: r["sections"][1].update(widht=1e-3), "reed.sections[1].widht"),
        (lambda r: r["sections"][1].update(s_end=5e-3), "reed.sections[1].s_end"),
        (lambda r: r["sections"][2].update(s_end=25.0e-3), "reed.sections[2].s_end"),
        (lambda r: r["sections"][1].update(s_end=25.4e-3), "reed.sections[1].s_end"),
        (lambda r: r["sections"][2].update(width=-1e-3), "reed.sections[2].width"),
        (lambda r: r["sections"][0].update(thickness=0.0), "reed.sections[0].thickness"),
        (lambda r: r["sections"][2].update(taper_to="narrow"), "reed.sections[2].taper_to"),
        (lambda r: r["sections"][0].pop("width"), "reed.sections[0].width"),
        (lambda r: r.update(width_tip=16e-3), "reed.width_tip"),
        (lambda r: r.update(step_fraction=0.2), "reed.step_fraction"),
        (lambda r: r.update(tip_radius=6.5e-3), "reed.tip_radius"),          # > half of the 12 mm tip
        (lambda r: r.update(tip_radius=6.0e-3, sections=r["sections"][:2] + [
            {"s_end": 25.4e-3, "width": 12e-3}]) or r["sections"][1].update(s_end=20e-3), "reed.tip_radius"),
        (lambda r: r.update(sections=[]), "reed.sections"),
        (lambda r: r.pop("thickness"), "reed.thickness"),
    ],
)
def test_bad_sections_are_named(edit, field):
    with pytest.raises(InputError) as exc:
        parse_reed(_sec(edit))
    assert exc.value.field == field


def test_grooves_must_be_shallower_than_the_local_thickness():
    base = SECTIONED + "[[reed.grooves]]\ns_start = {a}\ns_end = {b}\ny_center = 0.0\nwidth = 2e-3\ndepth = 1.2e-3\n"
    parse_reed(tomllib.loads(base.format(a=1e-3, b=5e-3)))     # 1.2 mm deep in the 1.5 mm root: fine
    with pytest.raises(InputError) as exc:                       # reaching the 1 mm section: not
        parse_reed(tomllib.loads(base.format(a=1e-3, b=8e-3)))
    assert exc.value.field == "reed.grooves[0].depth" and "sections[1]" in exc.value.message
    with pytest.raises(InputError) as exc:                       # leaving the 8 mm wide root
        parse_reed(tomllib.loads(base.format(a=1e-3, b=5e-3).replace("y_center = 0.0", "y_center = 3.5e-3")))
    assert exc.value.field == "reed.grooves[0].y_center"


def test_every_section_may_carry_its_thickness():
    d = tomllib.loads(SECTIONED)
    d["reed"].pop("thickness")
    for sec, h in zip(d["reed"]["sections"], (1.5e-3, 1.2e-3, 1.0e-3)):
        sec["thickness"] = h
    r = parse_reed(d)
    assert r.thickness == 1.5e-3 and [p.h for p in r.pieces()] == [1.5e-3, 1.2e-3, 1.0e-3]


@pytest.mark.parametrize("name", ["fv16", "three_section"])
def test_example_geometry_files_parse(name):
    from importlib import resources

    path = resources.files("geometry").joinpath(f"data/examples/reed_{name}.toml")
    r = load_reed(str(path))
    assert r.name == name and r.mass > 0
    assert parse_reed(tomllib.loads(reed_to_toml(r))) == r
