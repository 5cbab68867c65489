"""Does the validation procedure mean what it says? Its coverage and power on synthetic measurements of the thesis's
pumps, through the whole procedure.

The truth of a synthetic draw is the thesis's pump at a random set of its uncertain inputs:
for each rig a draw of its joint Monte Carlo (the fast path at that draw's inputs, as a change
from the fast path at the nominal inputs, added to the reference stepper's S), so the air
content, the viscosity and the rest differ from the nominal model exactly as the declarations
say. A relative model-form error delta may be injected into some runs. The measurements are
the truth times (1 + s eps_i)(1 + m): eps_i standard normal per run (s the real pooled
repeatability), m one uniform flow-meter error (+-0.5 %) common to every run. Then the real
procedure runs on them: the paired runs' repeatability estimated again (the suspect pair left
out, the F test, pooled or not: 5 or 2-3 dof), the procedure's Monte Carlo a bootstrap of draws
disjoint from the truths' (its sampling error included), the calibration, the intervals
(Welch-Satterthwaite or Monte Carlo), the verdicts (:func:`studies.validation.procedure.analyse`;
the calibrated prediction linear, as the benchmark cannot re-run the fast path per draw).

``coverage``: with no model error, the fraction of comparisons "within" per kind (nominal
95.45 %). ``power``: the fraction detected per kind when delta is injected into every run
outside the calibration condition (``held_out``: what the predictions and the calibrated rig
test judge) or into every run (``common``: what only the uncalibrated tests can see; a
calibration absorbs it into the air content); a run's own comparisons (``validation``,
``prediction``) are counted on the runs that carry the error.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, replace

import numpy as np

from studies.validation import procedure
from studies.validation.measurement import SUSPECT, repeatability

#: the kinds of comparison counted
KINDS = ("validation", "prediction", "differences", "rig_calibrated", "rig_nominal")
#: Monte Carlo samples of each interval in the benchmark (the real run uses joint.INTERVAL_SAMPLES)
SAMPLES = 4000


@dataclass(frozen=True)
class Bench:
    """What the synthetic draws are made of: the 12 thesis runs, their model values and each rig's draws."""

    cases: tuple[dict, ...]
    S: dict                 # reference stepper at the nominal inputs [cc/rev]
    nominal: dict           # the fast path at the nominal inputs [cc/rev]
    u_num: dict
    pools: dict             # {valve: Rig with the real D}: its draws are split into truths and the procedure's
    sigma: float            # the real pooled repeatability (relative)
    keys: dict              # {valve: calibrated keys}


def prepare(per_scramble: int = 128, progress: bool = True, cluster=None, seed: int = 7) -> Bench:
    """Run what the benchmark needs once: the reference S of the 12 runs, their tolerance ladders, the fast path at
    the nominal inputs and a joint Monte Carlo of ``8 per_scramble`` draws per rig."""
    from studies.validation import chain as V
    from studies.validation.pump_vv20 import FastPath, _ladders, _setup, build_rig
    from studies.validation.input_uncertainty import Point, propagate

    cases = V.cases()
    results = V.run_cases(cases, trace=False, progress=progress)
    names, S, models = _setup(cases, results)
    unum = _ladders(cases, names, S, models, False, progress)
    fast = FastPath(False)
    nominal = {n: fast.delivery(n) for n in names}
    points = [Point(n, models[n], c["speed_rpm"], c["load_pressure"], 2, V.FULL["max_revolutions"], group=c["valve"])
              for n, c in zip(names, cases)]
    draws: dict = {}
    propagate(points, cluster=cluster, progress=progress, seed=seed, draws=draws, per_scramble=per_scramble)
    out = "delivery_cc_per_rev"
    repeat = repeatability(cases, nominal)
    pools, keys = {}, {}
    for valve in ("disc", "reed"):
        vn = [n for n, c in zip(names, cases) if c["valve"] == valve]
        values = {n: (S[n][out], c["measured_delivery"] * 1e6, unum[n][out].u or 0.0) for n, c in zip(names, cases)}
        pools[valve] = build_rig(valve, vn, values, draws, models[vn[0]], repeat, SUSPECT)
        keys[valve] = tuple(d.key for d in models[vn[0]].uncertainties if d.calibrate)
    return Bench(tuple(cases), {n: S[n][out] for n in names}, nominal, {n: unum[n][out].u or 0.0 for n in names},
                 pools, repeat.s_rel, keys)


