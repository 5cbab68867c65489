"""Candidates the data cannot tell apart, and the evidence that would.

A round's winner W and another effect R that passed the decision rule too are indistinguishable when they fit
about equally (their held-out costs within the rule's absolute gain floor, their fit costs within the fraction
that counts as decisive) and explain the same part of the data (the best combination of the changes each makes
to the residuals gains too little over either alone to pass the rule's gain floors). The data then do not say
which is there: the workflow names
neither and reports them in the JSON's ``indistinguishable`` with the evidence that would separate them: where,
at each run's operating condition, the two models' revolutions differ most (a valve position, the cylinder
pressure, the delivery), in the gap's scales (``studies.discrepancy.gap.GapScales``), measured there or not.

Where they differ most, the data may still decide (:func:`window_test`): over the measured windows of that
evidence, a model that fits them better by a chi-square difference that is very strong evidence, and whose
residual there is the noise (within three standard deviations), is the one the data pick; the winner so picked
is told apart from the other. Where neither residual is the noise, or they fit the windows alike, the pair
stays indistinguishable.
"""

from __future__ import annotations

import numpy as np

from scipy.stats import chi2 as _chi2

from geometry.errors import ModelFailure
from studies.discrepancy.gap import crank_windows, periodic_interp
from studies.discrepancy.records import CandidateFit
from studies.discrepancy.selection import gain_reason

#: the crank grid the two models' revolutions are compared on [deg]
_GRID = np.arange(0.0, 360.0, 0.5)
#: at most this many places of evidence per pair (the largest differences)
MAX_EVIDENCE = 3
#: the model the windows pick fits them better by at least this chi-square (2 ln of the likelihood ratio: "very
#: strong" evidence on Kass & Raftery's 1995 scale) ...
WINDOW_DCHI2 = 10.0
#: ... and its residual there is consistent with the noise: its chi-square has at least this upper-tail
#: probability under noise alone (three standard deviations, one-sided)
WINDOW_P = 1.35e-3


def group(pb, base_model: tuple, order: list, winner: CandidateFit, rnd: int) -> dict | None:
    """The round's candidates indistinguishable from its winner (module docstring) as one JSON entry: the
    effects (the winner first), their parameters, fit and held-out costs, and per alternative the evidence that
    would separate it from the winner; None when every other candidate is told apart. ``base_model``: the
    model the round's candidates extend."""
    alike = [f for f in order if f is not winner and f.effect != winner.effect and f.why_not_added is None
             and not f.failed and _alike(pb, winner, f) and _substitutes(pb, base_model, winner, f)]
    separating = []
    for f in list(alike):
        try:
            ev_w, ev_f = pb.evaluate(winner.model), pb.evaluate(f.model)
            evidence = separating_evidence(pb, ev_w, ev_f)
            judged = window_test(pb, evidence, ev_w, ev_f)
        except ModelFailure:
            evidence, judged = [], None
        if judged is not None and judged["picks"] == 0:
            # where the two differ most, the winner fits far better and its residual is the noise: told apart
            alike.remove(f)
            pb.log(f"round {rnd}: {winner.key} told apart from {f.key} where they differ most "
                   f"({_window_words(judged, winner.key, f.key)})")
            continue
        separating.append({"effects": [winner.key, f.key], "evidence": evidence, "windows": judged})
    if not alike:
        return None
    fits = [winner, *alike]
    return {"round": rnd, "effects": [f.key for f in fits], "parameters": {f.key: f.reported for f in fits},
            "fit_cost": [f.fit_cost for f in fits], "held_out_cost": [f.held_cost for f in fits],
            "base_fit_cost": winner.base_fit_cost, "base_held_out_cost": winner.base_held_cost,
            "separating": separating, "sentence": _sentence(fits, separating[0])}


def _alike(pb, a: CandidateFit, b: CandidateFit) -> bool:
    """Whether two candidates fit the data about equally: their held-out costs within the rule's absolute gain
    floor (``Problem.min_gain_units``: what noise lets a wrong effect gain) and their fit costs within the
    fraction that counts as decisive (Settings.decisive_fit_improvement) of the lower."""
    if a.held_cost is not None and b.held_cost is not None and abs(a.held_cost - b.held_cost) >= pb.min_gain_units:
        return False
    low = min(a.fit_cost, b.fit_cost)
    return abs(a.fit_cost - b.fit_cost) < pb.settings.decisive_fit_improvement * low


