"""The baseline judged run by run with its validation uncertainty (ASME V&V 20-2009).

For every run and every output it measures (the delivery; per measured valve its opening and
closing crank angle, its peak opening and its seated position) the comparison error E = S - D of
the baseline model (S simulated, D measured) is set against the validation uncertainty
U_val = k sqrt(u_num^2 + u_input^2 + u_D^2) (:func:`studies.validation.vv20.vv20_row`):

- **u_num**: the output at the workflow's integrator tolerance against the truth tolerance (rtol
  1e-6), a two-level estimate (Fs = 3, order 1 in the tolerance; :func:`studies.validation.numerical.estimate`);
- **u_input**: the model's declared input uncertainties (``[uncertainty."KEY"]`` of the model file,
  lumped/model/uncertainty.py) propagated to first order (GUM eq 10): each key moved by one standard
  uncertainty, one simulation per key and run, u_input = sqrt(sum dS_k^2); the three largest
  contributors are listed. An air content stated in run.toml moves with the declared uncertainty of
  ``oil.air_content`` (it is the same unmeasured quantity);
- **u_D**: the delivery's stated ``delivery_uncertainty_cc`` and a Type A estimate from runs repeated
  at one condition (:func:`studies.validation.measurement.dataset_uncertainty`); angles: the sample
  spacing (rectangular) and the position noise over the trace's slope at the crossing; peak and seated
  position: ``position_uncertainty_rel`` (default the LTS's 1.12 %, section 5.3) of the reading and the
  noise of the samples the value averages.

The same procedure as ``valvelab validate`` (studies.validation.joint): the declarations are
Type B (infinite degrees of freedom; k from Welch-Satterthwaite with the repeated runs' dof),
and where one uniform declaration carries more than half of u_val^2 the interval is the
95.45 % Monte Carlo coverage interval of the linear model sum_k dS_k z_k (z_k drawn from each
declaration's distribution, ``distributions``) with the measurement and the numerics
(``interval``: "welch" or "monte_carlo"). Each row states the smallest model-form error it
detects with 80 % probability (``detectable``, in its unit; ``detectable_pct`` of the delivery),
and :func:`joint_tests` judges one error common to every run of an output, with the runs'
correlation through their shared inputs (generalised least squares, Sigma_ij = sum_k dS_ik dS_jk
plus each run's own u_D and u_num).

An output with |E| > U_val is a model-form error beyond what the numerics, the inputs and the
measurement allow: the disagreements the workflow starts from, and, left after the search, a
gap it must not be silent about (:func:`beyond`).
"""

from __future__ import annotations

import math

import numpy as np

from studies.discrepancy.gap import (Folded, closed_window, event_threshold, predict, valve_events, wrap_deg)

#: pseudo-effects a simulator with ``validation = True`` understands (studies.discrepancy.pump_sim): model keys
#: moved by their uncertainty ({key path: value}), and the integrator tolerance
INPUT = "input"
NUMERICS = "numerics"
#: the tolerance of the truth (u_num's finer level, synthetic data)
TRUTH_RTOL = 1e-6
#: outputs per measured valve: name suffix -> unit
VALVE_OUTPUTS = {"opening_deg": "deg", "closing_deg": "deg", "peak_mm": "mm", "seated_mm": "mm"}
#: the LTS's relative position uncertainty (thesis section 5.3.2, eq 5.11), used when run.toml states none
LTS_POSITION_REL = 0.0112
#: the moving average the event detection smooths with (studies.discrepancy.gap.valve_events) [deg]
SMOOTH_DEG = 2.0


def outputs(run, folded: Folded, sim, nuisance, threshold: dict | None = None) -> dict:
    """{output: value} of a simulated revolution ``sim`` as the run measures it (sensor nuisances applied;
    events at the measured trace's threshold), and the same of the measurement under ``"measured"``."""
    out, meas = {}, {}
    if run.delivery_m3_per_rev is not None:
        out["delivery_cc_per_rev"] = sim.delivery_m3_per_rev * 1e6
        meas["delivery_cc_per_rev"] = run.delivery_m3_per_rev * 1e6
    for valve, theta in folded.crank_deg.items():
        m = folded.position[valve]
        p = predict(sim, valve, theta, run.speed_rpm, nuisance)
        thr = (threshold or {}).get(valve) or event_threshold(m, folded.noise_m[valve])
        em, es = valve_events(theta, m, thr, SMOOTH_DEG), valve_events(theta, p, thr, SMOOTH_DEG)
        win = closed_window(theta, em)
        for name, a, b in (("opening_deg", es.opening_deg, em.opening_deg),
                           ("closing_deg", es.closing_deg, em.closing_deg),
                           ("peak_mm", es.peak_m * 1e3, em.peak_m * 1e3),
                           ("seated_mm", float(np.median(p[win])) * 1e3 if win.sum() >= 5 else None,
                            float(np.median(m[win])) * 1e3 if win.sum() >= 5 else None)):
            out[f"{valve}_{name}"] = a
            meas[f"{valve}_{name}"] = b
    out["measured"] = meas
    return out


