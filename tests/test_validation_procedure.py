"""The validation that can fail (studies.validation.joint, procedure, measurement): each piece against independent
numbers (hand arithmetic, closed forms of the normal, uniform and chi-square distributions, a linear model whose
truth is known), and the whole procedure's coverage on synthetic linear rigs."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.stats import norm

from studies.validation import joint, procedure
from studies.validation.measurement import (FLOW_METER_REL, paired_type_a, repeatability, sigma_interval,
                                            variance_test)

CASES = ("disc_inlet_baseline", "disc_inlet_high_speed", "disc_inlet_high_pressure",
         "disc_delivery_baseline", "disc_delivery_high_speed", "disc_delivery_high_pressure")


def _scores(n, rng):
    """Balanced scores: a uniform (midpoint grid, unit variance) and a normal (quantiles), shuffled apart."""
    u = (np.arange(n) + 0.5) / n
    z1 = math.sqrt(3.0) * (2.0 * u - 1.0)
    z2 = norm.ppf(u)
    return np.column_stack([rng.permutation(z1), rng.permutation(z2)])


def _rig(G, S=None, D=None, s=0.02, nu=5.0, n=20_000, seed=1, suspect=None, meter=FLOW_METER_REL):
    """A linear rig: draws = S + scores @ G^T, the first declaration uniform (the calibrated one), the second
    normal."""
    rng = np.random.default_rng(seed)
    G = np.asarray(G, dtype=float)
    m = G.shape[0]
    S = np.full(m, 1.7) if S is None else np.asarray(S, dtype=float)
    z = _scores(n, rng)
    return joint.Rig("disc", CASES[:m], S, S.copy() if D is None else np.asarray(D, dtype=float), np.zeros(m),
                     S + z @ G.T, z, np.arange(n) % 8, ("oil.air_content", "oil.viscosity"), (True, False), s, nu,
                     meter, tuple(suspect or [False] * m), {"oil.air_content": (0.013, 0.003)})


# --------------------------------------------------------------------------- the budget of a combination
def test_budget_of_a_run_and_of_a_difference_by_hand():
    """A run: u_input = sqrt(a1^2 + a2^2), u_D = sqrt((s D)^2 + (u_m D)^2). A difference of two runs with the same
    slope in the shared input: that input cancels, u_input = |a2 - b2|; the meter leaves u_m |D_a - D_b|."""
    G = [[0.06, 0.01], [0.06, 0.004]]
    rig = _rig(G, D=[1.7, 1.6])
    b = joint.budget(rig, [1.0, 0.0])
    assert b.u_input == pytest.approx(math.hypot(0.06, 0.01), rel=1e-3)
    assert b.u_D == pytest.approx(math.hypot(0.02 * 1.7, FLOW_METER_REL * 1.7), rel=1e-12)
    assert [k for k, _ in b.contributors] == ["oil.air_content", "oil.viscosity"] and b.linear_r2 > 0.999999
    d = joint.budget(rig, [1.0, -1.0])
    assert d.u_input == pytest.approx(0.006, rel=1e-3)
    assert d.u_repeat == pytest.approx(0.02 * math.sqrt(1.7**2 + 1.6**2), rel=1e-12)
    assert d.u_meter == pytest.approx(FLOW_METER_REL * 0.1, rel=1e-12)
    # the air content's uniform carries 97 % of u_val^2 of the run: its interval is a Monte Carlo one
    assert b.dominant == "oil.air_content" and d.dominant is None


def test_monte_carlo_interval_of_a_dominant_uniform_is_the_uniforms():
    """A comparison whose error is a uniform of standard uncertainty u: the 95.45 % interval is 0.9545 sqrt(3) u
    (k = 1.6533), not 2 u (which covers 100 %)."""
    rig = _rig([[0.05, 0.0]], s=1e-9, meter=0.0)
    b = joint.budget(rig, [1.0])
    k, how = joint.interval(b, joint.error_samples(rig, [1.0], b, np.random.default_rng(0), 200_000))
    assert how == "monte_carlo" and k == pytest.approx(0.9545 * math.sqrt(3.0), rel=3e-3)
    # a normal-dominated comparison keeps Welch-Satterthwaite: t at nu_eff
    rn = _rig([[0.0, 0.05]], s=1e-9)
    bn = joint.budget(rn, [1.0])
    k, how = joint.interval(bn, None)
    assert how == "welch" and k == pytest.approx(2.0, abs=1e-5)          # nu_eff huge: t -> 2


def test_detectable_error_of_a_normal_comparison():
    """X ~ N(0, 1), U = 2: the error delta detected with 80 % probability solves Phi(delta - 2) + Phi(-delta - 2)
    = 0.8: 2.8416, about 2 + z_0.80 (the lower tail adds 3e-5)."""
    x = norm.ppf((np.arange(400_000) + 0.5) / 400_000)
    exact = brentq(lambda d: norm.cdf(d - 2.0) + norm.cdf(-d - 2.0) - 0.8, 0.0, 10.0)
    assert exact == pytest.approx(2.0 + norm.ppf(0.8), abs=1e-4)
    assert joint.detectable(x, 2.0, 1.0) == pytest.approx(exact, abs=1e-3)
    assert joint.detectable(x, 2.0, 0.5) == pytest.approx(2.0 * exact, abs=2e-3)      # response 0.5: twice delta
    assert joint.detectable(x, 2.0, 0.0) is None                                      # a comparison blind to it


# --------------------------------------------------------------------------- calibration
def test_calibration_recovers_the_shared_input_and_cancels_it():
    """Measurements made by the model itself at the air content's score z = -1.3: the fit on the first two runs
    gives z exactly, every prediction error is zero, L removes the calibrated slope (L g = 0); the fit's data
    variance for two runs of equal D and slope is ((s D)^2 / 2 + (u_m D)^2) / g^2."""
    g = np.array([0.06, 0.062, 0.07, 0.058])
    G = np.column_stack([g, [0.01, 0.012, 0.011, 0.009]])
    S = np.array([1.70, 1.70, 1.68, 1.71])
    D = S - 1.3 * g                          # E = S - D = 1.3 g: the model at z = 0 against a truth at z = -1.3
    rig = _rig(G, S=S, D=D)
    cal = joint.calibrate(rig, ("oil.air_content",), [0, 1])
    assert cal.shift[0] == pytest.approx(-1.3, rel=1e-3)
    G_fit = rig.slopes()[:, [0]]
    assert np.allclose(cal.L @ G_fit, 0.0, atol=1e-12)
    assert np.allclose(cal.L @ (S - D), 0.0, atol=2e-4)
    # equal slopes and D on the calibration runs: the closed form
    eq = _rig(np.column_stack([[0.06, 0.06, 0.07], [0.0, 0.0, 0.0]]), S=[1.7, 1.7, 1.7])
    c2 = joint.calibrate(eq, ("oil.air_content",), [0, 1])
    by_hand = ((0.02 * 1.7) ** 2 / 2 + (FLOW_METER_REL * 1.7) ** 2) / 0.06**2
    assert c2.cov_data[0, 0] == pytest.approx(by_hand, rel=2e-3)
    with pytest.raises(ValueError, match="cannot determine"):
        joint.calibrate(eq, ("oil.air_content", "oil.viscosity"), [0])


def test_rig_weights_of_independent_equal_runs_are_the_mean():
    """Runs with equal D and independent, equal errors: the GLS common error is their mean (weights 1 / (n D))."""
    rig = _rig(np.zeros((3, 2)), S=[1.7, 1.7, 1.7], meter=0.0)
    c, cH = joint.rig_weights(rig, None, [0, 1, 2])
    assert np.allclose(c, 1.0 / (3 * 1.7)) and np.allclose(cH, c)


# --------------------------------------------------------------------------- repeatability
def test_pooled_repeatability_of_the_thesis_pairs_by_hand():
    """With the model's differences zero, the pairs' relative differences d = (D_inlet - D_delivery) / mean:
    disc 1.720/1.790, 1.684/1.678 (the high-pressure pair, with the suspect run, left out); reed 1.683/1.736,
    1.680/1.686, 1.675/1.648. s_r^2 = sum d^2 / (2 n); F the larger over the smaller, two-sided p; pooled
    s^2 = (2 s_disc^2 + 3 s_reed^2) / 5 with 5 dof."""
    from studies.validation.chain import case_name, cases

    cs = cases()
    rep = repeatability(cs, {case_name(c): 0.0 for c in cs})
    d_disc = [-0.070 / 1.755, 0.006 / 1.681]
    d_reed = [-0.053 / 1.7095, -0.006 / 1.683, 0.027 / 1.6615]
    s_disc = math.sqrt(sum(x * x for x in d_disc) / 4)
    s_reed = math.sqrt(sum(x * x for x in d_reed) / 6)
    assert rep.rigs["disc"] == (pytest.approx(s_disc, rel=1e-9), 2)
    assert rep.rigs["reed"] == (pytest.approx(s_reed, rel=1e-9), 3)
    assert rep.F == pytest.approx(s_disc**2 / s_reed**2, rel=1e-9)
    from scipy.stats import f

    assert rep.p == pytest.approx(2 * f.sf(s_disc**2 / s_reed**2, 2, 3), rel=1e-9) and rep.p > 0.05
    assert rep.pooled and rep.dof == 5
    assert rep.s_rel == pytest.approx(math.sqrt((2 * s_disc**2 + 3 * s_reed**2) / 5), rel=1e-12)
    assert [q.suspect for q in rep.pairs].count(True) == 1
    # variances far apart are not pooled
    F, p = variance_test(0.05, 3, 0.005, 3)
    assert F == pytest.approx(100.0) and p < 0.01
    assert paired_type_a([0.3, -0.4]) == (pytest.approx(math.sqrt(0.25 / 4)), 2)


def test_sigma_interval_from_chi_square_quantiles():
    """nu = 5: chi2_0.025 = 0.8312, chi2_0.975 = 12.833 (tables): sigma in [s sqrt(5 / 12.833), s sqrt(5 / 0.8312)]."""
    lo, hi = sigma_interval(1.0, 5)
    assert lo == pytest.approx(math.sqrt(5 / 12.8325), rel=1e-4) and hi == pytest.approx(math.sqrt(5 / 0.8312), rel=1e-4)


# --------------------------------------------------------------------------- the procedure on known truths
def _synthetic(rig, rng, delta=0.0):
    """A dataset made by the linear model at random inputs: truth S + G z (z from the declared distributions), a
    model-form error delta outside the calibration condition, the repeatability and the meter; s re-estimated
    with 5 dof as the pooled paired runs would (sigma^2 chi2_5 / 5)."""
    G = rig.slopes()
    z = np.array([math.sqrt(3.0) * rng.uniform(-1, 1), rng.standard_normal()])
    cal = set(procedure.calibration_runs(rig))
    T = np.array([rig.S[i] + G[i] @ z for i in range(len(rig.cases))])
    T = np.array([t / (1.0 + delta) if i not in cal else t for i, t in enumerate(T)])
    meter = 1.0 + math.sqrt(3.0) * FLOW_METER_REL * rng.uniform(-1, 1)
    D = T * (1.0 + 0.0172 * rng.standard_normal(len(T))) * meter
    s_hat = 0.0172 * math.sqrt(rng.chisquare(5) / 5)
    return joint.Rig(**{**rig.__dict__, "D": D, "repeat_rel": s_hat})


def test_the_procedure_covers_and_detects_on_a_linear_rig():
    """Six runs like the disc rig's, the air content's uniform dominating the nominal comparisons: over 250
    synthetic datasets without a model error every kind of comparison is within U_val in 90-99 % of them (nominal
    95.45 %); with a 10 % model-form error outside the calibration condition the calibrated rig test finds it in
    most datasets, and the nominal one, blinded by the air content, in far fewer."""
    g = np.array([0.064, 0.064, 0.065, 0.064, 0.064, 0.066])
    G = np.column_stack([g, [0.006, 0.0065, 0.0058, 0.006, 0.0066, 0.0059]])
    base = _rig(G, S=[1.726, 1.706, 1.697, 1.725, 1.708, 1.693], n=512)
    opts = procedure.Options(calibrate={"disc": ("oil.air_content",)}, samples=3000, power=False)
    rng = np.random.default_rng(3)
    hits: dict = {}
    for _ in range(250):
        part = procedure.analyse(_synthetic(base, rng), rng, opts)
        for kind in ("validation", "prediction", "differences", "rig_tests"):
            hits.setdefault(kind, []).extend(r["verdict"] == "within" for r in part[kind])
    for kind, v in hits.items():
        assert 0.90 <= np.mean(v) <= 0.99, (kind, np.mean(v))
    found = {True: [], False: []}
    for _ in range(100):
        for t in procedure.analyse(_synthetic(base, rng, delta=0.10), rng, opts)["rig_tests"]:
            found[t["calibrated"]].append(t["verdict"] != "within")
    assert np.mean(found[True]) > 0.75 and np.mean(found[False]) < 0.5 * np.mean(found[True])


def test_the_suspect_run_is_reported_but_not_used():
    """The suspect run is judged and flagged, and left out of the calibration and the rig tests."""
    G = np.column_stack([np.full(6, 0.064), np.full(6, 0.006)])
    rig = _rig(G, S=np.full(6, 1.7), n=512, suspect=[False] * 5 + [True])
    opts = procedure.Options(calibrate={"disc": ("oil.air_content",)}, samples=2000, power=True)
    part = procedure.analyse(rig, np.random.default_rng(0), opts)
    assert part["calibration"][0]["runs"] == ["disc_inlet_baseline", "disc_delivery_baseline"]
    assert [r["case"] for r in part["prediction"] if r["suspect"]] == ["disc_delivery_high_pressure"]
    assert all("disc_delivery_high_pressure" not in t["runs"] for t in part["rig_tests"])
    det = part["detectable"]
    assert det["rig"] < det["case"] < det["uncalibrated_case"]