def _substitutes(pb, base_model: tuple, a: CandidateFit, b: CandidateFit) -> bool:
    """Whether two candidates explain the same part of the data: with d_a, d_b the changes each makes to the
    base's fit residuals, the best linear combination of both gains too little over either alone to pass the
    rule's gain floors (``selection.gain_reason`` on the fit costs). Two effects that each explain a different
    half of a gap (a compliant seat and a squeeze film) are complements, not alternatives."""
    r0 = pb.residual_vector(base_model)
    ra, rb = pb.residual_vector(a.model), pb.residual_vector(b.model)
    if r0 is None or ra is None or rb is None or not r0.size == ra.size == rb.size:
        return False
    d = np.column_stack([r0 - ra, r0 - rb])
    both = r0 - d @ np.linalg.lstsq(d, r0, rcond=None)[0]
    cost_both = float(both @ both)
    for col in (0, 1):
        one = r0 - d[:, col] * (float(d[:, col] @ r0) / max(float(d[:, col] @ d[:, col]), 1e-300))
        if gain_reason(pb.settings, pb.min_gain_units, (float(one @ one), cost_both), None) is None:
            return False
    return True


def separating_evidence(pb, ev_a, ev_b) -> list[dict]:
    """Where two evaluated models differ most, per run condition and signal (both valves' positions, the
    cylinder pressure, the delivery), in units of the gap's scales: the largest first, at most MAX_EVIDENCE."""
    sc = pb.settings.scales
    found = []
    for r in pb.runs:
        sa, sb = ev_a.sims[r.name], ev_b.sims[r.name]
        measured = set(r.measured_valves) if r.trace is not None else set()
        signals = [(f"{v} position", sa.positions[v], sb.positions[v], sc.position_m, "m", v in measured)
                   for v in ("inlet", "delivery") if v in sa.positions and v in sb.positions]
        if sa.cylinder_pressure_pa is not None and sb.cylinder_pressure_pa is not None:
            has_p = r.trace is not None and r.trace.cylinder_pressure_pa is not None
            signals.append(("cylinder pressure", sa.cylinder_pressure_pa, sb.cylinder_pressure_pa, sc.pressure_pa,
                            "Pa", has_p))
        for name, xa, xb, scale, unit, seen in signals:
            d = periodic_interp(_GRID, sa.crank_deg, xa) - periodic_interp(_GRID, sb.crank_deg, xb)
            wins = crank_windows(_GRID, d, scale) or [(0.0, 360.0, float(d[np.argmax(np.abs(d))]))]
            a, e, peak = max(wins, key=lambda w: abs(w[2]))
            found.append(_place(r, name, [a, e], peak, unit, abs(peak) / scale, seen))
        dd = (sa.delivery_m3_per_rev - sb.delivery_m3_per_rev) / max(abs(sb.delivery_m3_per_rev), 1e-30)
        found.append(_place(r, "delivery", None, 100.0 * dd, "%", abs(dd) / sc.delivery_frac,
                            r.delivery_cc_per_rev is not None))
    found.sort(key=lambda d: -d["in_gap_scales"])
    return found[:MAX_EVIDENCE]