def thresholds(folded: Folded) -> dict:
    """The event threshold of each measured valve (studies.discrepancy.gap.event_threshold)."""
    return {v: event_threshold(folded.position[v], folded.noise_m[v]) for v in folded.position}


def measurement_uncertainty(run, folded: Folded, measured: dict, u_delivery) -> dict:
    """{output: (u_D, dof, source)} of a run's measured outputs (see the module docstring)."""
    out = {}
    if "delivery_cc_per_rev" in measured:
        if u_delivery is not None:
            out["delivery_cc_per_rev"] = (u_delivery.u, u_delivery.dof, "; ".join(c.name for c in u_delivery.components))
        else:
            out["delivery_cc_per_rev"] = (0.0, math.inf, "none stated (run.toml delivery_uncertainty_cc)")
    rel = run.position_uncertainty_rel if getattr(run, "position_uncertainty_rel", None) is not None else LTS_POSITION_REL
    for valve, theta in folded.crank_deg.items():
        m, sigma = folded.position[valve], folded.noise_m[valve]
        spacing = 360.0 / max(theta.size, 1)
        k = max(1, int(round(SMOOTH_DEG / spacing)))
        xs = np.convolve(np.concatenate([m[-k:], m, m[:k]]), np.ones(k) / k, mode="same")[k:-k] if k > 1 else m
        slope = np.abs(np.gradient(xs, theta)) if theta.size > 2 else np.zeros_like(xs)
        for name in ("opening_deg", "closing_deg"):
            at = measured.get(f"{valve}_{name}")
            if at is None:
                continue
            i = int(np.argmin(np.abs(wrap_deg(theta - at))))
            s = max(float(slope[i]), 1e-12)
            out[f"{valve}_{name}"] = (math.hypot(spacing / math.sqrt(12.0), sigma / math.sqrt(k) / s), math.inf,
                                      "sample spacing, noise over the slope")
        peak = measured.get(f"{valve}_peak_mm")
        if peak is not None:
            out[f"{valve}_peak_mm"] = (math.hypot(rel * peak, 1e3 * sigma / math.sqrt(k)), math.inf,
                                       f"position sensor {rel:.3g} of reading, noise")
        seated = measured.get(f"{valve}_seated_mm")
        if seated is not None:
            n = max(5, int(0.5 * theta.size))
            out[f"{valve}_seated_mm"] = (math.hypot(rel * abs(seated), 1e3 * 1.2533 * sigma / math.sqrt(n)), math.inf,
                                         f"position sensor {rel:.3g} of reading, noise of the median")
    return out


def unit_of(output: str) -> str:
    if output == "delivery_cc_per_rev":
        return "cc/rev"
    return next(u for k, u in VALVE_OUTPUTS.items() if output.endswith(k))


def difference(a, b, output: str) -> float | None:
    """a - b of an output (angles wrapped to (-180, 180])."""
    if a is None or b is None:
        return None
    return float(wrap_deg(a - b)) if output.endswith("_deg") else float(a - b)


def rows(run_name: str, base: dict, fine: dict | None, perturbed: list[tuple[str, dict]], u_d: dict,
         distributions: dict | None = None, seed: int = 0) -> list[dict]:
    """The V&V 20 rows of one run: ``base`` the baseline's outputs (with "measured"), ``fine`` the same at the
    truth tolerance (None: no u_num), ``perturbed`` [(declaration key, outputs)] one per declared uncertainty,
    each moved by one standard uncertainty; ``distributions`` {key: "normal" or "uniform"} of the declarations
    (None or a key missing: normal)."""
    from studies.validation.numerical import estimate

    out = []
    meas = base["measured"]
    rng = np.random.default_rng(seed)
    for name, d in meas.items():
        s = base.get(name)
        if s is None or d is None:
            continue
        unit = unit_of(name)
        u_num = 0.0
        note = "no tolerance ladder (the simulator has none)"
        if fine is not None and fine.get(name) is not None:
            diff = difference(fine[name], s, name)
            est = estimate(name, unit, (1e-6, 1e-4), [s + diff, s], s, "fit tolerance")
            u_num, note = (est.u or 0.0), est.note
        sens = {}
        for key, o in perturbed:
            ds = difference(o.get(name), s, name)
            if ds is not None:
                sens[key] = ds
        ud, dof, src = u_d.get(name, (0.0, math.inf, "none"))
        row = _row((run_name, name, unit), (s, d), u_num, sens, (ud, dof), distributions or {}, rng)
        row.update(run=run_name, u_num_note=note, u_D_source=src, sensitivities=sens)
        out.append(row)
    return out


