"""Multi-section reeds in the Euler-Bernoulli models (lumped.reed.euler_bernoulli analytic, fea.beam) against
independent solutions written here: the Naguleswaran characteristic equation of a stepped beam
(beam functions per segment, continuity at each step) and a shooting solution of
(EI w'')'' = m omega^2 w (and = q) integrated with scipy's solve_ivp through tapers."""

import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from fea import beam
from geometry import parse_reed
from lumped.reed import euler_bernoulli as rb

MATERIAL = "[reed.material]\nyoungs_modulus = 2.9e9\ndensity = 1410.0\npoisson_ratio = 0.35\n"

# three sections with a thickness step, square tip: piecewise uniform
THREE_STEP = """
[reed]
name = "three_step"
length = 25.4e-3
thickness = 1.0e-3
""" + MATERIAL + """
[[reed.sections]]
s_end = 6.0e-3
width = 8.0e-3
thickness = 1.5e-3
[[reed.sections]]
s_end = 15.0e-3
width = 12.0e-3
[[reed.sections]]
s_end = 25.4e-3
width = 16.0e-3
thickness = 0.8e-3
"""

# three sections with a thickness step, a linear taper and a rounded tip
THREE_TAPER = (Path(__file__).resolve().parents[1] / "geometry" / "data" / "examples"
    / "reed_three_section.toml").read_text()


def _reed(text):
    return parse_reed(tomllib.loads(text))


# -- independent references ----------------------------------------------------------------


def naguleswaran_frequencies(segments, n_modes):
    """omega [rad/s] of a clamped-free chain of uniform beams (length, E I, m): zeros of the
    4n x 4n determinant of beam functions A cos + B sin + C cosh + D sinh (beta x) in each segment
    with w, w', EI w'', EI w''' continuous at each step (Naguleswaran 2002)."""
    n = len(segments)

    def det(omega):
        rows = []
        Z = np.zeros((4 * n,))

        def funcs(EI, m, x):
            b = (m * omega**2 / EI) ** 0.25
            c, s, ch, sh = np.cos(b * x), np.sin(b * x), np.cosh(b * x), np.sinh(b * x)
            return np.array([[c, s, ch, sh],                                         # w
                             [-b * s, b * c, b * sh, b * ch],                        # w'
                             [-EI * b**2 * c, -EI * b**2 * s, EI * b**2 * ch, EI * b**2 * sh],   # M
                             [EI * b**3 * s, -EI * b**3 * c, EI * b**3 * sh, EI * b**3 * ch]])   # V
        L0, EI0, m0 = segments[0]
        F = funcs(EI0, m0, 0.0)
        for k in (0, 1):                      # clamp
            r = Z.copy()
            r[0:4] = F[k]
            rows.append(r)
        for i in range(n - 1):                # continuity of w, w', M, V at step i
            Li, EIi, mi = segments[i]
            Ej, mj = segments[i + 1][1], segments[i + 1][2]
            Fi, Fj = funcs(EIi, mi, Li), funcs(Ej, mj, 0.0)
            for k in range(4):
                r = Z.copy()
                r[4 * i:4 * i + 4] = Fi[k]
                r[4 * i + 4:4 * i + 8] = -Fj[k]
                rows.append(r)
        Ln, EIn, mn = segments[-1]
        F = funcs(EIn, mn, Ln)
        for k in (2, 3):                      # free tip
            r = Z.copy()
            r[4 * n - 4:] = F[k]
            rows.append(r)
        A = np.array(rows)
        A /= np.max(np.abs(A), axis=0)          # column scaling (cosh grows)
        return np.linalg.det(A)

    roots, w0 = [], 1.0
    f0 = det(w0)
    w = w0
    while len(roots) < n_modes:
        w1 = w * 1.003
        f1 = det(w1)
        if np.sign(f1) != np.sign(f0):
            roots.append(brentq(det, w, w1, xtol=1e-12, rtol=1e-14))
        w, f0 = w1, f1
    return np.array(roots)


def _segments(reed):
    """(length, E I, m) of each piece from the reed's own dimensions (rectangles, no grooves)."""
    E, rho = reed.material.youngs_modulus, reed.material.density
    return [(p.s1 - p.s0, E * p.w0 * p.h**3 / 12, rho * p.w0 * p.h) for p in reed.pieces()]


