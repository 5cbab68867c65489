"""The validation procedure of a rig's runs: every run, a calibration on stated runs, the others predicted, the
differences between conditions, the rig-level tests and the smallest model-form error each detects.

Pure numerics on a :class:`studies.validation.joint.Rig` (no simulation), so that
``valvelab validate`` and the coverage benchmark (:mod:`studies.validation.coverage`) run the
same procedure, the benchmark on synthetic measurements. Per rig:

1. ``validation``: each run at the nominal inputs (the declared air content with its prior
   range), one V&V 20 row each; the rows of a rig are not independent (they share the air
   content), so their count is no test;
2. ``calibration``: the declarations marked ``calibrate = true`` (the air content) fitted to the
   runs of one condition (:data:`CALIBRATION_CONDITION`: each rig's baseline, both of its
   runs), with the fit's uncertainty from those runs' measurements and from the other inputs;
3. ``prediction``: the other runs predicted with the fitted values, their uncertainty
   propagated through the calibration (the map L of :mod:`studies.validation.joint`);
4. ``differences``: each condition minus the baseline, per measured valve, at the nominal
   inputs (the air content largely cancels; the meter cancels);
5. ``rig_tests``: one relative model-form error common to the predicted runs (and, without
   calibration, to all runs), estimated by generalised least squares with the runs'
   correlation, with a chi-square of any pattern; the suspect runs (studies.validation.measurement.SUSPECT)
   are reported but left out of the calibration and the rig tests;
6. ``detectable``: per row and per rig, the smallest relative model-form error detected with
   80 % probability on the row's own error distribution.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from studies.validation import joint
from studies.validation.vv20 import Components, vv20_row

#: the condition whose runs calibrate each rig (its baseline: the thesis's reference point)
CALIBRATION_CONDITION = {"disc": "baseline", "reed": "low_speed"}
#: the condition the differences are taken from
BASELINE = CALIBRATION_CONDITION
OUTPUT = "delivery_cc_per_rev"


def parts(case: str) -> tuple[str, str, str]:
    """(valve, measured valve, condition) of a case name, e.g. ``disc_inlet_high_speed``."""
    valve, measured, *condition = case.split("_")
    return valve, measured, "_".join(condition)


@dataclass(frozen=True)
class Options:
    """How the procedure runs: the calibrated keys per rig, Monte Carlo samples per interval, whether to solve for
    the detectable errors, and a ``refine(rig, calibration) -> S`` that replaces the linear prediction."""

    calibrate: dict = field(default_factory=dict)
    samples: int = joint.INTERVAL_SAMPLES
    power: bool = True
    refine: object = None


def combination_row(rig: joint.Rig, c, case: str, values: tuple[float, float], response: float, rng, opts: Options,
                    unit: str | None = None) -> dict:
    """The V&V 20 row of the combination c^T E (``values``: its S and D) with its interval and detectable error."""
    b = joint.budget(rig, c)
    samples = joint.error_samples(rig, c, b, rng, opts.samples)
    k, how = joint.interval(b, samples)
    u = Components(b.u_num, b.u_input, b.u_D, (None, None, b.u_D_dof))
    row = vv20_row(case, OUTPUT, unit or rig.unit, *values, u,
                   contributors=b.contributors[:3], coverage=(k, how))
    row["u_input_se"] = b.u_input_se
    det = joint.detectable(samples, row["U_val"], response) if opts.power else None
    row["detectable_pct"] = None if det is None else det * 100.0
    row["linear_r2"] = b.linear_r2
    return row


def validation_rows(rig: joint.Rig, rng, opts: Options) -> list[dict]:
    """Each run at the nominal inputs (c = e_j); a model-form error delta of run j moves E_j by delta D_j."""
    rows = []
    for j, name in enumerate(rig.cases):
        c = np.zeros(len(rig.cases))
        c[j] = 1.0
        rows.append(_flag(combination_row(rig, c, name, (rig.S[j], rig.D[j]), rig.D[j], rng, opts), rig, [j]))
    return rows


def difference_rows(rig: joint.Rig, rng, opts: Options) -> list[dict]:
    """Each condition minus the baseline per measured valve, at the nominal inputs; delta is the error in the
    change, relative to the condition's delivery."""
    rows = []
    for a, name in enumerate(rig.cases):
        valve, measured, cond = parts(name)
        if cond == BASELINE.get(valve):
            continue
        base = f"{valve}_{measured}_{BASELINE.get(valve)}"
        if base not in rig.cases:
            continue
        b = rig.index(base)
        c = np.zeros(len(rig.cases))
        c[a], c[b] = 1.0, -1.0
        row = combination_row(rig, c, f"{name}-{base}", (rig.S[a] - rig.S[b], rig.D[a] - rig.D[b]), rig.D[a], rng,
                              opts)
        rows.append(_flag(row, rig, [a, b]))
    return rows


def _flag(row: dict, rig: joint.Rig, idx) -> dict:
    bad = [rig.cases[i] for i in idx if rig.suspect[i]]
    row["suspect"] = bool(bad)
    if bad:
        row["words"] += " (suspect run, section 5.4.4: not at cyclic steady state)"
    return row


