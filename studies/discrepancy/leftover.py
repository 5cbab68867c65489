"""What the final model leaves, the baseline's validation table, and where the simulations went.

:func:`unexplained` is the JSON's ``unexplained`` object (docs/discrepancy.md, "Never silent on a large gap"):
the cost left by signal, the outputs still beyond their validation uncertainty, the crank windows of the
residuals, the best partial candidates of the last round and the nuisances pinned to a bound, in words when
the gap is large. :func:`validate` is the baseline's V&V 20 table (``studies.discrepancy.validation``).
"""

from __future__ import annotations

from lumped.model.effects import Applied
from geometry.errors import InputError
from studies.discrepancy import validation as val
from studies.discrepancy.gap import Folded, pressure_windows
from studies.discrepancy.records import Evaluation, json_safe
from studies.discrepancy.simulations import SimulationFailure
from studies.discrepancy.validation import INPUT, NUMERICS, TRUTH_RTOL


def outputs_of(pb, ev: Evaluation) -> dict:
    """{run: {output: value}} of an evaluated model (studies.discrepancy.validation.outputs)."""
    out = {}
    for r in pb.runs:
        f = pb.folded.get(r.name, Folded({}, {}, {}))
        out[r.name] = val.outputs(r, f, ev.sims[r.name], ev.nuisance, val.thresholds(f))
    return out


def _declarations(pb) -> tuple:
    """(the pump model or None, the input uncertainties it declares)."""
    model = pb.context if not isinstance(pb.context, str) else None
    return model, tuple(getattr(model, "uncertainties", ()) or ())


def _perturbed_inputs(pb) -> list:
    """(key, applied INPUT effect) per input uncertainty the pump model declares, moved by one standard
    uncertainty."""
    from lumped.model.uncertainty import numeric_keys, sample_values

    model, decls = _declarations(pb)
    perturbed = []
    if decls:
        keys = numeric_keys(model)
        for j, d in enumerate(decls):
            z = [0.0] * len(decls)
            z[j] = 1.0
            try:
                vals = sample_values(model, decls, z, keys)
            except (InputError, KeyError, ValueError):
                continue
            perturbed.append((d.key, Applied.of(INPUT, "pump", vals)))
    return perturbed


def validate(pb, ev: Evaluation) -> dict | None:
    """The baseline's V&V 20 table per run (studies.discrepancy.validation): rows, the outputs beyond
    U_val, the declared input uncertainties used; None (with a note) for a simulator without inputs."""
    from studies.validation.measurement import dataset_uncertainty

    if not getattr(pb.sims.simulator, "validation", False):
        pb.notes.append("no validation uncertainty: the simulator offers no input uncertainties or tolerance")
        return None
    perturbed = _perturbed_inputs(pb)
    fine = Applied.of(NUMERICS, "pump", {"rtol": TRUTH_RTOL})
    jobs = [(pb.conds[r.name], (fine,)) for r in pb.runs]
    jobs += [(pb.conds[r.name], (a,)) for r in pb.runs for _, a in perturbed]
    pb.sims.many(jobs)
    u_del = dataset_uncertainty(pb.runs)
    # a uniform declaration's samples are not normal: V&V 20's expansion reads the distribution (validation.rows)
    distributions = {d.key: d.distribution for d in _declarations(pb)[1]}
    rows = []
    for r in pb.runs:
        f = pb.folded.get(r.name, Folded({}, {}, {}))
        thr = val.thresholds(f)
        c = pb.conds[r.name]
        base = val.outputs(r, f, ev.sims[r.name], ev.nuisance, thr)
        s_fine = pb.sims.cache[(c, (fine,))]
        fine_out = None if isinstance(s_fine, SimulationFailure) else val.outputs(r, f, s_fine, ev.nuisance, thr)
        pert = []
        for key, a in perturbed:
            s = pb.sims.cache[(c, (a,))]
            if not isinstance(s, SimulationFailure):
                pert.append((key, val.outputs(r, f, s, ev.nuisance, thr)))
        u_d = val.measurement_uncertainty(r, f, base["measured"], (u_del.get(r.name) or {}).get("delivery"))
        rows += val.rows(r.name, base, fine_out, pert, u_d, distributions=distributions)
    return {"rows": rows, "beyond": val.beyond(rows), "joint": val.joint_tests(rows),
            "declared": [k for k, _ in perturbed],
            "note": ("u_input from the model's declared input uncertainties to first order (one simulation per "
                     "key and run)" if perturbed else "the model declares no input uncertainty: u_input = 0")}


def _by_signal(pb, after: Evaluation) -> dict:
    """The gap left by signal [gap units]: as RunGap.cost_parts, the mean square above the noise."""
    sc = pb.settings.scales
    by_signal: dict = {}
    for g in after.gaps:
        for v in g.valves:
            by_signal[f"{v.valve} position"] = by_signal.get(f"{v.valve} position", 0.0) \
                + (v.rms_m**2 - v.noise_m**2) / sc.position_m**2
        if g.delivery_error_pct is not None:
            by_signal["delivery"] = by_signal.get("delivery", 0.0) \
                + (g.delivery_error_pct / 100.0 / sc.delivery_frac) ** 2
        if g.pressure is not None:
            by_signal["cylinder pressure"] = by_signal.get("cylinder pressure", 0.0) \
                + (g.pressure.rms_pa**2 - g.pressure.noise_pa**2) / sc.pressure_pa**2
    return by_signal