def _row(what: tuple, values: tuple, u_num: float, sens: dict, u_d: tuple, distributions: dict, rng) -> dict:
    """One row by the procedure of studies.validation.joint: the budget, the interval, the detectable error
    (``what``: run, output, unit; ``values``: S, D; ``u_d``: (u_D, its dof))."""
    run_name, name, unit = what
    s, d = values
    from studies.validation import joint
    from studies.validation.vv20 import Components, vv20_row

    contrib = sorted(((k, abs(v)) for k, v in sens.items()), key=lambda kv: -kv[1])
    u_input = math.sqrt(sum(c * c for _, c in contrib))
    ud, dof = u_d
    uniform = [(k, v * v) for k, v in contrib if distributions.get(k) == "uniform"]
    u_val2 = u_num**2 + u_input**2 + ud**2
    top = max(uniform, key=lambda kv: kv[1], default=(None, 0.0))
    dominant = top[0] if u_val2 > 0.0 and top[1] > joint.DOMINANT_SHARE * u_val2 else None
    b = joint.Budget(u_num, u_input, None, ud, 0.0, dof, tuple(contrib), None, dominant)
    samples = linear_samples(sens, distributions, b, rng)
    k, how = joint.interval(b, samples)
    E = difference(s, d, name)
    row = vv20_row(run_name, name, unit, d + E, d, Components(u_num, u_input, ud, (math.inf, math.inf, dof)),
                   contributors=contrib[:3], coverage=(k, how))
    det = joint.detectable(samples, row["U_val"], 1.0) if u_val2 > 0.0 else None
    row["detectable"] = det
    row["detectable_pct"] = (det / abs(d) * 100.0 if det is not None and d else None) if unit == "cc/rev" else None
    return row


def linear_samples(sens: dict, distributions: dict, b, rng, n: int = 20_000) -> np.ndarray:
    """Draws of the comparison's error when the model is right, from the first-order model: sum_k dS_k z_k (z_k of
    each declaration's distribution, unit variance), the measurement (s t_nu for a Type A u_D) and the numerics."""
    x = np.zeros(n)
    for key, ds in sens.items():
        if distributions.get(key) == "uniform":
            x += ds * math.sqrt(3.0) * rng.uniform(-1.0, 1.0, n)
        else:
            x += ds * rng.standard_normal(n)
    t = rng.standard_t(b.repeat_dof, n) if math.isfinite(b.repeat_dof) else rng.standard_normal(n)
    return x + b.u_repeat * t + b.u_num * rng.standard_normal(n)


def _own_variance(row: dict) -> float:
    """A run's own variance (measurement and numerics); a row without its budget: (U_val / 2)^2."""
    if "u_D" in row:
        return row["u_D"] ** 2 + row.get("u_num", 0.0) ** 2
    return (row["U_val"] / 2.0) ** 2


