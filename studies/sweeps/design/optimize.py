"""Design optimisation of a pump's model-file parameters: NSGA-II (pymoo) or differential evolution (scipy).

The loop
--------
Every generation's new designs run at every operating point on dask (one sweep folder per
generation, ``generations/gen-NNNN/``, :mod:`studies.sweeps.design.runner`), with the fast integrator
and the analytic reed model unless the spec says otherwise. Each design's objectives are
aggregated over the operating points (``mean``, the default, or ``worst``: the largest value
of a minimised output, the smallest of a maximised one); every constraint must hold at every
operating point (its worst value is constrained). A design whose evaluation fails at any point
(invalid geometry, an integrator error, no cyclic steady state within ``max_revolutions``) or
lacks an output is infeasible (one extra constraint).

Objectives ``max NAME`` / ``min NAME`` (one: scipy's ``differential_evolution``, vectorised over
the population, no polishing; several: pymoo's NSGA-II with ask and tell). Variables with
``scale = "log"`` are optimised in log space.

Resuming
--------
Both optimisers are seeded and deterministic, and a rerun replays them: each generation's designs
are regenerated from the recorded results of the previous ones, so the generation folders already
complete are read back, not recomputed, and a generation that was interrupted resumes inside its
sweep folder. Nothing is recomputed.

Multi-fidelity re-check of the front
------------------------------------
Every design on the final front (NSGA-II: the final population's non-dominated feasible designs;
DE: the best design) is re-checked: each reed valve with a geometry by the solid FEA (kappa,
omega_n, gamma1..3 against the analytic model, flagged beyond ``recheck.tolerance_pct``; the
bending stress at maximum lift against the in-loop estimate, flagged when the estimate is more
than ``recheck.stress_tolerance_pct`` low), then every design at every operating point by the
reference integrator, with the solid FEA's kappa, gammas and h_eff for a flagged valve
(``fidelity = "solid"``). Those values are the design's reported objectives and constraints (the
solid FEA's stress for the stress constraint), the front is re-sorted, and each design is written as a
complete model file (``design_NNN.toml``) that ``valvelab pump --model FILE --method reference``
reproduces. The base model (the baseline, e.g. the prototype reed) goes through the same checks.
"""

from __future__ import annotations

import inspect
import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from geometry.errors import InputError
from studies.sweeps.design import runner, study
from studies.sweeps.design.calibration import calibrate, calibration_summary
from studies.sweeps.design.entries import file_keys, finish
from studies.sweeps.design.evaluator import Evaluator, point_json
from studies.sweeps.design.front import signs
from studies.sweeps.design.recheck import baseline, recheck
from studies.sweeps.design.spec import DesignSpec, check_size, point_label
from studies.sweeps.design.study import Study

SUBFOLDERS = ("generations", "calibration", "recheck-fea", "recheck-reference", "baseline")


