"""Candidates fitted jointly with others, for a round that adds nothing while a large gap is left.

An effect may be masked by one added before it, fitted too strong in its absence (:func:`joint_candidate`:
each candidate fitted with each added effect started from that effect's prior), or two effects may explain
the gap only together (:func:`pair_candidate`: pairs of the most promising candidates, one at its prior).
"""

from __future__ import annotations

import math
import time

from geometry.errors import ModelFailure
from lumped.model.effects import Applied, Effect
from studies.discrepancy import fitting
from studies.discrepancy import profile as prof
from studies.discrepancy.records import CandidateFit
from studies.discrepancy.selection import Base, How, Trial, judge, significant


def joint_fits(pb, base: Base, todo: list, fits: list, rnd: int, rounds: list = ()) -> list[CandidateFit]:
    """Candidates fitted jointly with others: first each added effect refitted beside the alternatives of the
    round it won (:func:`alternative_candidate`); unless one of those passes, every candidate fitted with each
    added effect restarted from its prior; when nothing is added yet, pairs of the Settings.pair_top most
    promising candidates (by their fit cost) with every other one (a needle-prone one, declared
    tight_tolerance, on a dense grid). ``rounds``: the candidates of the earlier rounds."""
    out = _alternatives(pb, base, rnd, rounds)
    if any(significant(f, pb.settings, pb.min_gain_units) for f in out):
        return out
    out += _masked(pb, base, todo, rnd)
    if any(a.name not in pb.nuisance_effects for a in base.model):
        return out
    best = sorted((f for f in fits if not f.failed and not f.rejected), key=lambda f: f.fit_cost)[:pb.settings.pair_top]
    others = [f for f in fits if not f.failed]
    for w in best:
        for f0 in others:
            if f0 is w or f0.effect == w.effect:
                continue
            eff, w_eff = pb.library[f0.effect], pb.library[w.effect]
            t1 = time.perf_counter()
            pb.sims.stage = f"round {rnd}/{f0.effect}@{f0.target}+{w.effect}@{w.target}"
            fs = pair_candidate(pb, base, Applied.of(w_eff.name, w.target, w_eff.prior_values(pb.context, w.target)),
                                eff, f0.target)
            for f in fs:
                f.seconds = time.perf_counter() - t1
            out += fs
    return out


def _restarted(pb, current: tuple, i_w: int) -> tuple | None:
    """``current`` with the added effect ``current[i_w]`` at its prior; None when it sits there already."""
    w = current[i_w]
    w_eff = pb.eff(w.name)
    prior_w = w_eff.prior_values(pb.context, w.target)
    pw = w_eff.parameters_for(pb.context, w.target)
    if all(abs(p.to_unit(w.value_dict[p.name]) - p.to_unit(prior_w[p.name])) < 0.02 for p in pw):
        return None
    return current[:i_w] + (w.with_values(prior_w),) + current[i_w + 1:]


def _masked(pb, base: Base, todo: list, rnd: int) -> list[CandidateFit]:
    """Every candidate beside each added effect W restarted from its prior (:func:`joint_candidate`), screened
    first as a round's candidates are: each on its coarse grid on top of W at its prior (the Cd factor profiled
    with that model's Jacobian), then the competitive ones (Settings.refine_top by their gain over the current
    model, and any gaining Settings.refine_fraction of the best's) searched in full; the others recorded as
    screened out."""
    st = pb.settings
    screened = []
    for i_w, w in enumerate(base.model):
        start = None if w.name in pb.nuisance_effects else _restarted(pb, base.model, i_w)
        if start is None:
            continue
        for eff, target in todo:
            t1 = time.perf_counter()
            pb.sims.stage = f"round {rnd}/{eff.name}@{target}+{w.key}"
            opts = fitting.FitOptions(start=eff.prior_values(pb.context, target), profile=True, coarse_only=True,
                                      dense=True, reject_margin=st.hopeless_units,
                                      jacobian=prof.base_jacobian(pb, start))
            try:
                res = fitting.fit(pb, start, eff, target, opts)
            except (ArithmeticError, ValueError, RuntimeError):
                continue
            screened.append((i_w, eff, target, res, time.perf_counter() - t1))
    base_c = prof.screen_base(pb, base.model)
    gains = {k: base_c - s[3].cost for k, s in enumerate(screened) if not s[3].rejected and math.isfinite(s[3].cost)}
    top = sorted(gains, key=gains.get, reverse=True)[:st.refine_top]
    best_gain = max(gains.values(), default=0.0)
    out = []
    for k, (i_w, eff, target, res, secs) in enumerate(screened):
        w = base.model[i_w]
        t1 = time.perf_counter()
        pb.sims.stage = f"round {rnd}/{eff.name}@{target}+{w.key}"
        if k in top or (k in gains and gains[k] >= st.refine_fraction * best_gain):
            f = joint_candidate(pb, base, i_w, eff, target)
        else:
            f = CandidateFit(eff.name, target, res.values, eff.report(res.values, pb.context, target), res.cost,
                             None, math.inf, eff.plausibility(res.values, pb.context, target), 0, base_c,
                             base.ev.held_cost, rejected=res.rejected, joint_with=w.key)
            if not res.rejected:
                f.screened_out = (f"not competitive: its best grid point beside {w.key} at its prior gains "
                                  f"{gains.get(k, -math.inf):.3g} units where the best gains {best_gain:.3g}")
        if f is not None:
            f.seconds = secs + time.perf_counter() - t1
            out.append(f)
    return out


