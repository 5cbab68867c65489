"""The backward step: an effect the others made redundant is dropped (docs/discrepancy.md, "The backward step").

Each added effect but the one just added is taken out, the others and the nuisances refitted jointly, and the
effect judged as a candidate on top of the model without it by the acceptance rule: one that would not be
added back is dropped. Adding and dropping use one rule, and a dropped effect is not tried again, so the
search cannot cycle.
"""

from __future__ import annotations

from geometry.errors import ModelFailure
from studies.discrepancy import fitting
from studies.discrepancy.records import CandidateFit, Evaluation, delta_bic, json_safe
from studies.discrepancy.selection import significant


def backward(pb, current: tuple, cur: Evaluation, rnd: int, rows: list, dropped: set,
             keep: str | None) -> tuple[tuple, Evaluation]:
    """Each added effect of ``current`` but ``keep`` (the one just added) taken out, the others and the
    nuisances refitted jointly (:func:`removal`), and dropped when the acceptance rule would not add it back to
    the model without it; of several, the one whose removal leaves the lowest held-out cost, then again on what
    is left. ``dropped`` gets the effects dropped, ``rows`` every removal tried. Returns the model and its
    evaluation."""
    while True:
        idx = [i for i, a in enumerate(current) if a.name not in pb.nuisance_effects]
        if len(idx) < 2:
            return current, cur
        n_eff = pb.n_effective(cur)
        fit_c = pb.fit_objective(current)[0]
        tried = []
        for i in idx:
            if current[i].key == keep:
                continue
            memo = (current, i)
            fresh = memo not in pb.removals
            if fresh:
                pb.removals[memo] = removal(pb, current, cur, i, fit_c, n_eff, rnd)
            t = pb.removals[memo]
            if t is not None:
                tried.append((*t, fresh))
        out = [t for t in tried if t[0].why_not_added is not None]
        best = min(out, key=lambda t: (t[2].held_cost if t[2].held_cost is not None else t[2].fit_cost),
                   default=None)
        _record(tried, best, rnd, rows)
        if best is None:
            return current, cur
        f, current, cur, _ = best
        dropped.add(f.effect)
        pb.log(f"round {rnd}: dropping {f.key}: without it (the others refitted) {f.why_not_added}")


def _record(tried: list, best, rnd: int, rows: list) -> None:
    """A row per removal tried for the first time on its model (a removal tried on the very model before, the
    end's pass, was recorded then)."""
    for f, m, ev, fresh in tried:
        if not fresh:
            continue
        row = f.row(0, rnd)
        gone = best is not None and f is best[0]
        row.update({"dropped": gone, "why_dropped": f.why_not_added if gone else None,
                    "held_out_cost_without": f.base_held_cost, "fit_cost_without": f.base_fit_cost,
                    "without": {a.key: a.value_dict for a in m}})
        rows.append(json_safe(row))


def removal(pb, current: tuple, cur: Evaluation, i: int, fit_c: float, n_eff: float,
            rnd: int) -> tuple[CandidateFit, tuple, Evaluation] | None:
    """The added effect ``current[i]`` judged as a candidate on top of the model without it, whose other
    effects and nuisances are refitted jointly from their values beside it
    (:func:`~studies.discrepancy.fitting.polish`; one at a time, :func:`~studies.discrepancy.fitting.refine`,
    without a nuisance): (its record, the model without it, that model's evaluation), or None when the model
    without it fails."""
    n0 = pb.sims.count
    vt = pb.context
    a = current[i]
    eff = pb.library[a.name]
    stage = f"round {rnd}/backward {a.key}"
    rest = current[:i] + current[i + 1:]
    pb.sims.stage = f"{stage}/polish"
    if pb.nuisance_effects:
        rest = fitting.polish(pb, rest, {b.name for b in rest})
    else:
        rest = fitting.refine(pb, rest)
    base_fit = pb.fit_objective(rest)[0]
    pb.sims.stage = f"{stage}/evaluate"
    try:
        ev = pb.evaluate(rest)
    except ModelFailure:
        return None
    dbic = delta_bic(n_eff, fit_c, base_fit, pb.k(eff, a.target))
    f = CandidateFit(a.name, a.target, a.value_dict, eff.report(a.value_dict, vt, a.target), fit_c,
                     cur.held_cost, dbic, eff.plausibility(a.value_dict, vt, a.target), pb.sims.count - n0,
                     base_fit, ev.held_cost, nuisance=cur.nuisance, model=current, held_parts=cur.held_parts,
                     base_held_parts=ev.held_parts, fit_parts=cur.fit_parts, base_fit_parts=ev.fit_parts)
    significant(f, pb.settings, pb.min_gain_units)
    return f, rest, ev