def window_test(pb, places: list, ev_a, ev_b) -> dict | None:
    """The two models judged where they differ most: over the measured places of evidence (position and
    cylinder-pressure windows), each one's residual as chi-square in the white noise of each signal, chi2 =
    sum (r / sigma)^2 on the n samples of the windows, and its upper-tail probability under noise alone
    (scipy.stats.chi2). ``picks``: 0 (the first model) or 1 when that one fits the windows better by a
    chi-square difference of at least WINDOW_DCHI2 (the likelihood ratio of the two, the noise known) and its
    residual is consistent with the noise there (p >= WINDOW_P: the better of two misfits is no pick); else
    None. None when no place has a measured trace (the delivery, an unmeasured signal)."""
    used = [p for p in places if p["measured"] and p["crank_deg"] is not None and p["signal"] != "delivery"]
    stats = []
    for ev in (ev_a, ev_b):
        chi2, n = 0.0, 0
        for place in used:
            got = _window_residual(pb, ev, place)
            if got is None or not got[1] > 0.0:
                return None
            chi2 += float(np.sum((got[0] / got[1]) ** 2))
            n += got[0].size
        if n < 3:
            return None
        stats.append((chi2, n, float(_chi2.sf(chi2, n))))
    better = 0 if stats[0][0] <= stats[1][0] else 1
    picks = None
    if stats[better][2] >= WINDOW_P and stats[1 - better][0] - stats[better][0] >= WINDOW_DCHI2:
        picks = better
    return {"places": [[p["run"], p["signal"], p["crank_deg"]] for p in used], "samples": stats[0][1],
            "chi2_per_sample": [c / n for c, n, _ in stats], "p_noise": [p for _, _, p in stats], "picks": picks}


def _window_residual(pb, ev, place: dict):
    """(measured - modelled residuals in the place's crank window, the signal's white-noise deviation)."""
    g = next((g for g in ev.gaps if g.run == place["run"]), None)
    if g is None:
        return None
    if place["signal"] == "cylinder pressure":
        if g.pressure is None:
            return None
        r, theta, sigma = g.pressure.residual_pa, g.pressure.crank_deg, pb.folded[g.run].pressure_noise_pa
    else:
        valve = place["signal"].split()[0]
        v = next((v for v in g.valves if v.valve == valve), None)
        if v is None:
            return None
        r, theta, sigma = v.residual_m, v.crank_deg, v.noise_m
    a, e = place["crank_deg"]
    width = 360.0 if e - a >= 360.0 else np.mod(e - a, 360.0)
    inside = np.mod(np.asarray(theta) - a, 360.0) <= width
    return np.asarray(r)[inside], float(sigma)


def _place(run, signal: str, window, difference: float, unit: str, scales: float, measured: bool) -> dict:
    return {"run": run.name, "speed_rpm": float(run.speed_rpm), "load_pressure_pa": float(run.load_pressure_pa),
            "signal": signal, "crank_deg": window, "difference": float(difference), "unit": unit,
            "in_gap_scales": float(scales), "measured": bool(measured)}


def _window_words(judged: dict, a: str, b: str) -> str:
    """The window judgement in words: each model's chi-square per sample over the windows' samples."""
    c = judged["chi2_per_sample"]
    return (f"over {judged['samples']} measured samples in {len(judged['places'])} window(s) the residual is "
            f"{c[0]:.2f} noise variances a sample for {a} (p = {judged['p_noise'][0]:.2g}) and {c[1]:.2f} for {b} "
            f"(p = {judged['p_noise'][1]:.2g})")


def _sentence(fits: list, sep: dict) -> str:
    """The group in words, with the place the first two models differ most and, where measured, how each
    fits there (``sep``: the first pair's entry of ``separating``)."""
    evidence = sep["evidence"]
    keys = " and ".join(f.key for f in fits)
    costs = ", ".join(f"{f.fit_cost:.3g}" for f in fits)
    held = "" if any(f.held_cost is None for f in fits) else \
        "; held out " + ", ".join(f"{f.held_cost:.3g}" for f in fits)
    s = (f"{keys} explain the data about equally (fit cost {costs}{held}, from {fits[0].base_fit_cost:.3g}); "
         "none is named: the data do not say which")
    if evidence:
        e = evidence[0]
        where = "" if e["crank_deg"] is None else f" at crank {e['crank_deg'][0]:.0f}-{e['crank_deg'][1]:.0f} deg"
        s += (f"; {fits[0].key} and {fits[1].key} differ most in the {e['signal']} at {e['speed_rpm']:.0f} rpm and "
              f"{e['load_pressure_pa'] / 1e6:.2f} MPa{where} ({e['difference']:.3g} {e['unit']}, "
              f"{e['in_gap_scales']:.2g} gap scales; {'measured in' if e['measured'] else 'not measured in'} "
              f"run {e['run']})")
    if sep.get("windows") is not None:
        s += "; " + _window_words(sep["windows"], fits[0].key, fits[1].key)
    return s
