"""A thickness taper (``[[reed.sections]] thickness_to``), one change in the geometry, read by every fidelity.

The references are independent of the code: a cantilever of uniform width W and thickness h(s) varying
linearly from h0 at the clamp to h1 at the tip, under a uniform pressure p, deflects at its tip by the unit-load
integral delta = int_0^L M(s) m(s) / (E I(s)) ds = int_0^L 6 p (L - s)^3 / (E h(s)^3) ds (M = p W (L - s)^2 / 2,
m = L - s, I = W h^3 / 12), so kappa = p / delta (the stiffness of eq 3.30), integrated here by scipy's quad;
its volume is W L (h0 + h1) / 2. The exact Euler-Bernoulli model and the FE beam must give kappa to their own
accuracy; the plate and the solid carry Poisson's and the width's effects, which a taper does not change to
first order, so their kappa of the tapered reed over that of the uniform one must equal the closed form's ratio.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from scipy.integrate import quad

from geometry import InputError, parse_reed, reed_to_toml

E, RHO, NU = 2.9e9, 1410.0, 0.35
L, W, H0, H1 = 25.4e-3, 12.0e-3, 1.5e-3, 1.0e-3


def _reed(h1: float | None, tip_radius: float = 0.0, extra: str = ""):
    taper = "" if h1 is None else f"thickness_to = {h1!r}\n"
    return parse_reed(tomllib.loads(f"""
[reed]
name = "taper"
length = {L!r}
thickness = {H0!r}
tip_radius = {tip_radius!r}
[reed.material]
youngs_modulus = {E!r}
density = {RHO!r}
poisson_ratio = {NU!r}
[[reed.sections]]
s_end = {L!r}
width = {W!r}
{taper}{extra}"""))


def kappa_closed_form(h0: float, h1: float) -> float:
    """p / delta_tip [Pa/m] of the linearly tapered cantilever under a uniform pressure (module docstring)."""
    def h(s):
        return h0 + (h1 - h0) * s / L
    delta, _ = quad(lambda s: 6.0 * (L - s) ** 3 / (E * h(s) ** 3), 0.0, L, epsabs=0.0, epsrel=1e-13)
    return 1.0 / delta


def test_the_geometry_reads_the_taper():
    r = _reed(H1)
    assert r.has_thickness_taper and not r.is_piecewise_uniform and r.has_thickness_steps
    s = np.linspace(0.0, L, 7)
    assert np.allclose(r.thickness_profile(s), H0 + (H1 - H0) * s / L, rtol=1e-14)
    assert r.mass == pytest.approx(RHO * W * L * (H0 + H1) / 2, rel=1e-13)
    assert r.max_thickness == H0 and r.min_thickness == H1
    assert parse_reed(tomllib.loads(reed_to_toml(r))) == r                        # written and read back
    # a rounded tip: the corners cut (2 - pi/2) R^2 h at the tip's start plus the taper's R^3 h' / 3
    R = W / 2
    rt = _reed(H1, tip_radius=R)
    cut, _ = quad(lambda s: 2 * (R - math.sqrt(max(R * R - (s - (L - R)) ** 2, 0.0))) * (H0 + (H1 - H0) * s / L),
                  L - R, L, epsabs=0.0, epsrel=1e-12)
    assert rt.mass == pytest.approx(RHO * (W * L * (H0 + H1) / 2 - cut), rel=1e-10)


def test_a_taper_is_checked_like_a_thickness():
    with pytest.raises(InputError, match=r"reed.sections\[0\].thickness_to"):
        _reed(-1e-3)
    with pytest.raises(InputError, match=r"reed.sections\[0\].thickness_to"):
        _reed(20e-3)                                    # thicker than a quarter of the length: mm typed as m?


def test_the_exact_euler_bernoulli_model_and_the_fe_beam_against_the_closed_form():
    from fea import beam
    from lumped.reed.fidelities import reed_properties

    r = _reed(H1)
    k = kappa_closed_form(H0, H1)
    assert reed_properties(r, "analytic").kappa == pytest.approx(k, rel=1e-7)
    assert beam.reed_properties(r).kappa == pytest.approx(k, rel=2e-3)
    # the beam converges to it: halving the elements quarters the error at least
    e1 = abs(beam.reed_properties(r, mesh_size=L / 10).kappa / k - 1)
    e2 = abs(beam.reed_properties(r, mesh_size=L / 20).kappa / k - 1)
    assert e2 < e1 / 3


@pytest.mark.parametrize("fidelity, rel", [("plate", 0.02), ("solid", 0.03)])
def test_the_plate_and_the_solid_follow_the_taper(fidelity, rel):
    """kappa(taper) / kappa(uniform h0): the closed form's ratio (0.795) within 2 % (plate) and 3 % (solid), far
    from that of a reed that ignored the taper (1)."""
    from fea.fidelities import get

    props = get(fidelity, "fidelity").reed_properties
    size = L / 16
    ratio = props(_reed(H1), mesh_size=size).kappa / props(_reed(None), mesh_size=size).kappa
    expected = kappa_closed_form(H0, H1) / kappa_closed_form(H0, H0)
    assert expected == pytest.approx(0.795, abs=0.005)
    assert ratio == pytest.approx(expected, rel=rel), ratio


def test_the_solid_refuses_a_taper_it_cannot_map():
    """Another piece's thickness inside the taper's thickness range would cut its stretched node planes: refused,
    naming the taper's key."""
    from fea.mesh import solid_mesh

    r = parse_reed(tomllib.loads(f"""
[reed]
length = {L!r}
thickness = {H0!r}
[reed.material]
youngs_modulus = {E!r}
density = {RHO!r}
poisson_ratio = {NU!r}
[[reed.sections]]
s_end = 5.0e-3
width = {W!r}
thickness = 1.2e-3
[[reed.sections]]
s_end = {L!r}
width = {W!r}
thickness_to = {H1!r}
"""))
    with pytest.raises(InputError, match=r"reed.sections\[1\].thickness_to"):
        solid_mesh(r, L / 8)