# --------------------------------------------------------------------------- optimisers
def _nsga2(spec: DesignSpec, ev: Evaluator, progress: bool):
    """NSGA-II (pymoo, ask and tell): (the final population's non-dominated vectors, generations run)."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.evaluator import Evaluator as PymooEvaluator
    from pymoo.core.problem import Problem
    from pymoo.problems.static import StaticProblem

    r = spec.run_dict
    lo = np.array([v.opt_bounds()[0] for v in spec.variables])
    hi = np.array([v.opt_bounds()[1] for v in spec.variables])
    problem = Problem(n_var=len(lo), n_obj=len(spec.objectives), n_ieq_constr=ev.n_g, xl=lo, xu=hi)
    alg = NSGA2(pop_size=r["population"], eliminate_duplicates=True)
    alg.setup(problem, termination=("n_gen", r["generations"]), seed=r["seed"], verbose=False)
    bar = _bar(progress, r["generations"])
    try:
        while alg.has_next():
            pop = alg.ask()
            F, G = ev.evaluate(pop.get("X"))
            PymooEvaluator().eval(StaticProblem(problem, F=F, G=G), pop)
            alg.tell(infills=pop)
            _tick(bar, ev)
    finally:
        if bar is not None:
            bar.close()
    res = alg.result()
    X = np.atleast_2d(res.opt.get("X"))
    return [tuple(float(x) for x in z) for z in X], alg.n_gen - 1


def _de(spec: DesignSpec, ev: Evaluator, progress: bool):
    """Differential evolution (scipy, vectorised over the population, no polishing): ([the best vector],
    generations run).

    Runs the spec's ``run.generations``: the initial population and ``generations - 1`` evolved ones (scipy's
    convergence test is off, ``tol = atol = 0``: a population whose objectives agree within 1 % would otherwise
    stop it after one evolution, a run that asked for four reporting one)."""
    from scipy.optimize import NonlinearConstraint, differential_evolution

    r = spec.run_dict
    d = len(spec.variables)
    bounds = [v.opt_bounds() for v in spec.variables]
    bar = _bar(progress, r["generations"])
    populations = []

    def f(Z):
        F, _ = ev.evaluate(np.asarray(Z).T)
        return F[:, 0]

    def g(Z):
        Z = np.asarray(Z)
        if Z.ndim == 1 and tuple(float(x) for x in Z) not in ev.cache:
            # scipy asks once, before the first population, how many constraints there are: answered from the
            # count (a run of its own would be one more sweep folder and generation than the spec asked for)
            return np.zeros(ev.n_g)
        _, G = ev.evaluate(Z.T)
        if Z.ndim == 2:              # a population (the initial one, then each evolved one)
            populations.append(Z.shape[1])
            _tick(bar, ev)
        return G.T

    kw = {"rng" if "rng" in inspect.signature(differential_evolution).parameters else "seed": r["seed"]}
    try:
        res = differential_evolution(f, bounds, popsize=max(1, math.ceil(r["population"] / d)),
                                     maxiter=max(0, r["generations"] - 1), vectorized=True, updating="deferred",
                                     polish=False, tol=0.0, atol=0.0,
                                     constraints=NonlinearConstraint(g, -np.inf, 0.0), **kw)
    finally:
        if bar is not None:
            bar.close()
    return [tuple(float(x) for x in res.x)], len(populations)


def _bar(progress: bool, total: int):
    """A progress bar of the generations on stderr (None without progress)."""
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc="optimize", unit="generation", file=sys.stderr, smoothing=0.1)


def _tick(bar, ev: Evaluator):
    """One generation done: the bar shows the designs evaluated, feasible and computed."""
    if bar is None:
        return
    bar.set_postfix(designs=len(ev.cache), feasible=ev.feasible(), computed=ev.computed, refresh=False)
    bar.update(1)


# --------------------------------------------------------------------------- the study
class _reed_cache:
    """The study folder's ``.reed-cache/`` as lumped's FEA reed-property cache (lumped.reed.fidelities.CACHE_ENV) for
    this process and the local workers it starts: a front design's solid FEA, run by the re-check, is then not run
    again for its reference runs and its model file."""

    def __init__(self, out: Path):
        from lumped.reed.fidelities import CACHE_ENV

        self.env, self.path, self.old = CACHE_ENV, str(Path(out).resolve() / ".reed-cache"), None

    def __enter__(self):
        import os

        self.old = os.environ.get(self.env)
        os.environ.setdefault(self.env, self.path)
        return self

    def __exit__(self, *exc):
        import os

        if self.old is None:
            os.environ.pop(self.env, None)
        else:
            os.environ[self.env] = self.old


def _build_on_workers(ctx: Study, items) -> dict:
    """{repr(keys): PumpModel} of each design's model file, built on the workers: a design re-checked with the
    solid FEA's reed parameters needs that FEA again to be built, and the worker that re-ran it at the operating
    points still holds it (studies.sweeps.design.evaluate's model cache); built here it would cost a solid FEA
    per design in this one process."""
    from studies.sweeps.design.evaluate import build_design_model

    keys = list({repr(sorted(file_keys(rec).items())): file_keys(rec) for rec in items}.items())
    if not keys or ctx.cluster.client is None:
        return {}
    client = ctx.cluster.get()
    futures = client.map(build_design_model, [ctx.base_path] * len(keys), [k for _, k in keys], pure=False)
    out = {}
    for (name, _), f in zip(keys, futures):
        try:
            out[name] = f.result()
        except Exception:  # noqa: BLE001 - built again where the file is written, which reports the error
            pass
    return out


def _check(spec: DesignSpec, out: Path, force: bool):
    """Every check before any computation (the variables on the base model, the size, the folder); the base
    model."""
    r = spec.run_dict
    model = study.base_model(spec)
    study.check_variables(spec, model)
    n_eval = r["population"] * r["generations"]
    if n_eval > r["max_evaluations"]:
        raise InputError("run.generations", f"population x generations = {n_eval} designs exceeds "
                                            f"run.max_evaluations = {r['max_evaluations']}")
    check_size(n_eval * len(spec.points), "run.population", out,
               f"{r['population']} x {r['generations']} generations x {len(spec.points)} operating points")
    from studies.outputs import check_output_dir

    check_output_dir(out, "--out", force, kind="optimize")
    if model is not None and study.needs_stress(spec) and not study.reed_positions(model):
        raise InputError("constraints.reed_stress", "the base model has no reed valve with a geometry "
                                                    "(valves.<pos>.geometry)")
    return model


def _loop(ctx: Study, batch_size: int | None, stages: dict):
    """The stress calibration, then the optimiser's loop: (the study with its calibration, the evaluator, the
    front's records, the generations run)."""
    t0 = time.perf_counter()
    ctx = replace(ctx, calibration=calibrate(ctx)) if study.needs_stress(ctx.spec) else ctx
    stages["calibration"] = time.perf_counter() - t0
    module = study.EVALUATE if ctx.spec.model_kind == "pump" else ctx.spec.model
    ev = Evaluator(ctx, study.fixed_inputs(ctx.spec, ctx.base_path), module, batch_size)
    t_loop = time.perf_counter()
    front_keys, generations = (_nsga2 if ctx.spec.run_dict["algorithm"] == "nsga2" else _de)(ctx.spec, ev,
                                                                                                ctx.progress)
    stages["loop"] = time.perf_counter() - t_loop
    front = [dict(ev.cache[k], key=k) for k in dict.fromkeys(front_keys)]
    return ctx, ev, front, generations


def run_optimize(spec: DesignSpec, out, *, scheduler: str | None = None, workers: int | None = None, client=None,
                 batch_size: int | None = None, force: bool = False, progress: bool = True) -> dict:
    """Run (or resume) an optimisation into a study folder (see the module docstring).

    Parameters
    ----------
    spec : DesignSpec
        An ``optimize`` spec (:func:`studies.sweeps.design.spec.load_spec`).
    out : str or os.PathLike
        The study folder; a rerun replays the optimiser and computes nothing twice.
    scheduler, workers, client, batch_size, force, progress
        How it runs: :class:`~studies.sweeps.design.runner.StudyRun`.

    Returns
    -------
    dict
        The summary (CONTRACT.md, "Optimisation"), also written to ``summary.json``: the designs
        with their re-checked objectives and model files, the baseline, the files, timings.
    """
    run = runner.StudyRun(scheduler, workers, client, batch_size, force, progress)
    runner.check_study_arguments(spec, "optimize", out, run)
    t_start = time.perf_counter()
    out = Path(out)
    model = _check(spec, out, force)
    if progress:
        _announce(spec, run)
    stages: dict = {}
    with _reed_cache(out), runner.open_study(spec, out, model, run, SUBFOLDERS) as ctx:
        ctx, ev, front, generations = _loop(ctx, batch_size, stages)
        n_workers = ctx.cluster.workers if ctx.cluster.client is not None else None
        t0 = time.perf_counter()
        base = baseline(ctx) if spec.model_kind == "pump" else None    # the base model, fast (as in the loop)
        stages["baseline"] = time.perf_counter() - t0
        rechecked = recheck(ctx, front, base, stages)
        t0 = time.perf_counter()
        built = _build_on_workers(ctx, rechecked) if spec.model_kind == "pump" else {}
    designs = finish(ctx, rechecked, base, built)
    files = _report(ctx, ev, designs, base)
    stages["report"] = time.perf_counter() - t0
    result = _summary(ctx, ev, designs, base, files, generations, n_workers)
    result.update(wall_seconds=time.perf_counter() - t_start, loop_wall_seconds=stages["loop"],
                  stage_seconds={k: round(v, 2) for k, v in stages.items()},
                  designs_per_hour=ev.computed / ev.eval_seconds * 3600.0 if ev.computed and ev.eval_seconds else None)
    (out / "summary.json").write_text(json.dumps(_jsonable(result), indent=1, allow_nan=False))
    return _jsonable(result)


def _announce(spec: DesignSpec, run: runner.StudyRun) -> None:
    """Say what the optimisation runs and, for the pump model, about how long (studies.costs): the loop's
    evaluations on the cluster, then the best design (DE) or the front (NSGA-II, at most ``recheck.max_designs``)
    and the baseline on the reference integrator."""
    from studies import costs
    from studies.outputs import announce
    from studies.sweeps.cluster import default_workers

    r = spec.run_dict
    npts, d = len(spec.points), len(spec.variables)
    pop = math.ceil(r["population"] / d) * d if r["algorithm"] == "de" else r["population"]   # as _de sizes it
    n_loop = pop * r["generations"] * npts
    front = 1 if r["algorithm"] == "de" else min(pop, spec.recheck_dict.get("max_designs") or pop)
    algorithm = {"de": "differential evolution", "nsga2": "NSGA-II"}.get(r["algorithm"], r["algorithm"])
    what = (f"{algorithm}: {r['generations']} generations of {pop} designs x {npts} operating "
            f"point{'s' if npts > 1 else ''} = {n_loop} runs in the loop, then "
            f"{'the best design' if front == 1 else f'up to {front} designs of the front'} and the baseline re-checked "
            "on the reference integrator" + (" (reed valves by the solid FEA too)" if study.needs_stress(spec) else ""))
    if spec.model_kind != "pump":
        announce("optimize", what + "; no measured cost for this model")
        return
    workers = run.workers or (2 if run.scheduler or run.client is not None else default_workers())
    seconds = (0.0 if run.client is not None else costs.SECONDS["cluster"]) + costs.estimate(
        generation=r["generations"], pump__reference=(front + 1) * npts) + costs.estimate(pump__evaluation=n_loop) / workers
    announce("optimize", what, seconds, "measured per-run costs; the solid FEA and stress calibration not counted"
             if study.needs_stress(spec) else "measured per-run costs")


def _report(ctx: Study, ev: Evaluator, designs: list, base: dict | None) -> dict:
    """The Pareto table, the front plot (every feasible design evaluated) and the parallel-coordinates plot."""
    from studies.sweeps.design import report

    spec, out = ctx.spec, ctx.out
    files = {}
    rows, cols = report.pareto_rows(designs, spec.variables, spec.objectives, spec.constraints)
    files.update(report.write_pareto(out, rows, cols))
    feas = _feasible_f(ev)
    files["front_plot"] = str(report.plot_front(out / "front.png", spec.objectives, ctx.catalogue,
                                                feas * signs(spec.objectives) if len(feas) else None, designs, base,
                                                ev.records))
    if designs:
        files["parallel_plot"] = str(report.plot_parallel(out / "parallel.png", spec.variables, spec.objectives,
                                                          ctx.catalogue, designs, base))
    return files


def _feasible_f(ev: Evaluator) -> np.ndarray:
    """The objective vectors of every feasible design evaluated."""
    return np.array([rec["F"] for rec in ev.records if all(x <= 0 for x in rec["G"])])


def _summary(ctx: Study, ev: Evaluator, designs: list, base: dict | None, files: dict, generations: int,
             n_workers: int | None) -> dict:
    """The summary of an optimisation (without its timings)."""
    spec, catalogue = ctx.spec, ctx.catalogue
    r = spec.run_dict
    return {
        "command": "optimize", "algorithm": r["algorithm"], "model": spec.model, "out": str(ctx.out),
        "objectives": [{"output": o.output, "sense": o.sense, "aggregate": o.aggregate,
                        "unit": catalogue[o.output].unit} for o in spec.objectives],
        "constraints": [{"output": c.output, "min": c.low, "max": c.high, "unit": catalogue[c.output].unit,
                         "source": c.source} for c in spec.constraints],
        "variables": [v.describe() for v in spec.variables],
        "operating_points": [dict(point_json(p), label=point_label(p)) for p in spec.points],
        "population": r["population"], "generations": generations, "evaluated_designs": len(ev.cache),
        "feasible_designs": int(len(_feasible_f(ev))), "evaluations": len(ev.cache) * len(spec.points),
        "computed": ev.computed, "skipped": ev.skipped, "workers": n_workers,
        "stress_calibration": calibration_summary(ctx.calibration),
        "designs": designs, "baseline": base,
        "dominating_baseline": sum(1 for d in designs if d.get("dominates_baseline")),
        "warnings": [{"code": w["code"], "message": f"{d['name']}: {w['message']}"}
                     for d in designs + ([dict(base, name="baseline")] if base else [])
                     for w in d.get("warnings", [])],
        "files": files, "complete": True,
    }


def _jsonable(x):
    """Numpy scalars as Python numbers, NaN and infinity as None (the summary is strict JSON)."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return study.finite_or_none(float(x))
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x
