"""The discrepancy workflow: which physics is the baseline model missing?

Given measured runs (``studies/discrepancy/measured.py``), a simulator (run condition + applied
effects -> one simulated revolution) and a library of candidate effects
(``lumped/model/effects.py``), the workflow

1. simulates the baseline for every run and measures the gap (``studies/discrepancy/gap.py``);
2. splits the runs by operating condition into fitting and held-out runs (``holdout.py``), and fits the
   baseline's own nuisances (the discharge-coefficient factor, ``Settings.nuisance_effects``), which every
   later model carries and refits but which are never named (``search.start``);
3. fits each candidate's parameters on the fitting runs (``fitting.py``), with the position sensor's scale
   per valve and time offset profiled out (they are in real data and must not pass for physics) and the
   baseline nuisances profiled out to first order (``profile.py``), then refits the candidate and the
   nuisances jointly where it could pass;
4. scores every fit on the held-out runs, checks its parameters are physically plausible and that it pays
   for its parameters (``selection.py``: a BIC whose sample count is the effective number of independent
   residuals, the decision rule);
5. adds the best candidate if it shrinks the held-out gap significantly, refits the added effects jointly,
   and repeats until no candidate helps (``search.py``; joint and pair searches in ``joint.py``);
6. after each addition (and at the end) takes each earlier-added effect out again, refits the others
   jointly and drops it when the same rule would not add it back (``backward.py``);
7. says what is left (``leftover.py``).

:class:`Workflow` is the facade over these parts; its result is an
:class:`~studies.discrepancy.records.Outcome`, whose :meth:`~studies.discrepancy.records.Outcome.as_contract`
is the contract's JSON; ``studies/discrepancy/report.py`` writes a report folder.
"""

from __future__ import annotations

import time

from geometry.errors import InputError, ModelFailure  # noqa: F401  (re-exported)
from lumped.model.effects import Effect, Library
from studies.discrepancy import fitting, leftover, search
from studies.discrepancy import profile as prof
from studies.discrepancy.words import describe, findings
from studies.discrepancy import validation as val
from studies.discrepancy.holdout import conditions, split  # noqa: F401  (re-exported)
from studies.discrepancy.measured import Run
from studies.discrepancy.problem import MAX_TRACE_SAMPLES, Problem, check_inputs
from studies.discrepancy.records import (  # noqa: F401  (re-exported)
    CandidateFit, Evaluation, Outcome, RunCondition, Simulator,
)
from studies.discrepancy.selection import verdict
from studies.discrepancy.settings import Settings
from studies.discrepancy.simulations import SimulationFailure, Simulations

__all__ = ["CandidateFit", "Evaluation", "MAX_TRACE_SAMPLES", "ModelFailure", "Outcome", "RunCondition",
           "Settings", "SimulationFailure", "Simulations", "Workflow", "conditions", "split"]