def calibration_runs(rig: joint.Rig) -> list[int]:
    """The runs of the rig's calibration condition, suspect runs left out."""
    cond = CALIBRATION_CONDITION.get(rig.name)
    return [i for i, n in enumerate(rig.cases) if parts(n)[2] == cond and not rig.suspect[i]]


def calibrated(rig: joint.Rig, keys, opts: Options) -> tuple[joint.Calibration, np.ndarray, list[dict]]:
    """The calibration, the predicted S of every run and the ``calibration`` entries (CONTRACT keys)."""
    C = calibration_runs(rig)
    cal = joint.calibrate(rig, keys, C)
    G = rig.slopes()[:, [rig.keys.index(k) for k in cal.keys]]
    if opts.refine is None:
        S_pred, shift = rig.S + G @ cal.shift, cal.shift
    else:
        S_pred, shift = opts.refine(rig, cal)
    entries = []
    for j, key in enumerate(cal.keys):
        nominal, standard = rig.priors[key]
        u_data, u_in = np.sqrt(cal.cov_data[j, j]) * standard, np.sqrt(cal.cov_inputs[j, j]) * standard
        reach = np.sqrt(3.0) if rig.uniform[rig.keys.index(key)] else 4.0
        entries.append({"parameter": key, "rig": rig.name, "value": nominal + shift[j] * standard,
                        "linear_value": nominal + cal.shift[j] * standard,
                        "u": float(np.hypot(u_data, u_in)), "runs": [rig.cases[i] for i in C],
                        "u_data": float(u_data), "u_inputs": float(u_in), "prior": nominal, "prior_u": standard,
                        "within_prior": bool(abs(shift[j]) <= reach),
                        "predicted_runs": [n for i, n in enumerate(rig.cases) if i not in C],
                        "how": "weighted least squares on the runs' slopes (joint Monte Carlo), the model at the "
                               "other inputs' nominal values"})
    return cal, np.asarray(S_pred, dtype=float), entries


def prediction_rows(rig: joint.Rig, cal: joint.Calibration, S_pred, rng, opts: Options) -> list[dict]:
    """The runs not used to calibrate, predicted with the calibrated values (c = row j of L)."""
    rows = []
    for j, name in enumerate(rig.cases):
        if j in cal.runs:
            continue
        row = combination_row(rig, cal.L[j], name, (S_pred[j], rig.D[j]), rig.D[j], rng, opts)
        rows.append(_flag(row, rig, [j]))
    return rows


def rig_test(rig: joint.Rig, cal: joint.Calibration | None, S_after, rng, opts: Options) -> dict:
    """One relative model-form error common to the rig's judged runs (the predicted ones after ``cal``, else all),
    suspect runs left out: its GLS estimate as a row in % (S - D = 100 delta), and the chi-square of the runs."""
    held = [i for i in range(len(rig.cases)) if not rig.suspect[i] and (cal is None or i not in cal.runs)]
    c_full, c_held = joint.rig_weights(rig, cal, held)
    S_after = np.asarray(S_after, dtype=float)
    label = "predicted runs together" if cal is not None else "all runs together, nominal inputs"
    row = combination_row(rig, 100.0 * c_full, f"{rig.name}: {label}",
                          (100.0 * float(c_held @ S_after), 100.0 * float(c_held @ rig.D)), 100.0, rng, opts,
                          unit="% of D")
    x2, dof, p = joint.chi_square(rig, cal, held, S_after - rig.D)
    row.update(runs=[rig.cases[i] for i in held], calibrated=cal is not None, chi2=x2, chi2_dof=dof, chi2_p=p)
    return row


def analyse(rig: joint.Rig, rng, opts: Options) -> dict:
    """Every part of the procedure for one rig (see the module docstring)."""
    out = {"validation": validation_rows(rig, rng, opts), "differences": difference_rows(rig, rng, opts),
           "calibration": [], "prediction": [], "rig_tests": [rig_test(rig, None, rig.S, rng, opts)]}
    keys = opts.calibrate.get(rig.name, ())
    if keys and calibration_runs(rig):
        cal, S_pred, entries = calibrated(rig, keys, opts)
        out["calibration"] = entries
        out["prediction"] = prediction_rows(rig, cal, S_pred, rng, opts)
        out["rig_tests"].insert(0, rig_test(rig, cal, S_pred, rng, opts))
    out["detectable"] = detectable_summary(out)
    return out


def detectable_summary(part: dict) -> dict:
    """``{"case", "rig", "cases", ...}`` in percent: the best single predicted case (every case in ``cases``), the
    calibrated rig test; the nominal-input ones beside them (``uncalibrated_case``, ``uncalibrated_rig``)."""
    def pct(rows):
        return {r["case"]: r["detectable_pct"] for r in rows if not r.get("suspect")}

    pred, val = pct(part["prediction"]), pct(part["validation"])
    tests = {t["calibrated"]: t["detectable_pct"] for t in part["rig_tests"]}
    finite = [v for v in pred.values() if v is not None]
    vfinite = [v for v in val.values() if v is not None]
    return {"case": min(finite) if finite else None, "rig": tests.get(True),
            "cases": pred, "uncalibrated_case": min(vfinite) if vfinite else None, "uncalibrated_cases": val,
            "uncalibrated_rig": tests.get(False), "differences": pct(part["differences"])}