def _windows(pb, after: Evaluation, found_after: list) -> list:
    """The crank windows of the residuals left: positions (from the findings) and cylinder pressures."""
    windows = []
    for f in found_after:
        if f.kind == "window":
            windows.append({"run": f.run, "signal": f"{f.valve} position", "crank_deg": list(f.window),
                            "peak_residual": f.value, "unit": "m"})
    for g in after.gaps:
        windows += [{"run": g.run, "signal": "cylinder pressure", "crank_deg": [a, e], "peak_residual": peak,
                     "unit": "Pa"} for a, e, peak in pressure_windows(g, pb.settings.scales)]
    return windows


def _at_bound(pb, nuisances: tuple) -> list[str]:
    """A sentence per baseline nuisance that sits within 2 % of its range from a bound."""
    at_bound = []
    for a in nuisances:
        eff = pb.nuisance_effects[a.name][0]
        for p in eff.parameters:
            v = a.value_dict[p.name]
            lo, hi = p.bounds
            if min(v - lo, hi - v) <= 0.02 * (hi - lo):
                at_bound.append(f"the baseline nuisance {a.name} sits at its bound ({p.name} = {v:.4g}, "
                                f"range {lo:.3g}-{hi:.3g}): the model's {eff.summary.split('(')[0].strip()} or "
                                "an effect that acts like it is off by more than the nuisance allows")
    return at_bound


def _partial(pb, rounds: list) -> list[dict]:
    """The three best candidates of the last round that were judged and not added: the share of the fit and of
    the held-out gap each explains (held out only where that gap exceeds the gain floor), and why not."""
    partial = []
    for f in (rounds[-1] if rounds else []):
        if f.accepted or f.failed or f.rejected or f.screened_out or f.held_cost is None:
            continue
        held = None
        if f.base_held_cost is not None and f.base_held_cost > pb.min_gain_units:
            held = 100.0 * (1.0 - f.held_cost / f.base_held_cost)
        partial.append({"effect": f.effect, "target": f.target, "parameters": f.reported,
                        "fit_explained_pct": 100.0 * f.fit_improvement, "held_out_explained_pct": held,
                        "why_not_added": f.why_not_added})
    partial = [d for d in partial if d["fit_explained_pct"] > 0.0 and (d["held_out_explained_pct"] or 0.0) > 0.0]
    partial.sort(key=lambda d: -(d["held_out_explained_pct"] or 0.0) - d["fit_explained_pct"])
    return partial[:3]


def unexplained(pb, before: Evaluation, after: Evaluation, validation: dict | None, rounds: list,
                nuisances: tuple, found_after: list) -> dict:
    """What the final model leaves unexplained (never silent on a large gap): the cost by signal, the
    outputs beyond their validation uncertainty, the crank windows of the residuals, the best partial
    candidates of the last round and the nuisances pinned to a bound."""
    by_signal = _by_signal(pb, after)
    total_after = after.fit_cost + (after.held_cost or 0.0)
    total_before = before.fit_cost + (before.held_cost or 0.0)
    limit = pb.settings.large_gap_units_per_run * len(pb.runs)
    beyond = (validation or {}).get("beyond_after", [])
    windows = _windows(pb, after, found_after)
    at_bound = _at_bound(pb, nuisances)
    partial = _partial(pb, rounds)
    large = bool(beyond) or total_after > limit
    words = []
    if large:
        worst = max(by_signal.items(), key=lambda kv: kv[1]) if by_signal else ("-", 0.0)
        words.append(f"the model leaves a large gap: {total_after:.3g} gap units over {len(pb.runs)} runs "
                     f"({100 * total_after / total_before if total_before else 0:.0f} % of the baseline's "
                     f"{total_before:.3g}; above the {limit:.3g} that noise and the nuisances leave), most in the "
                     f"{worst[0]} ({worst[1]:.3g} units)")
        words += [val.sentence(b) for b in beyond]
        for d in partial:
            held = "" if d["held_out_explained_pct"] is None else \
                f" and {d['held_out_explained_pct']:.0f} % held out"
            words.append(f"{d['effect']}@{d['target']} explains {d['fit_explained_pct']:.0f} % of the fit cost"
                         f"{held}, but is not added: {d['why_not_added']}")
    words += at_bound
    return json_safe({"large": large, "cost": {"before": total_before, "after": total_after, "limit": limit,
                                               "fit": after.fit_cost, "held_out": after.held_cost},
                      "by_signal": by_signal, "beyond_validation": beyond, "windows": windows,
                      "partial_candidates": partial, "nuisances_at_bound": at_bound, "sentences": words})


def cost_report(sims) -> dict:
    """Where the simulations went: per stage and per candidate ([simulations, seconds])."""
    by_stage: dict = {}
    by_candidate: dict = {}
    for label, (n, sec) in sims.tally.items():
        head, _, tail = label.partition("/")
        stage = label.split("/")[-1] if tail else head
        if head.startswith("round"):
            cand = tail.split("/")[0] if tail else "evaluate"
            key = f"{head}: {cand}"
            c = by_candidate.setdefault(key, [0, 0.0])
            c[0] += n
            c[1] += sec
            stage = tail.split("/")[-1] if "/" in tail else "evaluate"
        s = by_stage.setdefault(stage, [0, 0.0])
        s[0] += n
        s[1] += sec
    return {"by_stage": by_stage, "by_candidate": by_candidate}
