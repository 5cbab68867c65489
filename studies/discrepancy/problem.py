"""One discrepancy problem: the measured runs, the simulator, the candidate library and the settings, with the
cost of a model on them.

A model is a tuple of :class:`lumped.model.effects.Applied` (the effects added and the baseline nuisances).
Its cost on the fitting runs (:meth:`Problem.fit_objective`) is the sum of squared scaled residuals with the
position sensor's nuisances profiled out: every position trace, cylinder-pressure trace and delivery weighs
as its mean square over one gap unit (:class:`studies.discrepancy.gap.GapScales`), the pressure with a robust
(Cauchy) loss. :meth:`Problem.evaluate` scores every run.
"""

from __future__ import annotations

import math
import sys
from collections import OrderedDict
from dataclasses import replace

import numpy as np
from tqdm import tqdm

from geometry.errors import InputError, ModelFailure
from lumped.model.effects import Effect, Library, Parameter
from studies.discrepancy.gap import (
    Folded, Nuisance, fit_nuisance, fold, predict, pressure_residual, robust_pressure, run_gap,
)
from studies.discrepancy.holdout import split
from studies.discrepancy.measured import Run
from studies.discrepancy.records import Evaluation, RunCondition, parts
from studies.discrepancy.settings import Settings
from studies.discrepancy.simulations import SimulationFailure, Simulations

#: most trace samples per run the search works on: longer traces are averaged down to this (:func:`coarsened`).
#: One round costs about SECONDS_PER_SAMPLE_ROUND per sample on top of the simulations (three runs of 1,000 vs
#: 20,000 samples, one round: 6.0 vs 14.6 s on 2 workers)
MAX_TRACE_SAMPLES = 10_000
SECONDS_PER_SAMPLE_ROUND = 1.6e-4
#: fit residuals kept per problem (:meth:`Problem.fit_residuals`), the most recently used: a third of a search's
#: residual vectors are asked for again for a model just computed (the candidate's screening cost and then its
#: profile, a polish's start and its Jacobian's base; v2_03 of the independent suite: 376 asked, 230 distinct),
#: and their sensor fit and residuals are most of the workflow's own seconds beside the simulations. 64 of
#: ~15,000 residuals each (four fitting runs of the independent suite): 7.5 MB; at most ~60 MB (four fitting
#: runs of MAX_TRACE_SAMPLES samples, two valves and the cylinder pressure)
RESIDUAL_MEMO = 64


def coarsened(run: Run) -> tuple[Run, str | None]:
    """``run`` with its trace folded onto one revolution and averaged over blocks of k samples adjacent in
    crank angle when it holds more than MAX_TRACE_SAMPLES (the search's cost grows with the samples; each
    block then spans about 360 / MAX_TRACE_SAMPLES crank degrees, whatever the revolutions), and a note
    saying so (None when the run is kept as it is)."""
    tr = run.trace
    n = 0 if tr is None else len(tr.time)
    if n <= MAX_TRACE_SAMPLES:
        return run, None
    k = math.ceil(n / MAX_TRACE_SAMPLES)
    m = n // k
    period = 60.0 / run.speed_rpm
    t = np.mod(np.asarray(tr.time, float), period)       # the search folds the trace anyway
    t[t > period * (1.0 - 1e-9)] = 0.0                   # a rounding short of a whole revolution is TDC
    order = np.argsort(t, kind="stable")[: m * k]

    def block(a):
        return np.asarray(a, float)[order].reshape(m, k).mean(axis=1)

    note = (f"{run.name}: {n:,} trace samples (about {n * SECONDS_PER_SAMPLE_ROUND:.0f} s per round of the "
            f"search besides the simulations); folded onto one revolution and averaged over blocks of {k} "
            f"samples adjacent in crank angle to {m:,} (at most {MAX_TRACE_SAMPLES:,} per run; "
            f"{360.0 / m:.2g} crank deg each)")
    return replace(run, trace=type(tr)(block(t), tr.speed_rpm, {key: block(v) for key, v in tr.signals.items()})), note


