"""The selection rules: a candidate judged on top of the model it would extend, and whether it is added.

:func:`judge` refits a candidate's augmented model with the effects added before it, scores it on every run
and against its bases (the model before it, and the same model without it as refitted with it), and
:func:`verdict` applies the decision rule of docs/discrepancy.md ("The decision rule"): plausible, paying for
its parameters in BIC, no kind of evidence worse, and a held-out gain above a relative and an absolute floor.
"""

from __future__ import annotations

from dataclasses import dataclass

from geometry.errors import ModelFailure
from lumped.model.effects import Effect
from studies.discrepancy import edge, fitting
from studies.discrepancy.records import CandidateFit, Evaluation, delta_bic
from studies.discrepancy.settings import Settings


@dataclass(frozen=True, eq=False)
class Base:
    """The model a candidate extends (its effects and the nuisances), its evaluation, and the effective number
    of independent residuals of the fitting runs there (the BIC's sample count)."""

    model: tuple
    ev: Evaluation
    n_eff: float


@dataclass(frozen=True, eq=False)
class Trial:
    """A candidate as its search left it: its augmented ``model`` (the last entry the candidate), the fit cost
    and sensor nuisances there, the base's fit cost, the simulation count when its search began, and the cost
    accounting's stage label."""

    eff: Effect
    target: str
    model: tuple
    cost: float
    nuis: object
    base_fit: float
    n0: int
    stage: str


@dataclass(frozen=True)
class How:
    """How :func:`judge` treats a trial: ``refit`` the effects added before it (else the model is judged as
    given); ``extra_k`` parameters beyond the candidate's own for the BIC; ``pair``: two new effects judged
    against the base only."""

    refit: bool = True
    extra_k: int = 0
    pair: bool = False


def _refitted(pb, base: Base, t: Trial, how: How) -> tuple[tuple, float, object]:
    """(model, fit cost, sensor nuisances) of the trial's augmented model, the effects added before it refitted
    with it: they were fitted without it, so the candidate is judged by the augmented model it would give, not
    against their bias. With a nuisance, the earlier effects one at a time and the candidate and the nuisances
    jointly (they may trade along a valley), the latter only where the profiled fit leaves the candidate a
    chance of the gain floor (the rest are judged as the profile left them: half the simulations)."""
    model, cost, nuis = t.model, t.cost, t.nuis
    if base.model and how.refit:
        pb.sims.stage = f"{t.stage}/refit"
        if pb.nuisance_effects:
            model = fitting.refine(pb, model, skip=frozenset({t.eff.name, *pb.nuisance_effects}))
            if cost < t.base_fit - pb.min_gain_units:
                pb.sims.stage = f"{t.stage}/polish"
                model = fitting.polish(pb, model, {t.eff.name, *pb.nuisance_effects}, free=frozenset({t.eff.name}))
        else:
            model = fitting.refine(pb, model)
        cost, nuis = pb.fit_objective(model)
    elif not how.refit:
        cost, nuis = pb.fit_objective(model)
    return model, cost, nuis


def _bases(pb, base: Base, model: tuple, base_fit: float, pair: bool) -> tuple[Evaluation, Evaluation, float]:
    """(the base the held-out gain counts from, the base evidence by kind is compared with, the base fit cost).

    The credit is the candidate's, not its refits': the same model without it (the effects and nuisances as
    refitted with it) is a base too, and the better base counts. Evidence by kind is compared at the same
    nuisance values: the baseline's Cd factor, fitted without the candidate, may have bought one kind with the
    others (a bench pump's soft seat: Cd at its 0.9 bound matched the delivery, not the traces)."""
    base_ev = kind_ev = cur = base.ev
    if base.model and not pair:
        try:
            wo = pb.evaluate(model[:-1])
        except ModelFailure:
            wo = None
        if wo is not None and wo.held_cost is not None and cur.held_cost is not None \
                and wo.held_cost < cur.held_cost:
            base_ev = wo
            base_fit = min(base_fit, pb.fit_objective(model[:-1])[0])
        if wo is not None and pb.nuisance_effects:
            kind_ev = wo
    return base_ev, kind_ev, base_fit


