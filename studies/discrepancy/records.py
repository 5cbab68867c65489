"""The records of a discrepancy search: a run's condition, a candidate's fit, an evaluated model, the outcome.

:class:`Outcome` is what the workflow returns; :meth:`Outcome.as_contract` is the contract's JSON.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

from lumped.model.effects import Library
from studies.discrepancy.gap import CycleTrace, Nuisance, summary
from studies.discrepancy.measured import Run



@dataclass(frozen=True)
class RunCondition:
    """What a simulator needs to know of a run (picklable and hashable: a cache key)."""

    name: str
    valve_type: str
    speed_rpm: float
    load_pressure_pa: float
    air_content: float | None

    @staticmethod
    def of(run: Run) -> "RunCondition":
        return RunCondition(run.name, run.valve_type, float(run.speed_rpm), float(run.load_pressure_pa),
                            None if run.air_content is None else float(run.air_content))


#: a simulator: (run condition, applied effects) -> one revolution of cyclic steady state
Simulator = Callable[[RunCondition, tuple], CycleTrace]


@dataclass
class CandidateFit:
    """A candidate effect fitted on the fitting runs and scored on the held-out runs."""

    effect: str
    target: str
    values: dict
    reported: dict
    fit_cost: float
    held_cost: float | None
    delta_bic: float
    plausible_reason: str | None
    n_sims: int
    base_fit_cost: float
    base_held_cost: float | None
    nuisance: Nuisance = field(default_factory=Nuisance)
    accepted: bool = False
    failed: str | None = None
    seconds: float = 0.0
    model: tuple = ()                  # the augmented model: added effects (refitted) + this one
    why_not_added: str | None = None   # set by the decision (selection.verdict)
    held_parts: dict | None = None     # held-out cost by kind of evidence, with the candidate ...
    base_held_parts: dict | None = None  # ... and without it
    fit_parts: dict | None = None      # the same on the fitting runs
    base_fit_parts: dict | None = None
    rejected: bool = False             # hopeless: no point of its coarse grid lowers the fit cost
    screened_out: str | None = None    # left at its coarse grid: far less promising than the best candidate
    pair_why: str | None = None        # a pair (joint.pair_candidate) one of whose two adds too little
    joint_with: str | None = None      # fitted jointly with this added effect (joint.joint_candidate)
    pulled_inside: str | None = None   # a fit at its plausible edge judged inside it (edge.pull_inside) ...
    pulled: tuple = ()                 # ... the parameters pulled: held where they are by later refits
    second_start: dict | None = None   # fitted again from the nuisances' prior (search._second_start)

    @property
    def key(self) -> str:
        """``effect`` or ``effect@valve`` (an effect on one valve)."""
        return self.effect if self.target in ("both", "pump") else f"{self.effect}@{self.target}"

    @property
    def held_improvement(self) -> float | None:
        """Fraction by which the held-out gap shrinks (None without held-out runs)."""
        if self.held_cost is None or not self.base_held_cost:
            return None
        return 1.0 - self.held_cost / self.base_held_cost

    @property
    def fit_improvement(self) -> float:
        """Fraction by which the fit cost shrinks."""
        return 1.0 - self.fit_cost / self.base_fit_cost if self.base_fit_cost else 0.0

    def parts_change(self) -> dict | None:
        """Change of the gap by kind of evidence over all runs (fitting and held out), in gap units."""
        if self.fit_parts is None or self.base_fit_parts is None:
            return None
        out = {}
        for k in self.fit_parts:
            after = self.fit_parts[k] + (self.held_parts or {}).get(k, 0.0)
            before = self.base_fit_parts[k] + (self.base_held_parts or {}).get(k, 0.0)
            out[k] = after - before
        return out

    def contradiction(self, max_worse: float) -> str | None:
        """None, or the kind of evidence the candidate makes worse by more than ``max_worse`` units."""
        change = self.parts_change()
        if not change:
            return None
        kind, worse = max(change.items(), key=lambda kv: kv[1])
        if worse > max_worse:
            return f"{kind} gap worse by {worse:.2f} units"
        return None

    def row(self, rank: int, round_: int) -> dict:
        """One ranking-table row (JSON-safe: a failed fit's infinities become None)."""
        return json_safe({
            "round": round_, "rank": rank, "effect": self.effect, "target": self.target,
            "parameters": self.reported, "fit_cost": self.fit_cost, "held_out_cost": self.held_cost,
            "held_out_improvement_pct": None if self.held_improvement is None else 100 * self.held_improvement,
            "fit_improvement_pct": 100 * self.fit_improvement, "delta_bic": self.delta_bic,
            "plausible": self.plausible_reason is None, "why_not_plausible": self.plausible_reason,
            "simulations": self.n_sims, "seconds": self.seconds, "accepted": self.accepted,
            "failed": self.failed, "held_out_parts": self.held_parts, "held_out_parts_before": self.base_held_parts,
            "fit_parts": self.fit_parts, "fit_parts_before": self.base_fit_parts,
            "gap_change_by_kind": self.parts_change(), "why_not_added": self.why_not_added,
            "hopeless": self.rejected, "screened_out": self.screened_out is not None,
            "fitted_jointly_with": self.joint_with, "pulled_inside": self.pulled_inside,
            "second_start": self.second_start,
        })


def json_safe(obj):
    """``obj`` with non-finite floats replaced by None (JSON has no infinity)."""
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


@dataclass
class Evaluation:
    """A model evaluated on a set of runs: per-run gaps, dimensionless cost, the nuisances used."""

    model: tuple
    gaps: list
    cost: float
    fit_cost: float
    held_cost: float | None
    nuisance: Nuisance
    sims: dict
    held_parts: dict | None = None      # held-out cost by kind of evidence (position, delivery, pressure)
    fit_parts: dict | None = None       # the same on the fitting runs


@dataclass
class Outcome:
    """Everything the workflow found (see :meth:`as_contract`)."""

    model: tuple
    library: Library
    before: Evaluation
    after: Evaluation
    fit_runs: list
    held_runs: list
    ranking: list                   # rows over all rounds
    disagreements_before: list
    disagreements_after: list
    findings_before: list
    n_sims: int
    seconds: float                  # wall-clock (simulations may run in worker processes)
    excluded: dict
    notes: list
    valve_type: object = "disc"          # the context effects were fitted in (valve type or pump model)
    nuisances: tuple = ()                # baseline nuisances fitted with the model (Applied), not effects
    nuisance_widths: dict = field(default_factory=dict)   # "effect.param" -> change that costs one gap unit
    validation: dict | None = None       # the baseline's V&V 20 rows per run and output, before and after
    unexplained: dict = field(default_factory=dict)      # what the final model leaves (leftover.unexplained)
    cost: dict = field(default_factory=dict)             # simulations and seconds per stage and candidate
    backward: list = field(default_factory=list)         # every removal tried by the backward step (rows)
    indistinguishable: list = field(default_factory=list)  # candidates the data cannot tell from one named

    def as_contract(self) -> dict:
        """The contract's JSON keys plus the details behind them."""
        names, params, units, targets = [], {}, {}, {}
        for a in self.model:
            eff = self.library[a.name]
            names.append(a.name)
            params[a.name] = eff.report(a.value_dict, self.valve_type, a.target)
            units[a.name] = eff.units(self.valve_type, a.target)
            targets[a.name] = a.target
        fit_names = [r.name for r in self.fit_runs]
        held_names = [r.name for r in self.held_runs]
        return {
            "effects_added": names,
            "parameters": params,
            "parameter_units": units,
            "targets": targets,
            "gap_before": gap_of(self.before, fit_names + held_names),
            "gap_after": gap_of(self.after, fit_names + held_names),
            "disagreements": self.disagreements_before,
            "disagreements_after": self.disagreements_after,
            "held_out": self._held_out(held_names),
            "fitted": {
                "runs": fit_names,
                "gap_before": gap_of(self.before, fit_names),
                "gap_after": gap_of(self.after, fit_names),
            },
            "nuisance": {"before": self.before.nuisance.as_dict(), "after": self.after.nuisance.as_dict()},
            "baseline_nuisances": self.nuisance_report(),
            "runs": [
                {**gb.as_dict(), "held_out": gb.run in held_names,
                 "after": {k: v for k, v in ga.as_dict().items() if k not in ("run", "speed_rpm", "load_pressure_pa")}}
                for gb, ga in zip(self.before.gaps, self.after.gaps)
            ],
            "ranking": self.ranking,
            "effects_dropped": [{k: r[k] for k in ("round", "effect", "target", "parameters", "why_dropped")}
                                for r in self.backward if r["dropped"]],
            "backward": self.backward,
            "indistinguishable": json_safe(self.indistinguishable),
            "validation": json_safe(self.validation),
            "unexplained": self.unexplained,
            "cost": json_safe(self.cost),
            "excluded_effects": self.excluded,
            "simulations": self.n_sims,
            "wall_seconds": self.seconds,
            "notes": self.notes,
        }

    def _held_out(self, held_names: list) -> dict | None:
        """The contract's ``held_out`` object: the held-out runs' gaps before and after, their reductions."""
        if not held_names:
            return None
        hb, ha = gap_of(self.before, held_names), gap_of(self.after, held_names)
        return {
            "runs": held_names,
            "gap_before": hb,
            "gap_after": ha,
            "position_rms_reduction_pct": reduction(hb["position_rms_m"], ha["position_rms_m"]),
            "position_excess_reduction_pct": reduction(hb["position_excess_rms_m"], ha["position_excess_rms_m"]),
            "delivery_error_reduction_pct": reduction(hb["delivery_error_pct"], ha["delivery_error_pct"]),
            "pressure_excess_reduction_pct": reduction(hb["pressure_excess_rms_pa"], ha["pressure_excess_rms_pa"]),
            "cost_before": self.before.held_cost,
            "cost_after": self.after.held_cost,
        }

    def nuisance_report(self) -> dict:
        """Baseline nuisances fitted with the final model: values and the one-gap-unit half-widths."""
        out = {}
        for a in self.nuisances:
            vals = a.value_dict
            out[a.name] = {
                "target": a.target, "values": vals,
                "one_unit_half_width": {k: self.nuisance_widths.get(f"{a.name}.{k}") for k in vals},
                "summary": self.library[a.name].summary,
            }
        return json_safe(out)

    def nuisance_sentences(self) -> list[str]:
        """The fitted nuisances in words (e.g. "discharge_scale (both valves): scale = 0.970 +- 0.004")."""
        out = []
        for name, d in self.nuisance_report().items():
            vals = ", ".join(f"{k} = {v:.4g}" + (f" +- {w:.2g}" if (w := d["one_unit_half_width"].get(k)) else "")
                             for k, v in d["values"].items())
            out.append(f"{name} ({d['target']}): {vals} (fitted as a baseline nuisance, not an effect; "
                       f"+- is the change that raises the fit cost by one gap unit)")
        return out


def values_text(values: dict, units: dict) -> str:
    """Fitted values as a user reads them, each with its unit (none for a ratio, ``-``).

    Parameters
    ----------
    values : dict
        {name: value} in SI.
    units : dict
        {name: unit} (:meth:`lumped.model.effects.Effect.units`); a name without one is printed bare.

    Returns
    -------
    str

    >>> values_text({"k_seat": 1503314.78, "c_seat": 153.1395, "scale": 0.99941}, {"k_seat": "N/m", "c_seat": "N s/m",
    ...             "scale": "-"})
    'k_seat = 1.503e+06 N/m, c_seat = 153.1 N s/m, scale = 0.9994'
    """
    return ", ".join(f"{k} = {v:.4g} {units.get(k, '') if units.get(k) != '-' else ''}".rstrip()
                     for k, v in values.items())


def gap_of(ev: Evaluation, runs) -> dict:
    """The contract's gap object of an evaluated model on the runs named ``runs``."""
    s = summary([g for g in ev.gaps if g.run in runs])
    return {"position_rms_m": s["position_rms_m"], "delivery_error_pct": s["delivery_error_pct"],
            "position_excess_rms_m": s["position_excess_rms_m"], "pressure_excess_rms_pa": s["pressure_excess_rms_pa"]}


def parts(gaps, names, scales) -> dict:
    """Cost of the runs ``names`` by kind of evidence (RunGap.cost_parts summed)."""
    out = {"position": 0.0, "delivery": 0.0, "pressure": 0.0}
    for g in gaps:
        if g.run in names:
            for k, v in g.cost_parts(scales).items():
                out[k] += v
    return out


def reduction(before, after):
    """Per cent by which ``after`` is below ``before`` (None where either is missing or ``before`` is 0)."""
    if before is None or after is None or before == 0:
        return None
    return 100.0 * (1.0 - after / before)



def delta_bic(n_eff: float, cost: float, base_cost: float, k: int) -> float:
    """BIC of a model with k more parameters than its base, less the base's: n ln(cost / base cost) + k ln n on
    n_eff effective residuals (Schwarz 1978, Gaussian residuals); inf when either cost is not finite."""
    if not (math.isfinite(cost) and math.isfinite(base_cost)):
        return math.inf
    return n_eff * math.log(max(cost, 1e-12) / max(base_cost, 1e-12)) + k * math.log(n_eff)


def rank_key(f: CandidateFit):
    """Eligible (plausible, BIC-paying) candidates first, then by held-out cost, then fit cost; hopeless last."""
    eligible = f.failed is None and not f.rejected and not f.screened_out and f.plausible_reason is None \
        and f.delta_bic < 0
    score = f.held_cost if f.held_cost is not None else f.fit_cost
    return (f.rejected, f.screened_out is not None, not eligible, score if math.isfinite(score) else math.inf,
            f.fit_cost)


def with_value(model: tuple, i: int, name: str, value: float) -> tuple:
    """``model`` with parameter ``name`` of its ``i``-th applied effect set to ``value``."""
    return model[:i] + (model[i].with_values({name: value}),) + model[i + 1:]