def _alternatives(pb, base: Base, rnd: int, rounds) -> list[CandidateFit]:
    """Each added effect W refitted beside each alternative of the round W won: a candidate of that round
    that passed the decision rule too but ranked below W, and is not in the model."""
    out = []
    names = {a.name for a in base.model}
    for i_w, w in enumerate(base.model):
        if w.name in pb.nuisance_effects:
            continue
        won = [r for r in rounds if any(f.accepted and f.key == w.key for f in r)]
        alts = [f for r in won[:1] for f in r if not f.accepted and f.why_not_added is None
                and f.failed is None and f.effect not in names]
        for alt in alts:
            t1 = time.perf_counter()
            pb.sims.stage = f"round {rnd}/{alt.key}+{w.key} (alternative)"
            f = alternative_candidate(pb, base, i_w, alt)
            if f is not None:
                f.seconds = time.perf_counter() - t1
                out.append(f)
    return out


def alternative_candidate(pb, base: Base, i_w: int, alt: CandidateFit) -> CandidateFit | None:
    """The alternative ``alt`` to the added effect W = ``base.model[i_w]`` (a candidate of W's round that
    passed the rule too), at its fitted values in place of W, with W's whole search on top of it (the Cd factor
    profiled), then W, the alternative and the nuisances polished jointly, judged as a candidate on top of the
    current model. The other valley of a pair that trades: a squeeze film fitted too strong in round one makes
    the disc hover and hides a compliant seat of the same valve, while the seat's fit of round one with a film
    searched beside it finds both (None when W adds nothing beside it: the alternative alone was judged in W's
    round)."""
    n0 = pb.sims.count
    vt, stage, current, cur = pb.context, pb.sims.stage, base.model, base.ev
    w = current[i_w]
    w_eff, eff = pb.library[w.name], pb.library[alt.effect]
    start = current[:i_w] + current[i_w + 1:] + (Applied.of(alt.effect, alt.target, alt.values),)
    base_fit = pb.fit_objective(current)[0]
    try:
        res = fitting.fit(pb, start, w_eff, w.target, fitting.FitOptions(
            start=w_eff.prior_values(vt, w.target), profile=True, reject_margin=pb.settings.hopeless_units,
            dense=True))
    except (ArithmeticError, ValueError, RuntimeError) as exc:
        return failed_fit(pb, eff, alt.target, exc, cur, n0, w)
    if res.rejected or not math.isfinite(res.cost):
        return None
    model, cost, nuis = polished_jointly(pb, start, start[-1], w_eff, w.target, res, stage, frozenset({alt.effect}))
    model = model[:-2] + (model[-1], model[-2])          # the alternative last: it is the candidate judged
    f = judge(pb, base, Trial(eff, alt.target, model, cost, nuis, base_fit, n0, stage), How(refit=False))
    f.joint_with = f"{w.key} (refitted beside it, started from it alone)"
    return f


def failed_fit(pb, eff: Effect, target: str, exc: Exception, cur, n0: int, w: Applied) -> CandidateFit:
    """The record of a candidate whose fit beside the effect ``w`` raised ``exc`` (at its prior, no gain)."""
    return CandidateFit(eff.name, target, eff.prior_values(pb.context, target), {}, math.inf, None, math.inf,
                        "fit failed", pb.sims.count - n0, cur.fit_cost, cur.held_cost,
                        failed=f"{type(exc).__name__}: {exc}", joint_with=w.key)


def polished_jointly(pb, start: tuple, w: Applied, eff: Effect, target: str, res: fitting.FitResult,
                     stage: str, free: frozenset) -> tuple:
    """(model, fit cost, nuisances) of ``start`` + the effect ``eff`` at its fitted values, the nuisances
    profiled (with the Jacobian its fit ended with), then W, that effect and the nuisances polished together by
    least squares (the effects in ``free``, the candidates being judged, within their search bounds; an added
    effect inside its plausible range)."""
    model = start + (Applied.of(eff.name, target, res.values),)
    if pb.nuisance_effects:
        model = prof.profiled_model(pb, prof.at_origin(pb, start) + model[-1:], res.jacobian)
    pb.sims.stage = f"{stage}/polish"
    model = fitting.polish(pb, model, {w.name, eff.name, *pb.nuisance_effects}, free=free)
    cost, nuis = pb.fit_objective(model)
    return model, cost, nuis


