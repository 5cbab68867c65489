"""Fluid stiction that lets go: the squeeze film of eqs 2.7-2.18 with its pressure bounded at cavitation.

The film force of ``lumped.valves.disc.film_force`` is checked against an independent solution of
the Reynolds equation with a cavity (quadrature of the piecewise pressure field, cavity edges by
bracketing), and the separation of two plates pulled apart by a constant force against closed
forms: Stefan's law without the cavitation limit, and with it the Reynolds-condition cavity
(docs/stiction.md derives both). The pump runs and both valves open with C2 from 0.1 to 10 times
eq 2.15.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from lumped.valves import disc as dv
from lumped.valves.disc import DISC, film_force
from lumped.solver.layout import pack
from lumped.model.model_file import load_model
from lumped.solver.layout import OFF_IN

RI, RO = 5.24e-3, 7.5e-3           # the thesis disc's film annulus (Table 2.3)
MU = 0.0683                         # Pa s


# ----------------------------------------------------------------- an independent Reynolds solution
def reynolds_force(p_up, p_down, p_lim, k, ri=RI, ro=RO):
    """Force [N] on the face of an annulus ri..ro (p_up inside ri, p_down outside ro) from the
    Reynolds film P = k r^2 + A ln r + B, bounded at p_lim with the Reynolds (zero-gradient) cavity
    condition: each liquid zone solved on its own, edges found by bracketing, pressures integrated
    by quadrature. Nothing from lumped.valves.disc is used."""
    lnr = math.log(ro / ri)
    a = (p_down - p_up - k * (ro**2 - ri**2)) / lnr
    b = p_up - k * ri**2 - a * math.log(ri)
    full = lambda r: k * r * r + a * math.log(r) + b                           # noqa: E731
    grid = np.linspace(ri, ro, 4001)
    if min(full(r) for r in grid) >= p_lim or k <= 0:
        integral = quad(lambda r: full(r) * 2 * math.pi * r, ri, ro, epsabs=0, epsrel=1e-13)[0]
        return math.pi * ri**2 * p_up + integral - math.pi * ro**2 * p_down
    # inner zone: P(ri) = p_up, P(r1) = p_lim, P'(r1) = 0; outer zone likewise at r2
    r1 = ri if p_up <= p_lim else brentq(
        lambda r1: k * (r1**2 - ri**2) - 2 * k * r1**2 * math.log(r1 / ri) + p_up - p_lim, ri * (1 + 1e-14), ro,
        xtol=1e-16, rtol=1e-15)
    r2 = ro if p_down <= p_lim else brentq(
        lambda r2: k * (ro**2 - r2**2) - 2 * k * r2**2 * math.log(ro / r2) - (p_down - p_lim), ri,
        ro * (1 - 1e-14), xtol=1e-16, rtol=1e-15)
    z1 = lambda r: p_lim + k * (r * r - r1 * r1) - 2 * k * r1 * r1 * math.log(r / r1)   # noqa: E731
    z2 = lambda r: p_lim + k * (r * r - r2 * r2) - 2 * k * r2 * r2 * math.log(r / r2)   # noqa: E731
    f1 = quad(lambda r: z1(r) * 2 * math.pi * r, ri, r1, epsabs=0, epsrel=1e-11, limit=200)[0] if r1 > ri else 0.0
    f2 = quad(lambda r: z2(r) * 2 * math.pi * r, r2, ro, epsabs=0, epsrel=1e-11, limit=200)[0] if r2 < ro else 0.0
    return math.pi * ri**2 * p_up + f1 + p_lim * math.pi * (r2**2 - r1**2) + f2 - math.pi * ro**2 * p_down


@pytest.mark.parametrize("p_up, p_down, p_lim, k", [
    (3.0e6, 2.76e6, 10.0, 1e10),      # full film (no cavity)
    (3.0e6, 2.76e6, 10.0, 1e13),      # a cavity in the middle of the annulus
    (3.0e6, 2.76e6, 10.0, 1e16),      # nearly all of it cavitating
    (1.0e5, 5.0e4, 0.0, 1e12),        # an inlet valve in suction
    (1.0e5, 5.0e4, 0.0, 1e19),        # edge zones thinner than 1e-3 R_i: the series branch
    (2.0e6, 3.0e6, -1.0e6, 1e14),     # reverse pressure, an oil holding 1 MPa of tension
    (1.0e5, 1.0e5, 0.0, 1e12),        # no pressure difference: squeeze only
])
def test_film_force_is_the_reynolds_solution_with_a_cavity(p_up, p_down, p_lim, k):
    assert film_force(p_up, p_down, p_lim, k, RI, RO) == pytest.approx(reynolds_force(p_up, p_down, p_lim, k),
                                                                       rel=1e-8, abs=1e-9)


def test_limits_are_eqs_2_13_and_2_16():
    c1 = dv.c1_coefficient(RI, RO)
    g = dv.squeeze_area_moment(RI, RO)
    pu, pd = 3.0e6, 2.76e6
    k = 1e9       # slow: no cavity, eq 2.13 with C2 u / x^3 = k G
    assert film_force(pu, pd, 0.0, k, RI, RO) == pytest.approx(c1 * (pu - pd) * math.pi * RO**2 - k * g, rel=1e-12)
    # fast: the whole film at the limit pressure, eq 2.16 (A_port = pi R_i^2)
    fmin = (pu - pd) * math.pi * RI**2 + (0.0 - pd) * math.pi * (RO**2 - RI**2)
    assert film_force(pu, pd, 0.0, 1e22, RI, RO) == pytest.approx(fmin, rel=1e-5)
    # monotone between: opening faster never sucks less, and never beyond eq 2.16
    ks = np.geomspace(1e8, 1e22, 300)
    f = np.array([film_force(pu, pd, 0.0, kk, RI, RO) for kk in ks])
    assert np.all(np.diff(f) < 0) and np.all(f > fmin)
    # closing (k < 0) pushes: the film pressure rises, nothing cavitates
    assert film_force(pu, pd, 0.0, -1e14, RI, RO) == pytest.approx(c1 * (pu - pd) * math.pi * RO**2 + 1e14 * g,
                                                                   rel=1e-12)


def test_force_is_continuous_where_the_cavity_appears():
    pu, pd = 3.0e6, 2.76e6
    g = dv.squeeze_area_moment(RI, RO)
    full = lambda k: dv.c1_coefficient(RI, RO) * (pu - pd) * math.pi * RO**2 - k * g      # noqa: E731
    lo, hi = 1e9, 1e16           # bisect for the onset: below it the force is eq 2.13 exactly
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if film_force(pu, pd, 10.0, mid, RI, RO) > full(mid) + 1e-9 * abs(full(mid)):
            hi = mid
        else:
            lo = mid
    kc = hi
    for eps in (1e-4, 1e-6):
        jump = film_force(pu, pd, 10.0, kc * (1 + eps), RI, RO) - full(kc * (1 - eps))
        assert abs(jump) < 4 * eps * kc * g        # no jump: only the slope (at most -G) times 2 eps kc


def test_tensile_strength_holds_the_disc_harder():
    # Roemer et al. (2015): an oil under tension cavitates below the vapour pressure
    f0 = film_force(1e5, 1e5, 10.0, 1e21, RI, RO)
    f1 = film_force(1e5, 1e5, 10.0 - 1e6, 1e21, RI, RO)
    assert f1 < f0 < 0
    assert f1 - f0 == pytest.approx(-1e6 * math.pi * (RO**2 - RI**2), rel=1e-3)


# ----------------------------------------------------------------- separation under a constant force
def separation_time(pull, p_amb, p_lim, h0, h1, ri, ro, p_up=None, mu=MU):
    """Time [s] for two parallel plates (film annulus ri..ro) to go from gap h0 to h1 when pulled apart
    by ``pull`` [N], inertia neglected: at each gap the opening speed makes the film force balance the pull."""
    p_up = p_amb if p_up is None else p_up
    kf = 3.0 * mu                       # parallel plates: theta = 90 deg

    def log_speed(h):
        return brentq(lambda lu: film_force(p_up, p_amb, p_lim, kf * math.exp(lu) / h**3, ri, ro) + pull,
                      -80.0, 40.0, xtol=1e-13)

    # t = integral of dh / u(h), in log h
    return quad(lambda lh: math.exp(lh - log_speed(math.exp(lh))), math.log(h0), math.log(h1),
                epsabs=0, epsrel=1e-9, limit=200)[0]


def test_annulus_separates_as_stefans_law_without_the_limit():
    """No cavitation limit: F = 3 mu G dh/dt / h^3 (Stefan 1874 for the annulus), G the area moment by
    quadrature of the Reynolds field: t = 3 mu G / (2 F) (1/h0^2 - 1/h1^2)."""
    lnr = math.log(RO / RI)
    # G = integral of (the squeeze pressure per unit k) over the face (eq 2.11 with dp = 0, by quadrature)
    shape = lambda r: -(r * r * math.log(RI / RO) + RI**2 * math.log(RO / r) + RO**2 * math.log(r / RI)) / lnr  # noqa
    g = quad(lambda r: -shape(r) * 2 * math.pi * r, RI, RO, epsrel=1e-13)[0]
    pull, h0, h1 = 50.0, 2e-6, 200e-6
    t = separation_time(pull, 2.76e6, -1e15, h0, h1, RI, RO)
    assert t == pytest.approx(3 * MU * g / (2 * pull) * (1 / h0**2 - 1 / h1**2), rel=1e-6)


def test_annulus_separates_faster_with_the_cavitation_limit():
    """With the limit the opening speed is constant in k = 3 mu u / h^3 (the cavity keeps its size
    under a constant pull): t = 3 mu / (2 k_F) (1/h0^2 - 1/h1^2), k_F solving the independent
    Reynolds-with-cavity force for the pull."""
    p_amb, p_lim, h0, h1 = 2.76e6, 10.0, 2e-6, 200e-6
    f_max = (p_amb - p_lim) * math.pi * (RO**2 - RI**2)      # the whole film at p_lim: eq 2.16
    for frac in (0.6, 0.9, 0.99):
        pull = frac * f_max
        k_f = math.exp(brentq(lambda lk: reynolds_force(p_amb, p_amb, p_lim, math.exp(lk)) + pull, 10, 60,
                              xtol=1e-14))
        t_closed = 3 * MU / (2 * k_f) * (1 / h0**2 - 1 / h1**2)
        t = separation_time(pull, p_amb, p_lim, h0, h1, RI, RO)
        assert t == pytest.approx(t_closed, rel=1e-5)
        t_stefan = 3 * MU * dv.squeeze_area_moment(RI, RO) / (2 * pull) * (1 / h0**2 - 1 / h1**2)
        assert t < t_stefan


def plate_closed_form(pull, dp_c, radius):
    """Solid circular plates, cavity at the centre with the Reynolds condition (docs/stiction.md):
    pull = dp_c pi R^2 Phi(s), Phi = s^2 + g(s)/f(s), s = r_c/R; returns (s, t / t_Stefan = 2 f Phi)."""
    f = lambda s: 1 - s * s + 2 * s * s * math.log(s)                                  # noqa: E731
    g = lambda s: (1 - s * s) ** 2 / 2 - s * s * (1 - s * s) - 2 * s**4 * math.log(s)   # noqa: E731
    phi = lambda s: s * s + g(s) / f(s)                                                 # noqa: E731
    target = pull / (dp_c * math.pi * radius**2)
    s = brentq(lambda s: phi(s) - target, 1e-9, 1 - 1e-4, xtol=1e-15)
    return s, 2 * f(s) * phi(s)


@pytest.mark.parametrize("frac", [0.55, 0.7, 0.9, 0.98])
def test_solid_plates_separate_as_the_closed_form(frac):
    """Two solid circular plates (R = 7.5 mm) pulled apart by more than half the largest suction
    dp_c pi R^2: the film cavitates at the centre from the start; Stefan's time
    t_S = 3 pi mu R^4 / (4 F) (1/h0^2 - 1/h1^2) shrinks by 2 f(s) Phi(s) (docs/stiction.md).
    The code's annulus with a vanishing centre held at the limit pressure is this plate."""
    p_amb, p_lim, h0, h1 = 1.0e5, 10.0, 1e-6, 100e-6
    dp_c = p_amb - p_lim
    pull = frac * dp_c * math.pi * RO**2
    s, ratio = plate_closed_form(pull, dp_c, RO)
    t_stefan = 3 * math.pi * MU * RO**4 / (4 * pull) * (1 / h0**2 - 1 / h1**2)
    t = separation_time(pull, p_amb, p_lim, h0, h1, 1e-9 * RO, RO, p_up=p_lim)
    assert t == pytest.approx(ratio * t_stefan, rel=1e-5)
    assert 0 < ratio < 1


