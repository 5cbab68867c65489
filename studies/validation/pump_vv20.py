"""The thesis's pump cases (Tables 5.4, 5.6) through the validation procedure: simulations in, tables out.

For the selected cases: S from the reference stepper (the runs ``valvelab validate`` made),
u_num from each case's tolerance ladder (:mod:`studies.validation.numerical`), a joint Monte
Carlo per rig (:func:`studies.validation.input_uncertainty.propagate` with the rig's runs in one
group and a fixed budget: the same inputs at every run of a draw), the fast model at the nominal
inputs for every thesis run (the paired runs' differences net of the model's), the pooled
repeatability (:func:`studies.validation.measurement.repeatability`), then
:func:`studies.validation.procedure.analyse` per rig. The calibrated prediction is refined
on the fast path: the calibrated keys are moved until the calibration runs' weighted mean error
is zero (Gauss-Newton on the draws' slopes), and every run is predicted at that point (S + the
fast path's change), so the reported prediction is not the linearisation.
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace

import numpy as np

from studies.validation.vv20 import LADDER, LADDER_QUICK, ValidationTable, u_pooling

#: points per Sobol scramble of the joint Monte Carlo (8 scrambles): the whole budget, known before the first draw
PER_SCRAMBLE, PER_SCRAMBLE_QUICK = 64, 8
#: Gauss-Newton iterations of the calibration on the fast path, and when to stop (relative change of the fit)
REFINE_STEPS, REFINE_TOL = 6, 1e-6
#: the reed parameters the thesis tuned to the validation data (section 5.5.3): calibrated, not validated
TUNED = {"reed": (("valves.flow.f1", "valves.inlet.flow.f1"), ("valves.flow.f2", "valves.inlet.flow.f2"))}


def _setup(selected, results):
    from lumped.model.model_file import with_values
    from studies.validation.chain import case_name, thesis_model_of
    from studies.validation.numerical import output_values

    names = [case_name(c) for c in selected]
    S = {n: output_values(r) for n, r in zip(names, results)}
    models = {n: with_values(thesis_model_of(c), {"oil.air_content": c["air_content"]}) for n, c in zip(names, selected)}
    return names, S, models


class FastPath:
    """The fast model of the thesis's runs at given standard scores of their declarations (the draws' settings)."""

    def __init__(self, quick: bool):
        from lumped.model.model_file import with_values
        from studies.validation.chain import FULL, QUICK, case_name, cases, thesis_model_of

        self.most = (QUICK if quick else FULL)["max_revolutions"]
        self.cases = {case_name(c): c for c in cases()}
        self.models = {n: with_values(thesis_model_of(c), {"oil.air_content": c["air_content"]})
                       for n, c in self.cases.items()}

    def delivery(self, name: str, z=None) -> float:
        from lumped.model.uncertainty import numeric_keys
        from studies.validation.input_uncertainty import evaluate_draws

        m, c = self.models[name], self.cases[name]
        bare = replace(m, uncertainties=())
        z = np.zeros(len(m.uncertainties)) if z is None else np.asarray(z, dtype=float)
        row = evaluate_draws(bare, c["speed_rpm"], c["load_pressure"], tuple(m.uncertainties), numeric_keys(bare),
                             [z], {"revolutions": 2, "max_revolutions": self.most}, ("delivery_cc_per_rev",))[0]
        if row is None or row.get("delivery_cc_per_rev") is None:
            raise RuntimeError(f"the fast path did not run {name} at scores {z}")
        return float(row["delivery_cc_per_rev"])


def refiner(fast: FastPath, nominal: dict):
    """``refine(rig, cal) -> (S, scores)``: the calibrated keys moved on the fast path until the calibration runs'
    weighted error is zero (Gauss-Newton with the draws' slopes), every run predicted there: S + fast(z) - fast(0)."""
    from studies.validation import joint

    def refine(rig, cal):
        idx = [rig.keys.index(k) for k in cal.keys]
        G, A = joint.gain(rig, cal.keys, cal.runs)
        C = list(cal.runs)
        z = np.zeros(len(rig.keys))
        z[idx] = cal.shift
        for _ in range(REFINE_STEPS):
            Y = np.array([fast.delivery(rig.cases[i], z) - nominal[rig.cases[i]] for i in C])
            step = -A @ (rig.S[C] + Y - rig.D[C])
            z[idx] += step
            if np.max(np.abs(G[C] @ step)) <= REFINE_TOL * float(np.max(rig.D)):
                break
        out = np.array([rig.S[i] + fast.delivery(n, z) - nominal[n] for i, n in enumerate(rig.cases)])
        return out, z[idx]

    return refine


def _monte_carlo(selected, names, models, quick, cluster, progress, seed):
    """The joint Monte Carlo: one group per rig, a fixed budget."""
    from studies.validation.chain import FULL, QUICK
    from studies.validation.input_uncertainty import Point, propagate

    most = (QUICK if quick else FULL)["max_revolutions"]
    points = [Point(n, models[n], c["speed_rpm"], c["load_pressure"], 2, most, group=c["valve"])
              for n, c in zip(names, selected)]
    draws: dict = {}
    per = PER_SCRAMBLE_QUICK if quick else PER_SCRAMBLE
    uin = propagate(points, quick=quick, cluster=cluster, progress=progress, seed=seed, draws=draws, per_scramble=per)
    return uin, draws


def build_rig(valve: str, names, values: dict, draws, model, repeat, suspect) -> "joint.Rig":  # noqa: F821
    """The :class:`studies.validation.joint.Rig` of one valve's runs: ``values`` {name: (S, D, u_num)}, the draws
    (with a failed run dropped), the model's declarations and the repeatability."""
    from lumped.model.uncertainty import numeric_keys
    from studies.validation import joint
    from studies.validation.measurement import FLOW_METER_REL

    first = draws[names[0]]
    Y = np.column_stack([draws[n]["delivery_cc_per_rev"] for n in names])
    ok = np.all(np.isfinite(Y), axis=1)
    decls = tuple(model.uncertainties)
    keys = numeric_keys(replace(model, uncertainties=()))
    priors = {d.key: (keys[d.key], d.standard_of(keys[d.key])) for d in decls if d.key in keys}
    s, nu = repeat.of(valve)
    S, D, u_num = (np.array([values[n][k] for n in names], dtype=float) for k in range(3))
    return joint.Rig(valve, tuple(names), S, D, u_num, Y[ok], first["z"][ok], first["scramble"][ok],
                     tuple(first["keys"]), tuple(d.distribution == "uniform" for d in decls), s, float(nu),
                     FLOW_METER_REL, tuple(n in suspect for n in names), priors)


def tuned_entries(valve: str, model, names) -> list[dict]:
    """The parameters the thesis tuned to these runs, flagged: calibrated, not validated."""
    from lumped.model.uncertainty import numeric_keys

    keys = numeric_keys(replace(model, uncertainties=()))
    return [{"parameter": name, "rig": valve, "value": keys[key], "u": None, "runs": list(names),
             "how": f"tuned by the thesis to these runs' deliveries and reed positions (section 5.5.3: "
                    f"{name.split('.')[-1]} = {keys[key]:g}, both valves); calibrated to the validation data, so part "
                    "of the reed's agreement is calibration, not validation", "validated": False}
            for name, key in TUNED.get(valve, ()) if key in keys]


def _rows_of(parts: dict, key: str) -> list[dict]:
    return [r for p in parts.values() for r in p[key]]


def pump_validation(selected, results, *, quick: bool = False, cluster=None, progress: bool = False,
                    seed: int = 0) -> tuple[ValidationTable, dict]:
    """The validation of the thesis's pump cases (see the module docstring). Returns the per-run table and
    ``{"calibration", "prediction", "differences", "rig_tests", "detectable_error", "repeatability",
    "tables": {name: ValidationTable}, "predictions", "measurement", "area_metric_detail", "draws", ...}``."""
    from studies.validation import procedure
    from studies.validation.measurement import SUSPECT, delivery_uncertainty, repeatability

    names, S, models = _setup(selected, results)
    unum = _ladders(selected, names, S, models, quick, progress)
    uin, draws = _monte_carlo(selected, names, models, quick, cluster, progress, seed)
    fast = FastPath(quick)
    if progress:
        print("  the fast model at the nominal inputs of every thesis run (paired differences net of the model's)",
              file=sys.stderr, flush=True)
    nominal = {n: fast.delivery(n) for n in fast.cases}
    repeat = repeatability(list(fast.cases.values()), nominal)
    out = "delivery_cc_per_rev"
    values = {n: (S[n][out], c["measured_delivery"] * 1e6, unum[n][out].u) for n, c in zip(names, selected)}
    opts = procedure.Options(refine=refiner(fast, nominal))
    parts, calibration = {}, []
    rng = np.random.default_rng(seed)
    for valve in dict.fromkeys(c["valve"] for c in selected):
        vn = [n for n, c in zip(names, selected) if c["valve"] == valve]
        rig = build_rig(valve, vn, values, draws, models[vn[0]], repeat, SUSPECT)
        keys = tuple(d.key for d in models[vn[0]].uncertainties if d.calibrate)
        parts[valve] = procedure.analyse(rig, rng, replace(opts, calibrate={valve: keys}))
        calibration += parts[valve]["calibration"] + tuned_entries(valve, models[vn[0]], vn)
    res = {"parts": parts, "calibration": calibration, "names": names, "selected": selected, "S": S, "unum": unum,
           "uin": uin, "uD": delivery_uncertainty(selected, repeat=repeat), "draws": draws, "repeat": repeat}
    return _assemble(res, quick)


def _ladders(selected, names, S, models, quick, progress) -> dict:
    from studies.validation.numerical import numerical_uncertainty
    from studies.validation.point import Point

    unum = {}
    for n, c in zip(names, selected):
        if progress:
            print(f"  numerical uncertainty (tolerance ladder): {n}", file=sys.stderr, flush=True)
        point = Point(n, models[n], c["speed_rpm"], c["load_pressure"], **(LADDER_QUICK if quick else LADDER))
        unum[n] = numerical_uncertainty(point, reported=S[n], quick=quick)
    return unum


def _area(res: dict) -> tuple[dict, dict]:
    """The u-pooled area metric per valve kind and its detail."""
    from studies.validation.numerical import OUTPUTS

    out = "delivery_cc_per_rev"
    names, selected, draws = res["names"], res["selected"], res["draws"]
    area, detail = {}, {}
    for valve in ("disc", "reed"):
        idx = [i for i, c in enumerate(selected) if c["valve"] == valve]
        if not idx:
            area[valve] = None
            continue
        preds = [draws[names[i]][out][np.isfinite(draws[names[i]][out])] for i in idx]
        pool = u_pooling(preds, [selected[i]["measured_delivery"] * 1e6 for i in idx])
        area[valve] = pool["area"]
        detail[valve] = {"output": out, "unit": OUTPUTS[out], "area_u": pool["area_u"], "u_values": pool["u_values"],
                         "cases": [names[i] for i in idx]}
    return area, detail


def _assemble(res: dict, quick: bool):
    """The tables and the extra results of :func:`pump_validation`."""
    from studies.validation.numerical import OUTPUTS

    parts, names, S, unum, uin = res["parts"], res["names"], res["S"], res["unum"], res["uin"]
    area, detail = _area(res)
    predictions = {n: {o: {"S": S[n][o], "unit": OUTPUTS[o], "u_num": unum[n][o].u, "U_num": unum[n][o].U,
                           "u_num_note": unum[n][o].note, "u_input": uin[n][o].u, "u_input_se": uin[n][o].se,
                           "u_input_precision": uin[n][o].precision,
                           "contributors": [list(x) for x in uin[n][o].contributors]} for o in OUTPUTS}
                   for n in names}
    worst = [e.precision for r in uin.values() for e in r.values() if e.precision is not None]
    mode = ("quick: a two-level tolerance ladder (Fs = 3) and 64 joint draws per rig, cheaper and coarser" if quick
            else "tolerance ladder rtol 1e-3/1e-4/1e-5 (GCI, Fs = 1.25) and 512 joint draws per rig")
    tables = tables_of(parts, area, mode)
    extra = {"calibration": res["calibration"], "prediction": _rows_of(parts, "prediction"),
             "differences": _rows_of(parts, "differences"), "rig_tests": _rows_of(parts, "rig_tests"),
             "detectable_error": {v: p["detectable"] for v, p in parts.items()},
             "repeatability": res["repeat"].as_dict(), "tables": tables, "predictions": predictions,
             "measurement": {n: res["uD"][n].as_dict() for n in names}, "area_metric_detail": detail,
             "draws": {n: int(max(e.samples + e.missing for e in uin[n].values())) for n in names},
             "worst_precision": max(worst) if worst else None, "mode": mode}
    return tables["validation"], extra


def tables_of(parts: dict, area: dict, mode: str) -> dict[str, ValidationTable]:
    """``validation`` (each run, nominal inputs), ``prediction`` (calibration, predicted runs, rig tests) and
    ``differences``, with their notes."""
    return {
        "validation": ValidationTable("Validation of the pump model against each measured delivery (ASME V&V 20), "
                                      "nominal inputs", tuple(_rows_of(parts, "validation")),
                                      tuple(notes_for("validation", parts, mode)), area),
        "prediction": ValidationTable("Calibrated on one condition per rig, the other runs predicted (ASME V&V 20)",
                                      tuple(_rows_of(parts, "prediction") + _rows_of(parts, "rig_tests")),
                                      tuple(notes_for("prediction", parts, mode))),
        "differences": ValidationTable("Differences between conditions of one rig (ASME V&V 20, inputs jointly)",
                                       tuple(_rows_of(parts, "differences")),
                                       tuple(notes_for("differences", parts, mode))),
    }


def notes_for(kind: str, parts: dict, mode: str) -> list[str]:
    """The notes under each table: what S, D and every column are, and which runs calibrated what."""
    rows = [r for p in parts.values() for r in p["validation"]]
    if not rows:
        return []
    common = [
        "u_num: the tolerance ladder of the fast stepper, GCI-style band / 1.15 (ASME V&V 20 section 2-4).",
        "u_input: the thesis models' declarations ([uncertainty] in lumped/data/models/*.toml) by a joint Monte "
        f"Carlo per rig ({mode}): draw k is one set of inputs at every run of the rig, so the rig's comparisons "
        "carry their correlation; se(u_input) is the Monte Carlo's standard error (8 Sobol scrambles), a precision, "
        "not a degree of freedom: the declarations are Type B (infinite dof).",
        "u_D: a single run's repeatability from the paired runs (see repeatability in the JSON; Type A, its dof) and "
        "the gear flow meter, +-0.5 % uniform, one meter common to every run.",
        "k: t(nu_eff) by Welch-Satterthwaite ('welch'), or the 95.45 % coverage interval of the comparison's error "
        "distribution by Monte Carlo ('monte_carlo') where one non-normal input (the air content's uniform range) "
        "carries more than half of u_val^2 (GUM G.6.5, Supplement 1).",
        "detectable: the smallest model-form error in delivery this comparison detects with 80 % probability, in % "
        "of the measured delivery.",
    ]
    if kind == "validation":
        return ["E = S - D at the nominal inputs: S the thesis's model (thesis-disc; thesis-reed: Table 3.13's printed "
                "and identified parameters, f1 and f2 tuned in section 5.5.3), reference stepper at cyclic steady "
                "state; D the measured delivery (Tables 5.4, 5.6).", *common,
                "The runs of a rig share the air content: their verdicts are not independent, and a model-form error "
                "common to every run cannot be told from the air content. prediction.md calibrates it on one "
                "condition per rig and judges the other runs.",
                "disc_delivery_high_pressure is the run the thesis says was not at cyclic steady state (section "
                "5.4.4): reported, left out of u_D, the calibration and the rig tests."]
    if kind == "differences":
        return ["E = (S_a - S_b) - (D_a - D_b): one condition minus the rig's baseline with the same valve measured, "
                "at the nominal inputs; the inputs move both runs at once (the air content largely cancels) and the "
                "flow meter cancels.", *common[:2], common[3], common[4].replace("delivery", "the change")]
    cal = [f"{e['parameter']} of the {e['rig']} rig: {e['value']:.4g} +- {e['u']:.2g} (standard; from the "
           f"measurements {e['u_data']:.2g}, the other inputs {e['u_inputs']:.2g}; prior {e['prior']:.4g} +- "
           f"{e['prior_u']:.2g}), fitted to {', '.join(e['runs'])}" for p in parts.values() for e in p["calibration"]]
    return ["Calibration: " + "; ".join(cal) + ".",
            "E = S - D of the runs not used to calibrate, S the model at the calibrated values (fast path's change "
            "from the nominal run added to the reference stepper's S). u_input: the other inputs with the calibrated "
            "key refitted at every draw (L of studies.validation.joint); u_D: the run's own repeatability and the "
            "calibration runs' through the fit.",
            "Rig rows ('predicted runs together', 'all runs together'): one relative model-form error common to the "
            "runs (generalised least squares with their correlation), in % of the delivery; its chi-square over the "
            "same runs is in the JSON (rig_tests).", *common[:1], *common[3:]]