def joint_candidate(pb, base: Base, i_w: int, eff: Effect, target: str) -> CandidateFit | None:
    """A candidate fitted with the added effect ``base.model[i_w]`` (W) started from W's prior instead of its
    fitted value: the candidate's whole search on top of W at its prior (the Cd factor profiled), then a
    joint least-squares polish of W, the candidate and the nuisances. For an effect masked by an earlier
    one fitted too strong in its absence: a squeeze film fitted at twice its C2 makes the inlet disc
    hover, and no inlet seat stiffness then changes anything, while with the film at eq 2.15's C2 the
    seat's valley is there to find. None when W sits at its prior already."""
    n0 = pb.sims.count
    vt, stage, current, cur = pb.context, pb.sims.stage, base.model, base.ev
    w = current[i_w]
    start = _restarted(pb, current, i_w)
    if start is None:
        return None
    base_fit = pb.fit_objective(current)[0]
    try:
        res = fitting.fit(pb, start, eff, target, fitting.FitOptions(
            start=eff.prior_values(vt, target), profile=True, reject_margin=pb.settings.hopeless_units, dense=True))
    except (ArithmeticError, ValueError, RuntimeError) as exc:
        return failed_fit(pb, eff, target, exc, cur, n0, w)
    if res.rejected or not math.isfinite(res.cost):
        return CandidateFit(eff.name, target, res.values, eff.report(res.values, vt, target), res.cost, None,
                            math.inf, eff.plausibility(res.values, vt, target), pb.sims.count - n0, base_fit,
                            cur.held_cost, rejected=True, joint_with=w.key)
    model, cost, nuis = polished_jointly(pb, start, w, eff, target, res, stage, frozenset({eff.name}))
    f = judge(pb, base, Trial(eff, target, model, cost, nuis, base_fit, n0, stage), How(refit=False))
    f.joint_with = w.key
    return f


def pair_candidate(pb, base: Base, w: Applied, eff: Effect, target: str) -> list[CandidateFit]:
    """Two effects not yet added, fitted together: W at its prior, the candidate's whole search on top of it
    (the Cd factor profiled), then W, the candidate and the nuisances polished jointly by least squares.
    For a gap two effects explain only together: the reed's added mass at 2-4 times its prior changes the
    inlet reed's bounce only as eq 3.21's quadratic drag lets it (alone, each gains 0-5 % of the gap)."""
    n0 = pb.sims.count
    vt, stage, current, cur = pb.context, pb.sims.stage, base.model, base.ev
    start = current + (w,)
    base_fit = pb.fit_objective(current)[0]
    try:
        res = fitting.fit(pb, start, eff, target, fitting.FitOptions(
            start=eff.prior_values(vt, target), profile=True, dense=True, reject_margin=pb.settings.hopeless_units))
        if res.rejected:
            return []           # nothing on top of W at its prior: no pair
    except (ArithmeticError, ValueError, RuntimeError) as exc:
        return [failed_fit(pb, eff, target, exc, cur, n0, w)]
    if not math.isfinite(res.cost):
        return []
    model, cost, nuis = polished_jointly(pb, start, w, eff, target, res, stage, frozenset({eff.name, w.name}))
    w_eff = pb.library[w.name]
    f = judge(pb, base, Trial(eff, target, model, cost, nuis, base_fit, n0, stage),
              How(refit=False, extra_k=len(w_eff.parameters_for(vt, w.target)), pair=True))
    f.joint_with = w.key
    out = [f]
    if f.held_cost is not None or f.failed is None:
        out += _each_earns_its_place(pb, base, f, model, w, (eff, target, base_fit, stage))
    pb.sims.stage = stage
    return out


def _each_earns_its_place(pb, base: Base, f: CandidateFit, model: tuple, w: Applied, trial: tuple) -> list:
    """The pair against each of its two alone (the others as fitted): ``f.pair_why`` says which adds too little.
    Where W adds nothing, the candidate as fitted beside it is judged as a candidate of its own (a start from
    W's prior may have led its search to a valley its own search missed: the reed's added mass, whose cost is
    low only within 3 % of the truth); that record is returned."""
    eff, target, base_fit, stage = trial
    i_w = len(model) - 2
    for drop, who in ((i_w, w.key), (len(model) - 1, f.key)):
        try:
            alone = pb.evaluate(model[:drop] + model[drop + 1:])
        except ModelFailure:
            continue
        if f.held_cost is not None and alone.held_cost is not None:
            gain, base_c = alone.held_cost - f.held_cost, alone.held_cost
        else:
            gain, base_c = alone.fit_cost - (f.fit_parts and sum(f.fit_parts.values()) or 0.0), alone.fit_cost
        if gain < pb.settings.min_rel_improvement * base_c or gain < pb.min_gain_units:
            f.pair_why = (f"{who} adds too little to the other: the gap shrinks by {gain:.3g} units "
                          f"({100 * gain / base_c if base_c else 0:.0f} %) with it")
            if drop != i_w:
                return []
            pb.sims.stage = f"{stage}/alone"
            m1 = model[:i_w] + model[i_w + 1:]
            c1, n1 = pb.fit_objective(m1)
            g = judge(pb, base, Trial(eff, target, m1, c1, n1, base_fit, pb.sims.count, stage), How(refit=False))
            g.joint_with = f"{w.key} (started beside it, alone)"
            return [g]
    return []