def _split(rig) -> tuple[np.ndarray, np.ndarray]:
    """Draw indices of the truths (the first half of the scrambles) and of the procedure's Monte Carlo (the rest)."""
    half = np.unique(rig.scramble)[: len(np.unique(rig.scramble)) // 2]
    truth = np.isin(rig.scramble, half)
    return np.flatnonzero(truth), np.flatnonzero(~truth)


def _injected(case: str, valve: str, pattern: str) -> bool:
    """Whether a run carries the injected model-form error: every run (``common``) or every run outside the
    calibration condition (``held_out``)."""
    return pattern == "common" or procedure.parts(case)[2] != procedure.CALIBRATION_CONDITION[valve]


def synthetic_measurements(bench: Bench, rng, delta: float, pattern: str) -> dict:
    """{case: synthetic measured delivery} of one draw: the truths from the truth draws, delta injected (see the
    module docstring), the repeatability and the common meter."""
    from studies.validation.measurement import FLOW_METER_HALF_WIDTH

    meter = 1.0 + rng.uniform(-FLOW_METER_HALF_WIDTH, FLOW_METER_HALF_WIDTH)
    D = {}
    for valve, rig in bench.pools.items():
        truths, _ = _split(rig)
        k = truths[rng.integers(0, len(truths))]
        for i, n in enumerate(rig.cases):
            T = bench.S[n] + rig.draws[k, i] - bench.nominal[n]
            if _injected(n, valve, pattern):
                T /= 1.0 + delta              # the model is (1 + delta) times the truth
            D[n] = T * (1.0 + bench.sigma * rng.standard_normal()) * meter
    return D


def one_draw(bench: Bench, rng, delta: float = 0.0, pattern: str = "held_out") -> dict:
    """The procedure on one synthetic dataset: {kind: [verdict is a model-form error, ...]} and the rig tests'
    intervals against the injected delta."""
    from studies.validation.chain import case_name

    D = synthetic_measurements(bench, rng, delta, pattern)
    syn = [dict(c, measured_delivery=D[case_name(c)] * 1e-6) for c in bench.cases]
    repeat = repeatability(syn, bench.nominal)
    out = {k: [] for k in KINDS}
    opts = procedure.Options(calibrate=bench.keys, samples=SAMPLES, power=False)
    for valve, rig in bench.pools.items():
        _, proc = _split(rig)
        pick = proc[rng.integers(0, len(proc), len(proc))]              # the procedure's Monte Carlo: a bootstrap
        s, nu = repeat.of(valve)
        syn_rig = replace(rig, D=np.array([D[n] for n in rig.cases]), draws=rig.draws[pick], scores=rig.scores[pick],
                          scramble=rig.scramble[pick], repeat_rel=s, repeat_dof=float(nu))
        part = procedure.analyse(syn_rig, rng, opts)
        hit = {n for n in rig.cases if _injected(n, valve, pattern)} if delta else set(rig.cases)
        for kind in ("validation", "prediction"):              # with an error: the runs that carry it
            out[kind] += [r["verdict"] != "within" for r in part[kind] if r["case"] in hit]
        out["differences"] += [r["verdict"] != "within" for r in part["differences"]]
        for t in part["rig_tests"]:
            kind = "rig_calibrated" if t["calibrated"] else "rig_nominal"
            out[kind].append(t["verdict"] != "within")
            out.setdefault(kind + "_contains", []).append(t["delta_model"][0] <= 100 * delta <= t["delta_model"][1])
    out["pooled"] = [repeat.pooled]
    return out


def study(bench: Bench, draws: int = 2000, deltas=(0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.08, 0.10),
          per_delta: int = 400, seed: int = 0, progress: bool = True) -> dict:
    """Coverage over ``draws`` synthetic datasets without a model error, and the power curves (see the module
    docstring): {"coverage": {kind: fraction within}, "power": {pattern: {kind: [fraction detected per delta]}}}."""
    rng = np.random.default_rng(seed)
    total = draws + 2 * per_delta * len(deltas)
    bar = _bar(total, progress)
    clean = _many(bench, rng, draws, 0.0, "held_out", bar)
    cov = {k: 1.0 - float(np.mean(v)) for k, v in clean.items() if k in KINDS}
    counts = {k: len(v) for k, v in clean.items() if k in KINDS}
    power: dict = {}
    for pattern in ("held_out", "common"):
        curves: dict = {k: [] for k in KINDS}
        contains: dict = {"rig_calibrated": [], "rig_nominal": []}
        for d in deltas:
            res = _many(bench, rng, per_delta, d, pattern, bar)
            for k in KINDS:
                curves[k].append(float(np.mean(res[k])))
            for k in contains:
                contains[k].append(float(np.mean(res[k + "_contains"])))
        power[pattern] = {"detected": curves, "interval_holds_delta": contains}
    if bar is not None:
        bar.close()
    return {"draws": draws, "comparisons": counts, "coverage": cov, "pooled_fraction": float(np.mean(clean["pooled"])),
            "deltas_pct": [100 * d for d in deltas], "per_delta": per_delta, "power": power,
            "sigma_pct": 100 * bench.sigma, "procedure_draws": {v: len(_split(r)[1]) for v, r in bench.pools.items()},
            "truth_draws": {v: len(_split(r)[0]) for v, r in bench.pools.items()}}


def _many(bench, rng, n, delta, pattern, bar) -> dict:
    acc: dict = {}
    for _ in range(n):
        for k, v in one_draw(bench, rng, delta, pattern).items():
            acc.setdefault(k, []).extend(v)
        if bar is not None:
            bar.update(1)
    return acc


def _bar(total: int, progress: bool):
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc="synthetic datasets", unit="dataset", file=sys.stderr, smoothing=0.05)