class Workflow:
    """The discrepancy search over one dataset (see the module docstring)."""

    def __init__(self, runs: list[Run], simulator: Simulator, library: Library, settings: Settings = Settings(),
                 progress: bool = True, context=None):
        """``runs``: the measured runs, or a dataset folder (a path: read by
        :func:`studies.discrepancy.measured.read_dataset`). Every argument is checked here, before any work
        (InputError naming it); a trace longer than :data:`MAX_TRACE_SAMPLES` is averaged down to it (a note
        and a line on stderr say so). ``context``: what effect priors are computed for (the pump model;
        default the runs' valve type)."""
        usable = check_inputs(runs, simulator, library, settings, progress)
        self.problem = Problem(usable, simulator, library, settings, context, progress)

    # -- the problem's parts, read-only
    runs = property(lambda self: self.problem.runs, doc="the usable runs (a trace or a measured delivery)")
    fit_runs = property(lambda self: self.problem.fit_runs, doc="the runs fitted on")
    held_runs = property(lambda self: self.problem.held_runs, doc="the runs held out")
    settings = property(lambda self: self.problem.settings, doc="the search's Settings")
    library = property(lambda self: self.problem.library, doc="the candidate effects")
    context = property(lambda self: self.problem.context, doc="what effect priors are computed for")
    sims = property(lambda self: self.problem.sims, doc="the simulation cache (Simulations)")
    notes = property(lambda self: self.problem.notes, doc="notes for the JSON's notes key")

    @property
    def min_gain_units(self) -> float:
        """The absolute gain floor [gap units] (Problem.min_gain_units)."""
        return self.problem.min_gain_units

    def simulate(self, model: tuple, runs: list[Run]) -> dict:
        """run name -> the simulated revolution of ``model`` at that run's condition."""
        return self.problem.simulate(model, runs)

    def fit_objective(self, model: tuple):
        """(cost on the fitting runs, sensor nuisances), the sensor nuisances profiled out (inf on a failure)."""
        return self.problem.fit_objective(model)

    def residual_vector(self, model: tuple):
        """Residuals whose sum of squares is :meth:`fit_objective`."""
        return self.problem.residual_vector(model)

    def evaluate(self, model: tuple) -> Evaluation:
        """Gaps of every run under ``model``."""
        return self.problem.evaluate(model)

    def n_effective(self, ev: Evaluation) -> float:
        """Effective number of independent residuals on the fitting runs."""
        return self.problem.n_effective(ev)

    def fit(self, base: tuple, effect: Effect, target: str,
            options: fitting.FitOptions = fitting.FitOptions()) -> fitting.FitResult:
        """``effect`` at ``target`` fitted on top of ``base`` (studies.discrepancy.fitting.fit)."""
        return fitting.fit(self.problem, base, effect, target, options)

    def refine(self, model: tuple, skip: frozenset = frozenset()) -> tuple:
        """The added effects refitted one at a time (studies.discrepancy.fitting.refine)."""
        return fitting.refine(self.problem, model, skip)

    def polish(self, model: tuple, names: set) -> tuple:
        """The effects named refitted jointly by least squares (studies.discrepancy.fitting.polish)."""
        return fitting.polish(self.problem, model, names)

    def verdict(self, f: CandidateFit) -> str | None:
        """None if the candidate would be added, else why not (studies.discrepancy.selection.verdict)."""
        return verdict(f, self.problem.settings, self.problem.min_gain_units)

    def run(self) -> Outcome:
        """The whole search (the module docstring): what is added, what is left, what it cost.

        With one BLAS thread: the search's linear algebra is on vectors of tens of thousands of residuals,
        where threaded BLAS on a shared machine costs more in its threads' hand-offs than it saves (a dot
        product of 60,000: 20 ms with two threads at a load of 13, 0.07 ms with one; the workflow's CPU
        seconds 8.0 -> 6.3 and 12.4 -> 9.4 on two datasets), and its sums then do not depend on the machine's
        thread count."""
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1, user_api="blas"):
            return self._run()

    def _run(self) -> Outcome:
        """:meth:`run`'s body."""
        t0 = time.perf_counter()
        pb = self.problem
        cands, excluded = pb.library.candidates(pb.context, pb.runs)
        if not pb.held_runs:
            pb.notes.append("one operating condition only: nothing held out; significance from the fit runs "
                            "and the information criterion alone")
        pb.log(f"{len(pb.runs)} runs ({len(pb.fit_runs)} fitted, {len(pb.held_runs)} held out), "
               f"{len(cands)} candidate effects")
        state = search.start(pb)
        pb.sims.stage = "validation"
        validation = leftover.validate(pb, state.before) if pb.settings.validation else None
        if validation is not None:
            for b in validation["beyond"]:
                pb.log("beyond the validation uncertainty: " + val.sentence(b))
        search.search(pb, state, cands)
        return self._outcome(state, validation, excluded, t0)

    def _outcome(self, state: search.State, validation: dict | None, excluded: dict, t0: float) -> Outcome:
        """The Outcome of a finished search: findings before and after in words, the nuisances and their
        one-unit widths, the validation after, what is left unexplained, the cost."""
        pb = self.problem
        before, after, current = state.before, state.cur, state.current
        sc = pb.settings.scales
        fb = [f for g in before.gaps for f in findings(g, sc)]
        fa = [f for g in after.gaps for f in findings(g, sc)]
        n_runs = {}
        for r in pb.runs:
            for v in r.measured_valves:
                n_runs[v] = n_runs.get(v, 0) + 1
            if r.delivery_cc_per_rev is not None:
                n_runs["pump"] = n_runs.get("pump", 0) + 1
        nuisances = tuple(a for a in current if a.name in pb.nuisance_effects)
        pb.sims.stage = "nuisance widths"
        widths = prof.nuisance_widths(pb, current) if nuisances else {}
        if validation is not None:
            validation["after"] = val.after(validation["rows"], leftover.outputs_of(pb, after))
            validation["beyond_after"] = val.beyond(validation["after"])
        model = tuple(a for a in current if a.name not in pb.nuisance_effects)
        unexplained = leftover.unexplained(pb, before, after, validation, state.rounds, nuisances, fa)
        undecided = state.undecided(pb)
        unexplained["sentences"] += [g["sentence"] for g in undecided]
        pb.sims.__exit__()
        return Outcome(model, pb.library, before, after, pb.fit_runs, pb.held_runs, state.ranking,
                       describe(fb, n_runs), describe(fa, n_runs), fb, pb.sims.count, time.perf_counter() - t0,
                       excluded, pb.notes, pb.context, nuisances, widths, validation, unexplained,
                       leftover.cost_report(pb.sims), state.backward, undecided)