def _shoot(reed, omega=None, load=None):
    """State (w, theta, M, V) at the tip of the two homogeneous solutions started at the clamp with
    (M, V) = (1, 0) and (0, 1), and of the particular one under ``load`` q(s) [N/m] (solve_ivp, DOP853)."""
    E, rho = reed.material.youngs_modulus, reed.material.density

    def EI(s):
        return E * reed.width(s) * reed.thickness_profile(s) ** 3 / 12

    def m(s):
        return rho * reed.width(s) * reed.thickness_profile(s)

    def rhs(s, y, hom):
        w, th, M, V = y
        q = 0.0 if (hom or load is None) else load(s)
        dyn = 0.0 if omega is None else m(s) * omega**2 * w
        return [th, M / EI(s), V, dyn + q]

    # integrate piece by piece (EI and m jump at the section ends); stop just short of a closing tip
    brk = list(reed.breakpoints())
    brk[-1] = reed.length * (1 - 1e-12)
    out = []
    for y0, hom in (([0, 0, 1, 0], True), ([0, 0, 0, 1], True), ([0, 0, 0, 0], False)):
        y = np.array(y0, dtype=float)
        for a, b in zip(brk[:-1], brk[1:]):
            y = solve_ivp(rhs, (a, b), y, args=(hom,), method="DOP853", rtol=1e-10, atol=1e-30).y[:, -1]
        out.append(y)
    return out


def shooting_frequencies(reed, n_modes, guesses):
    """omega [rad/s] where the tip conditions M = V = 0 admit a solution (root of a 2 x 2 determinant)."""
    def det(w):
        a, b, _ = _shoot(reed, omega=w)
        return a[2] * b[3] - a[3] * b[2]

    return np.array([brentq(det, 0.999 * g, 1.001 * g, xtol=1e-9 * g) for g in guesses[:n_modes]])


def shooting_stiffness(reed):
    """kappa = p / w(L) [Pa/m] under the uniform pressure p = 1 Pa, q(s) = W(s)."""
    a, b, c = _shoot(reed, load=reed.width)
    # (M0, V0) such that M(L) = V(L) = 0
    A = np.array([[a[2], b[2]], [a[3], b[3]]])
    M0, V0 = np.linalg.solve(A, -c[2:])
    return 1.0 / (c[0] + M0 * a[0] + V0 * b[0])


# -- tests ----------------------------------------------------------------------------------


def test_three_step_reed_against_the_naguleswaran_determinant():
    """Piecewise uniform (thickness and width steps): analytic = beam FE within 0.05 %, both = the
    characteristic equation within 0.1 % (the analytic model is exact: 1e-9)."""
    reed = _reed(THREE_STEP)
    ref = naguleswaran_frequencies(_segments(reed), 4)
    an = rb.modes(reed, 4).omega
    fe = beam.modes(reed, 4).omega
    assert an == pytest.approx(ref, rel=1e-9)
    assert fe == pytest.approx(an, rel=5e-4)
    assert fe == pytest.approx(ref, rel=1e-3)
    assert rb.natural_frequency(reed) == pytest.approx(ref[0], rel=1e-9)
    # kappa: the shooting solution, independent of both
    k = shooting_stiffness(reed)
    assert rb.exact_stiffness(reed) == pytest.approx(k, rel=1e-8)
    assert beam.solve(reed).kappa == pytest.approx(k, rel=5e-4)


def test_three_section_reed_with_taper_and_rounded_tip():
    """Thickness step, width step, taper and a rounded tip: analytic and beam FE against shooting."""
    reed = _reed(THREE_TAPER)
    an = rb.modes(reed, 3)
    props = rb.reed_properties(reed)
    fe = beam.solve(reed, n_modes=3)
    ref = shooting_frequencies(reed, 3, an.omega)
    k = shooting_stiffness(reed)
    assert an.omega == pytest.approx(ref, rel=1e-6)
    assert props.omega_n == pytest.approx(ref[0], rel=1e-6) and props.kappa == pytest.approx(k, rel=1e-6)
    assert fe.omega == pytest.approx(an.omega, rel=5e-4) and fe.kappa == pytest.approx(props.kappa, rel=5e-4)
    assert fe.omega == pytest.approx(ref, rel=1e-3) and fe.kappa == pytest.approx(k, rel=1e-3)
    assert an.labels == ["bending 1", "bending 2", "bending 3"]
    # the n-th mode has n - 1 nodes
    for j in range(3):
        sh = an.shapes[:, j]
        assert np.sum(np.diff(np.sign(sh[np.abs(sh) > 1e-3])) != 0) == j