def bounded_nuisances(library: Library, settings: Settings, context) -> dict:
    """name -> (the nuisance effect with its parameters bounded to prior x (1 -+ nuisance_range), target).

    Only library effects that are not candidates and apply to the context (a user's library
    without ``discharge_scale`` simply has no nuisance).
    """
    out = {}
    r = settings.nuisance_range
    for name in settings.nuisance_effects:
        if name not in library or library[name].candidate:
            continue
        eff = library[name]
        target = eff.targets[0]
        if not eff.applies_to(context, target):
            continue
        params = []
        for p in eff.parameters_for(context, target):
            lo, hi = sorted((p.prior * (1 - r), p.prior * (1 + r)))
            params.append(Parameter(p.name, p.unit, p.prior, (lo, hi), (lo, hi), p.source, log=False,
                                    field=p.field))
        out[name] = (replace(eff, parameters=tuple(params), variants={}), target)
    return out


class Problem:
    """The runs, simulator, library and settings of one search, with the cost of a model on them.

    ``runs`` are the usable runs (a trace or a measured delivery), already checked; ``context`` is what effect
    priors are computed for (the pump model, or the valve type). Holds the simulation cache
    (:class:`~studies.discrepancy.simulations.Simulations`), the nuisance Jacobians taken
    (``jacobians``) and the backward step's trials (``removals``).
    """

    def __init__(self, runs: list[Run], simulator, library: Library, settings: Settings, context=None,
                 progress: bool = True):
        self.notes: list[str] = []
        self.progress = progress
        self.runs = []
        for r in runs:
            r, note = coarsened(r)
            if note is not None:
                self.notes.append(note)
                self.log(note)
            self.runs.append(r)
        self.valve_type = self.runs[0].valve_type
        self.context = context if context is not None else self.valve_type
        self.library = library
        self.settings = settings
        self.folded = {r.name: fold(r) for r in self.runs if r.trace is not None}
        self.fit_runs, self.held_runs = split(self.runs, settings.holdout)
        self.conds = {r.name: RunCondition.of(r) for r in self.runs}
        self.sims = Simulations(simulator, settings.workers)
        self.last_failure: str | None = None    # why the last failed simulation failed
        self.jacobians: dict = {}               # model -> its nuisance Jacobian (profile.base_jacobian)
        self.removals: dict = {}                # (model, index) -> the backward step's trial (backward.removal)
        self.held: dict = {}                    # (effect, target) -> {parameter: value} pulled inside (edge.py)
        self.nuisance_effects = bounded_nuisances(library, settings, self.context)
        self._residuals: OrderedDict = OrderedDict()   # model -> (residuals, Nuisance, failure) (fit_residuals)

    def held_values(self, name: str, target: str) -> dict:
        """The parameters of the added effect ``name`` at ``target`` that its judgement pulled inside their
        plausible range (studies.discrepancy.edge), with their values: every later refit holds them."""
        return self.held.get((name, target), {})

    def log(self, msg: str):
        """A progress line on stderr (when ``progress``)."""
        if self.progress:
            tqdm.write(f"discrepancy: {msg}", file=sys.stderr)

    @property
    def min_gain_units(self) -> float:
        """The absolute gain floor [gap units]: Settings.min_abs_improvement, or its default for whether
        a Cd nuisance is fitted (1.5 with, 3 without)."""
        if self.settings.min_abs_improvement is not None:
            return float(self.settings.min_abs_improvement)
        return 1.5 if self.nuisance_effects else 3.0

    def eff(self, name: str) -> Effect:
        """The effect of an applied name: the bounded nuisance version for a nuisance, else the library's."""
        return self.nuisance_effects[name][0] if name in self.nuisance_effects else self.library[name]

    def is_nuisance(self, name: str) -> bool:
        """Whether ``name`` is a baseline nuisance (fitted, never named)."""
        return name in self.nuisance_effects

    def k(self, eff: Effect, target: str) -> int:
        """The parameters an effect adds for the BIC (a pure switch still costs one)."""
        return max(1, len(eff.parameters_for(self.context, target)))

    def prior_residuals(self, model: tuple) -> np.ndarray:
        """Prior residuals of the nuisances in ``model``: (value - prior) / (sd prior), one per parameter."""
        out = []
        for a in model:
            if a.name in self.nuisance_effects:
                vals = a.value_dict
                for p in self.nuisance_effects[a.name][0].parameters:
                    out.append((vals[p.name] - p.prior) / (self.settings.nuisance_prior_sd * abs(p.prior)))
        return np.array(out, float)

    # -- costs ----------------------------------------------------------------------

    def simulate(self, model: tuple, runs: list[Run]) -> dict:
        """run name -> the simulated revolution of ``model`` at that run's condition (or a SimulationFailure)."""
        res = self.sims.many([(self.conds[r.name], model) for r in runs])
        return {r.name: s for r, s in zip(runs, res)}

    def sensor_nuisance(self, sims: dict) -> Nuisance:
        """The position sensor's nuisances (scale per valve, time offset) fitted on the fitting runs' traces."""
        fit = [r for r in self.fit_runs if r.trace is not None]
        if not fit:
            fit = [r for r in self.runs if r.trace is not None]
        return fit_nuisance(fit, self.folded, sims, scale_bounds=self.settings.scale_bounds,
                            offset_bounds_s=self.settings.offset_bounds_s)

    def fit_residuals(self, model: tuple) -> tuple[np.ndarray | None, Nuisance]:
        """Scaled residuals on the fitting runs, nuisances profiled out (None if a simulation
        failed): each position trace divided by the position tolerance and sqrt(samples), so
        it weighs as its mean square; each delivery by the delivery tolerance; each
        cylinder-pressure trace by the pressure tolerance and sqrt(samples).

        A pure function of ``model`` (its simulations are cached): the last RESIDUAL_MEMO results are kept and
        a copy handed out again."""
        hit = self._residuals.get(model)
        if hit is None:
            hit = self._fit_residuals(model)
            self._residuals[model] = hit
            if len(self._residuals) > RESIDUAL_MEMO:
                self._residuals.popitem(last=False)
        else:
            self._residuals.move_to_end(model)
        res, nuis, failure = hit
        if failure is not None:
            self.last_failure = failure
            return None, nuis
        return res.copy(), nuis

    def _fit_residuals(self, model: tuple) -> tuple[np.ndarray | None, Nuisance, str | None]:
        """:meth:`fit_residuals` computed: (residuals, sensor nuisances, why a simulation failed or None)."""
        sims = self.simulate(model, self.fit_runs)
        bad = [s for s in sims.values() if isinstance(s, SimulationFailure)]
        if bad:
            return None, Nuisance(), bad[0].reason
        nuis = self.sensor_nuisance(sims)
        sc = self.settings.scales
        out = []
        for r in self.fit_runs:
            s = sims[r.name]
            if r.name in self.folded:
                f = self.folded[r.name]
                for valve, th in f.crank_deg.items():
                    res = f.position[valve] - predict(s, valve, th, r.speed_rpm, nuis)
                    out.append(res / (sc.position_m * math.sqrt(res.size)))
                res = pressure_residual(f, s)
                if res is not None:
                    res, _ = robust_pressure(res, f.pressure_noise_pa, sc.pressure_robust)
                    out.append(res / (sc.pressure_pa * math.sqrt(res.size)))
            if r.delivery_m3_per_rev is not None:
                out.append(np.array([(s.delivery_m3_per_rev - r.delivery_m3_per_rev)
                                     / r.delivery_m3_per_rev / sc.delivery_frac]))
        out.append(self.prior_residuals(model))
        return np.concatenate(out), nuis, None

    def fit_objective(self, model: tuple) -> tuple[float, Nuisance]:
        """Cost on the fitting runs, nuisances profiled out (inf if a simulation failed)."""
        res, nuis = self.fit_residuals(model)
        return (math.inf, nuis) if res is None else (float(res @ res), nuis)

    def residual_vector(self, model: tuple) -> np.ndarray | None:
        """Residuals whose sum of squares is :meth:`fit_objective` (for least_squares)."""
        return self.fit_residuals(model)[0]

    def evaluate(self, model: tuple) -> Evaluation:
        """Gaps of every run under ``model`` (nuisances fitted on the fitting runs)."""
        sims = self.simulate(model, self.runs)
        bad = [n for n, s in sims.items() if isinstance(s, SimulationFailure)]
        if bad:
            raise ModelFailure(f"the model failed for run {bad[0]}: {sims[bad[0]].reason}")
        hit = self._residuals.get(model)
        nuis = hit[1] if hit is not None and hit[2] is None else self.sensor_nuisance(sims)   # the same fit
        gaps = []
        for r in self.runs:
            folded = self.folded.get(r.name)
            if folded is None:
                folded = Folded({}, {}, {})
            gaps.append(run_gap(r, folded, sims[r.name], nuis, self.settings.scales))
        sc = self.settings.scales
        fit_names = {r.name for r in self.fit_runs}
        held_names = {r.name for r in self.held_runs}
        fit_cost = sum(g.cost(sc) for g in gaps if g.run in fit_names)
        held_cost = sum(g.cost(sc) for g in gaps if g.run in held_names) if held_names else None
        return Evaluation(model, gaps, fit_cost + (held_cost or 0.0), fit_cost, held_cost, nuis, sims,
                          parts(gaps, held_names, sc) if held_names else None, parts(gaps, fit_names, sc))

    def n_effective(self, ev: Evaluation) -> float:
        """Effective number of independent residuals on the fitting runs.

        Each position trace counts N (1 - rho) / (1 + rho) samples (rho: lag-1
        autocorrelation of its residual, the AR(1) variance-inflation factor), each
        measured delivery counts one.
        """
        n = 0.0
        fit_names = {r.name for r in self.fit_runs}
        for g in ev.gaps:
            if g.run not in fit_names:
                continue
            traces = [v.residual_m for v in g.valves] + ([g.pressure.residual_pa] if g.pressure is not None else [])
            for res in traces:
                r = res - np.mean(res)
                den = float(r @ r)
                rho = float(r[1:] @ r[:-1]) / den if den > 0 else 0.0
                rho = min(max(rho, 0.0), 0.999)
                n += max(1.0, r.size * (1 - rho) / (1 + rho))
            if g.delivery_error_pct is not None:
                n += 1.0
        return max(n, 2.0)

    def large(self, ev: Evaluation) -> bool:
        """Whether the gap an evaluated model leaves is large (Settings.large_gap_units_per_run per run)."""
        return ev.fit_cost + (ev.held_cost or 0.0) > self.settings.large_gap_units_per_run * len(self.runs)