# ----------------------------------------------------------------- in the disc valve and the pump
def test_disc_film_is_x_plus_min_gap_thick_and_off_on_the_seat():
    m = load_model("thesis-disc")
    c2 = m.inlet.c2(m.oil.viscosity)
    m = replace(m, inlet=replace(m.inlet, squeeze_c2=c2))
    p = pack(m, 593.0, 2.76e6)
    o = OFF_IN
    v = m.inlet
    h_r = v.squeeze_min_gap
    dp, p_down = 1e5, 2e4
    x, u = 0.2e-3, 1e-3       # slow: eq 2.13 on the film x + h_r
    assert dv.pressure_force(x, u, dp, p_down, 10.0, p, o, 0, 1) == pytest.approx(
        v.c1 * dp * v.disc_area - c2 * u / (x + h_r) ** 3, rel=1e-12)
    # fast from the seat: eq 2.16 bounds it, the film at the vapour pressure
    f = dv.pressure_force(0.0, 0.5, dp, p_down, 10.0, p, o, 0, 1)
    fmin = dp * v.port_area + (10.0 - p_down) * (v.disc_area - v.port_area)
    assert fmin < f < fmin + 1e-3 * abs(fmin)
    # seated (contact 0) the disc moves with the seat: no squeeze
    assert dv.pressure_force(-1e-9, 0.5, dp, p_down, 10.0, p, o, 0, 0) == pytest.approx(v.c1 * dp * v.disc_area)
    # the tensile strength lowers the bound (the fast opening above, now 0.5 MPa below P_vap)
    pt = pack(replace(m, inlet=replace(m.inlet, squeeze_tensile_strength=5e5)), 593.0, 2.76e6)
    f_t = dv.pressure_force(0.0, 0.5, dp, p_down, 10.0, pt, o, 0, 1)
    assert f_t == pytest.approx(f - 5e5 * (v.disc_area - v.port_area), rel=1e-3)
    assert p[o + DISC.film_coefficient] == pytest.approx(3 * m.oil.viscosity / math.sin(v.bevel_angle) ** 4)