def test_one_step_form_and_its_sections_give_identical_results():
    """The one-step preset and the same outline as two sections: analytic and beam agree to round-off."""
    from geometry import load_reed

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
    a, b = rb.reed_properties(one), rb.reed_properties(two)
    for q in ("omega_n", "kappa", "gamma1", "gamma2", "gamma3", "h_eff"):
        assert getattr(b, q) == pytest.approx(getattr(a, q), rel=1e-12)
    fa, fb = beam.solve(one), beam.solve(two)
    # the same mesh up to the step node (R_l L is 1 ulp off s_end): round-off of a 200-element beam, whose
    # lowest eigenvalue may carry up to eps lambda_max / lambda_1 = 1.3e-4 (1.6e-8 seen between two machines' BLAS)
    assert fb.omega_n == pytest.approx(fa.omega_n, rel=1e-6) and fb.kappa == pytest.approx(fa.kappa, rel=1e-6)


def test_higher_analytic_modes_of_the_uniform_reed_are_the_classical_roots():
    """cos a cosh a + 1 = 0 (eq 3.2): alpha_n = 1.8751, 4.6941, 7.8548, 10.9955, 14.1372, 17.2788."""
    from geometry import load_reed

    reed = load_reed("uniform")
    m = reed.material
    base = reed.thickness / reed.length**2 * np.sqrt(m.youngs_modulus / (12 * m.density))
    alpha = np.sqrt(rb.modes(reed, 6).omega / base)
    assert alpha == pytest.approx([1.875104, 4.694091, 7.854757, 10.995541, 14.137168, 17.278760], abs=2e-6)
    # a taper (no exact determinant): the spectral eigenproblem converges with the node count
    tapered = _reed(THREE_TAPER)
    assert rb.modes(tapered, 6).omega == pytest.approx(rb.modes(tapered, 6, nodes=48).omega, rel=1e-7)


def test_bad_section_on_the_command_line_is_one_line(cli, tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text(THREE_TAPER.replace("taper_to = 12.0e-3", "taper_to = -12.0e-3"))
    rc, out, err = cli("reed", f, "--fidelity", "beam")
    assert rc == 2 and out == "" and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1 and "reed.sections[2].taper_to" in err
    good = tmp_path / "good.toml"
    good.write_text(THREE_TAPER)
    rc, out, err, obj = cli("reed", good, "--modes", "2", "--plot", tmp_path / "p.png", "--json")
    assert rc == 0, err
    assert obj["mode_kinds"] == ["bending 1", "bending 2"] and (tmp_path / "p.png").stat().st_size > 10_000


from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@st.composite
def sectioned_reeds(draw):
    """Random valid multi-section reeds (1-4 sections, thickness steps, tapers, rounded tips)."""
    n = draw(st.integers(1, 4))
    L = draw(st.floats(5e-3, 60e-3))
    ends = sorted(draw(st.lists(st.floats(0.1, 0.9), min_size=n - 1, max_size=n - 1, unique=True)))
    secs = []
    for k, e in enumerate(ends + [1.0]):
        sec = {"s_end": e * L if k < n - 1 else L, "width": draw(st.floats(2e-3, 20e-3))}
        if draw(st.booleans()):
            sec["thickness"] = draw(st.floats(0.2e-3, min(2e-3, 0.2 * L)))  # a reed, not a block (t/L <= 0.25)
        if draw(st.booleans()):
            sec["taper_to"] = sec["width"] * draw(st.floats(0.5, 1.5))
        secs.append(sec)
    last = secs[-1].get("taper_to", secs[-1]["width"])
    start_last = ends[-1] * L if n > 1 else 0.0
    R = min(last / 2, L - start_last) * draw(st.sampled_from([0.0, 0.5, 0.9]))
    d = {"reed": {"length": L, "thickness": 1e-3, "tip_radius": R, "sections": secs,
                  "material": {"youngs_modulus": 2e11, "density": 7800.0, "poisson_ratio": 0.3}}}
    return parse_reed(d)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(sectioned_reeds())
def test_random_sectioned_reeds_analytic_equals_beam_fe(reed):
    """Same theory, independent numerics (spectral quadrature vs Hermite FE): 0.1 % on any profile."""
    a = rb.reed_properties(reed)
    b = beam.reed_properties(reed)
    assert a.omega_n > 0 and a.kappa > 0 and a.h_eff > 0
    assert b.omega_n == pytest.approx(a.omega_n, rel=1e-3) and b.kappa == pytest.approx(a.kappa, rel=1e-3)
    assert b.gamma1 == pytest.approx(a.gamma1, rel=1e-3)
    assert np.all(np.diff(rb.modes(reed, 3).omega) > 0)
