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


def rows(run_name: str, base: dict, fine: dict | None, perturbed: list[tuple[str, dict]], u_d: dict) -> list[dict]:
    """The V&V 20 rows of one run: ``base`` the baseline's outputs (with "measured"), ``fine`` the same at the
    truth tolerance (None: no u_num), ``perturbed`` [(declaration key, outputs)] one per declared uncertainty."""
    from studies.validation.numerical import estimate
    from studies.validation.vv20 import vv20_row

    out = []
    meas = base["measured"]
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
        contrib = []
        for key, o in perturbed:
            ds = difference(o.get(name), s, name)
            if ds is not None:
                contrib.append((key, abs(ds)))
        u_input = math.sqrt(sum(c * c for _, c in contrib))
        contrib.sort(key=lambda kv: -kv[1])
        ud, dof, src = u_d.get(name, (0.0, math.inf, "none"))
        E = difference(s, d, name)
        row = vv20_row(run_name, name, unit, d + E, d, u_num, u_input, ud, dof=(math.inf, math.inf, dof),
                       contributors=contrib[:3])
        row["run"] = run_name
        row["u_num_note"] = note
        row["u_D_source"] = src
        out.append(row)
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
    the runs that measure them (and two): ``[{"output", "unit", "runs", "of", "E": [...], "U_val": [...]}]``,
    the largest |E| / U_val first. One run in twenty beyond U_val is the coverage (k = 2) and not a finding."""
    groups: dict = {}
    for r in rows_:
        groups.setdefault(r["output"], []).append(r)
    out = []
    for name, rs in groups.items():
        bad = [r for r in rs if r["verdict"] != "within" and abs(r["E"]) > _floor(r)]
        if len(bad) >= max(2, math.ceil(len(rs) / 2)):
            out.append({"output": name, "unit": rs[0]["unit"], "runs": [r["run"] for r in bad], "of": len(rs),
                        "E": [r["E"] for r in bad], "U_val": [r["U_val"] for r in bad],
                        "ratio": max(abs(r["E"]) / r["U_val"] if r["U_val"] > 0 else math.inf for r in bad)})
    return sorted(out, key=lambda b: -b["ratio"])


def sentence(b: dict) -> str:
    """One output beyond its validation uncertainty in words."""
    name = b["output"].replace("_cc_per_rev", "").replace("_deg", " angle").replace("_mm", " position")
    name = name.replace("_", " ")
    lo, hi = min(b["E"]), max(b["E"])
    rng = f"{lo:+.3g}" if len(b["E"]) == 1 else f"{lo:+.3g} to {hi:+.3g}"
    return (f"{name}: E = S - D = {rng} {b['unit']}, beyond U_val = {min(b['U_val']):.2g}-{max(b['U_val']):.2g} "
            f"{b['unit']} in {len(b['runs'])} of {b['of']} runs")