def joint_tests(rows_: list[dict]) -> list[dict]:
    """Per output measured in two or more runs: one model-form error common to them, estimated by generalised
    least squares with their correlation (the shared inputs' sensitivities), its U_val (k from the smallest dof of
    the runs' u_D, else 2) and verdict, and the chi-square of the runs against their covariance (any pattern)."""
    from scipy.stats import chi2

    from studies.validation.vv20 import coverage_factor

    groups: dict = {}
    for r in rows_:
        groups.setdefault(r["output"], []).append(r)
    out = []
    for name, rs in groups.items():
        if len(rs) < 2:
            continue
        keys = sorted({k for r in rs for k in r.get("sensitivities", {})})
        A = np.array([[r.get("sensitivities", {}).get(k, 0.0) for k in keys] for r in rs]).reshape(len(rs), len(keys))
        V = A @ A.T + np.diag([_own_variance(r) for r in rs])
        E = np.array([r["E"] for r in rs])
        one = np.ones(len(rs))
        try:
            w = np.linalg.solve(V, one)
        except np.linalg.LinAlgError:           # no uncertainty at all: nothing to judge against
            continue
        u = math.sqrt(1.0 / float(one @ w))
        est = float(w @ E) * u * u
        dofs = [r.get("dof") for r in rs if r.get("dof") is not None]
        U = coverage_factor(min(dofs) if dofs else math.inf) * u
        x2 = float(E @ np.linalg.solve(V, E))
        out.append({"output": name, "unit": rs[0]["unit"], "runs": [r["run"] for r in rs], "E": est, "u_val": u,
                    "U_val": U, "delta_model": [est - U, est + U],
                    "verdict": "within" if abs(est) <= U else "model_form_error",
                    "chi2": x2, "chi2_dof": len(rs), "chi2_p": float(chi2.sf(x2, len(rs)))})
    return out


def after(rows_: list[dict], final: dict) -> list[dict]:
    """The rows of the final model: its E against the baseline's U_val (the uncertainties are the baseline's)."""
    from studies.validation.vv20 import verdict_words

    out = []
    for r in rows_:
        s = final.get(r["run"], {}).get(r["output"])
        if s is None:
            continue
        E = difference(s, r["D"], r["output"])
        row = {k: r[k] for k in ("run", "output", "unit", "D", "U_val")}
        row.update(S=r["D"] + E, E=E, delta_model=[E - r["U_val"], E + r["U_val"]],
                   verdict="within" if abs(E) <= r["U_val"] else "model_form_error")
        row["words"] = verdict_words(row)
        out.append(row)
    return out


#: the smallest |E| counted as a disagreement, whatever U_val, per unit: the gap's own tolerances
#: (studies.discrepancy.gap.GapScales: 20 um of position; findings: 2 crank degrees; 0.5 % of the delivery).
#: A seat stiffness fitted within 1 % still leaves its valve's seated position 9-12 um off, beyond a U_val of
#: 4-5 um that knows nothing of the fitted parameter's own uncertainty.
FLOOR = {"mm": 0.02, "deg": 2.0, "cc/rev": None}
DELIVERY_FLOOR = 0.005


def _floor(row: dict) -> float:
    if row["unit"] == "cc/rev":
        return DELIVERY_FLOOR * abs(row["D"])
    return FLOOR.get(row["unit"]) or 0.0


def beyond(rows_: list[dict]) -> list[dict]:
    """Outputs beyond their validation uncertainty, and beyond the gap's tolerance (FLOOR), in at least half of
    the runs that measure them (and two): ``[{"output", "unit", "runs", "of", "E": [...], "U_val": [...],
    "joint": ...}]``, the largest |E| / U_val first, each with the output's :func:`joint_tests` entry. One run in
    twenty beyond U_val is the coverage (k = 2) and not a finding."""
    joint = {j["output"]: j for j in joint_tests(rows_)}
    groups: dict = {}
    for r in rows_:
        groups.setdefault(r["output"], []).append(r)
    out = []
    for name, rs in groups.items():
        bad = [r for r in rs if r["verdict"] != "within" and abs(r["E"]) > _floor(r)]
        if len(bad) >= max(2, math.ceil(len(rs) / 2)):
            out.append({"output": name, "unit": rs[0]["unit"], "runs": [r["run"] for r in bad], "of": len(rs),
                        "E": [r["E"] for r in bad], "U_val": [r["U_val"] for r in bad],
                        "ratio": max(abs(r["E"]) / r["U_val"] if r["U_val"] > 0 else math.inf for r in bad),
                        "joint": joint.get(name)})
    return sorted(out, key=lambda b: -b["ratio"])


def sentence(b: dict) -> str:
    """One output beyond its validation uncertainty in words."""
    name = b["output"].replace("_cc_per_rev", "").replace("_deg", " angle").replace("_mm", " position")
    name = name.replace("_", " ")
    lo, hi = min(b["E"]), max(b["E"])
    rng = f"{lo:+.3g}" if len(b["E"]) == 1 else f"{lo:+.3g} to {hi:+.3g}"
    return (f"{name}: E = S - D = {rng} {b['unit']}, beyond U_val = {min(b['U_val']):.2g}-{max(b['U_val']):.2g} "
            f"{b['unit']} in {len(b['runs'])} of {b['of']} runs")