def judge(pb, base: Base, t: Trial, how: How = How()) -> CandidateFit:
    """The trial's augmented model refitted with the effects added before (``_refitted``), scored on every
    run and against its bases (``_bases``): BIC, held-out gain, evidence by kind; the refitted earlier
    effects must stay plausible too (nuisances are bounded)."""
    vt = pb.context
    eff, target = t.eff, t.target
    model, cost, nuis = _refitted(pb, base, t, how)
    pulled, held = None, ()
    if eff.plausibility(model[-1].value_dict, vt, target) is not None:
        pb.sims.stage = f"{t.stage}/edge"
        pulled = edge.pull_inside(pb, model, len(model) - 1, t.base_fit, cost)
        if pulled is not None:
            model, cost, nuis, pulled, held = pulled
    vals = model[-1].value_dict
    pb.sims.stage = f"{t.stage}/evaluate"
    try:
        ev = pb.evaluate(model)      # every run: the held-out score and the gap by kind of evidence
    except ModelFailure as exc:
        return CandidateFit(eff.name, target, vals, eff.report(vals, vt, target), cost, None, float("inf"),
                            "held-out simulation failed", pb.sims.count - t.n0, base.ev.fit_cost,
                            base.ev.held_cost, failed=str(exc))
    base_ev, kind_ev, base_fit = _bases(pb, base, model, t.base_fit, how.pair)
    dbic = delta_bic(base.n_eff, cost, base_fit, pb.k(eff, target) + how.extra_k)
    why = eff.plausibility(vals, vt, target)
    for a in model[:-1]:
        if a.name not in pb.nuisance_effects:
            why = why or pb.library[a.name].plausibility(a.value_dict, vt, a.target)
    pb.sims.stage = t.stage
    return CandidateFit(eff.name, target, vals, eff.report(vals, vt, target), cost, ev.held_cost, dbic, why,
                        pb.sims.count - t.n0, base_fit, base_ev.held_cost, nuisance=nuis, model=model,
                        held_parts=ev.held_parts, base_held_parts=kind_ev.held_parts, fit_parts=ev.fit_parts,
                        base_fit_parts=kind_ev.fit_parts, pulled_inside=pulled, pulled=held)


def significant(f: CandidateFit, settings: Settings, floor: float) -> bool:
    """Whether a candidate is added (:func:`verdict`); records why not in ``f.why_not_added``."""
    f.why_not_added = verdict(f, settings, floor)
    return f.why_not_added is None


def verdict(f: CandidateFit, settings: Settings, floor: float) -> str | None:
    """None if the candidate qualifies, else why not: a failed, hopeless or implausible fit, a BIC it does
    not pay for, a kind of evidence it makes worse by more than Settings.max_worse_units and
    Settings.worse_fraction of its whole gain (an effect that removes most of a large gap may leave a
    kind a little worse where no model is the truth; one that trades one kind for another may not), or
    a gain below the floors (:func:`gain_reason`)."""
    why = _disqualified(f, settings)
    if why is not None:
        return why
    held = None
    if f.held_cost is not None and f.base_held_cost is not None:
        held = (f.base_held_cost, f.held_cost)
    return gain_reason(settings, floor, (f.base_fit_cost, f.fit_cost), held)


def gain_reason(settings: Settings, floor: float, fit: tuple, held: tuple | None) -> str | None:
    """None if going from a base to a model gains enough, else why not: the held-out gain (the fit gain
    without held-out runs) below the relative threshold or the absolute ``floor`` [gap units], the floor
    lowered to Settings.decisive_abs_improvement where the fit gain is decisive
    (Settings.decisive_fit_improvement), unless the user set it. ``fit``, ``held``: (base cost, cost)."""
    st = settings
    fit_improvement = 1.0 - fit[1] / fit[0] if fit[0] else 0.0
    if held is not None:
        gain, base, where = held[0] - held[1], held[0], "held-out"
    else:
        gain, base, where = fit[0] - fit[1], fit[0], "fit"   # no held-out runs
    # the gap is the mean square above the noise, which scatters about 0 where nothing is missing: a base
    # below the floor is judged as the floor, so that a relative gain on nothing never counts
    if gain < st.min_rel_improvement * max(base, floor):
        return (f"{where} gap shrinks by {100 * gain / base if base > 0 else 0:.0f} % < "
                f"{100 * st.min_rel_improvement:.0f} %")
    if where == "held-out" and fit_improvement >= st.decisive_fit_improvement \
            and st.min_abs_improvement is None:
        floor = min(floor, st.decisive_abs_improvement)     # a floor the user set applies as set
    if gain < floor:
        return f"{where} gap shrinks by {gain:.2f} units < {floor:g}"
    return None


def _disqualified(f: CandidateFit, st: Settings) -> str | None:
    """Why a candidate cannot be added whatever its gain (failed, hopeless, screened out, a pair one of whose
    two adds too little, implausible, not paying in BIC, contradicting a kind of evidence), or None."""
    if f.failed:
        return "fit failed"
    if f.rejected:
        return "hopeless: no value on its search grid lowers the fit cost"
    if f.screened_out:
        return f.screened_out
    if f.pair_why:
        return f.pair_why
    if f.plausible_reason is not None:
        return "not plausible"
    if not f.delta_bic < -st.max_bic_increase:
        return "does not pay for its parameters (BIC)"
    change = f.parts_change() or {}
    gain_all = -sum(change.values())
    why = f.contradiction(max(st.max_worse_units, st.worse_fraction * max(gain_all, 0.0)))
    if why is not None:
        return f"contradicts the data: {why} (its whole gain {gain_all:.3g} units)"
    return None