def check_inputs(runs, simulator, library, settings, progress) -> list[Run]:
    """The workflow's arguments checked before any work (InputError naming the first bad one); the usable runs
    (a trace or a measured delivery). ``runs`` may be a dataset folder (read by
    :func:`studies.discrepancy.measured.read_dataset`)."""
    import os

    from geometry import validate
    from studies.discrepancy.measured import read_dataset

    if isinstance(runs, (str, os.PathLike)):
        runs = read_dataset(runs)
    if not isinstance(runs, (list, tuple)) or not all(isinstance(r, Run) for r in runs):
        raise InputError("runs", f"expected a list of studies.discrepancy.measured.Run or a dataset folder, "
                                 f"got {type(runs).__name__}")
    if not callable(simulator):
        raise InputError("simulator", f"expected a callable (run condition, effects) -> CycleTrace, got "
                                      f"{simulator!r}")
    if not isinstance(library, Library):
        raise InputError("library", f"expected a lumped.model.effects.Library (e.g. studies.discrepancy.pump_sim.LIBRARY),"
                                    f" got {library!r}")
    if not isinstance(settings, Settings):
        raise InputError("settings", f"expected a studies.discrepancy.Settings, got {settings!r}")
    validate.boolean(progress, "progress")
    if not runs:
        raise InputError("DATASET", "no runs")
    usable = [r for r in runs if r.trace is not None or r.delivery_cc_per_rev is not None]
    if not usable:
        raise InputError("DATASET", "no run has a trace.csv or a measured delivery_cc_per_rev to compare with")
    return usable