@pytest.mark.parametrize("factor", [0.1, 1.0, 10.0])
def test_pump_runs_and_both_valves_open_with_stiction(factor):
    """C2 from 0.1 to 10 times eq 2.15: the pump runs (fast path), both discs open past half their stop
    gap, each passes 10 % of it no earlier than without stiction (the film delays the lift-off), the
    mass balances and the delivery drops but stays."""
    from studies.validation.stiction import opening

    m = load_model("thesis-disc")
    ref = opening(m, 0.0)
    r = opening(m, factor)
    for v in ("inlet", "delivery"):
        assert r[v]["peak_opening_m"] > 0.5 * getattr(m, v).stop_gap
        assert r[v]["open50_deg"] is not None
        assert r[v]["open10_deg"] >= ref[v]["open10_deg"] - 0.05
    assert r["mass_balance_error"] < 1e-9
    assert 0.5 < r["delivery_per_rev"] / ref["delivery_per_rev"] <= 1.0 + 1e-3


@pytest.mark.slow
def test_fast_and_reference_agree_with_the_squeeze_film():
    """The compiled fast path and the scipy reference run the same film (measured 1.6e-4 apart)."""
    from lumped.run.simulate import simulate
    from lumped.model.effect_library import baseline
    from lumped.model.effects import Applied

    m0 = baseline(load_model("thesis-disc"))
    m = m0.with_effects((Applied.of("squeeze_film", "both", {"C2": m0.inlet.c2(m0.oil.viscosity)}),))
    kw = dict(revolutions=3, max_revolutions=6, air_content=0.013)
    f = simulate(m, 593.0, 2.76e6, method="fast", **kw)
    r = simulate(m, 593.0, 2.76e6, method="reference", **kw)
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=1e-3)
    for v in ("inlet", "delivery"):
        assert getattr(f, v).peak_opening == pytest.approx(getattr(r, v).peak_opening, rel=1e-2)
