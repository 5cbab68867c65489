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
import tomllib
from pathlib import Path

import numpy as np

from geometry.errors import InputError
from studies.sweeps.design import runner, study
from studies.sweeps.design.spec import DesignSpec, check_size, design_inputs, point_label
from studies.sweeps.pump import parse_warnings

SUBFOLDERS = ("generations", "calibration", "recheck-fea", "recheck-reference", "baseline")
FAILED_F = 1e12          # objective value of an infeasible (failed) design: never on a front
PUMP_COMMAND = "valvelab pump --model {file} --method reference --speed-rpm {speed:g} --load-pressure-mpa {load:g} " \
               "--revolutions {rev} --max-revolutions {maxrev} --json"


# --------------------------------------------------------------------------- evaluation with a cache
class Evaluator:
    """Evaluate populations (optimiser space) on dask, one sweep folder per batch of new designs; cache by vector."""

    def __init__(self, spec: DesignSpec, cluster, out: Path, fixed: dict, module: str, catalogue: dict,
                 batch_size: int | None, progress: bool, calibration: dict | None = None):
        self.spec, self.cluster, self.out, self.fixed, self.module = spec, cluster, Path(out), fixed, module
        self.calibration = calibration
        self.catalogue, self.batch_size, self.progress = catalogue, batch_size, progress
        self.cache: dict = {}
        self.batches = 0
        self.computed = self.skipped = 0
        self.eval_seconds = 0.0
        self.objectives = spec.objectives
        self.constraints = spec.constraints
        self.n_g = len(self.constraints) + 1

    def values_of(self, z) -> dict:
        return {v.name: v.from_opt(float(x)) for v, x in zip(self.spec.variables, z)}

    def evaluate(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        Z = np.atleast_2d(np.asarray(Z, dtype=float))
        keys = [tuple(float(x) for x in z) for z in Z]
        new = [k for k in dict.fromkeys(keys) if k not in self.cache]
        if new:
            self._run(new)
        F = np.array([self.cache[k]["F"] for k in keys])
        G = np.array([self.cache[k]["G"] for k in keys])
        return F, G

    def _run(self, new: list[tuple]) -> None:
        spec = self.spec
        npts = len(spec.points)
        designs, invalid = [], {}
        for k in new:
            values = self.values_of(k)
            try:
                if spec.model_kind == "pump":
                    design_inputs(spec, values)
                designs.append((k, values))
            except InputError as exc:
                invalid[k] = str(exc)
        self.batches += 1
        folder = self.out / "generations" / f"gen-{self.batches:04d}"
        rows = study.rows_for(spec, [v for _, v in designs], self.calibration)
        t0 = time.perf_counter()
        try:
            df, summ = runner.evaluate_rows(self.cluster, folder, self.module, self.fixed, rows, group=npts,
                                            batch_size=self.batch_size, progress=False, desc=folder.name)
        except InputError as exc:
            if exc.field == "--out":
                raise InputError("--out", f"{self.out} holds an optimisation this spec does not replay ({folder.name} "
                                          "differs); pass --force to start over") from None
            raise
        self.eval_seconds += time.perf_counter() - t0
        self.computed += summ.get("computed", 0)
        self.skipped += summ.get("skipped", 0)
        recs = design_records(spec, self.catalogue, df, len(designs))
        for (k, values), rec in zip(designs, recs):
            rec["values"] = values
            rec["generation_folder"] = folder.name
            self.cache[k] = self._fg(rec)
        for k, msg in invalid.items():
            self.cache[k] = self._fg({"values": self.values_of(k), "ok": False, "error": msg, "objectives": {},
                                      "constraints": {}, "points": []})

    def _fg(self, rec: dict) -> dict:
        f, g = objective_vector(self.objectives, rec), constraint_vector(self.constraints, rec)
        rec["F"], rec["G"] = f, g
        return rec

    @property
    def records(self) -> list[dict]:
        return list(self.cache.values())


def design_records(spec: DesignSpec, catalogue: dict, df, n_designs: int) -> list[dict]:
    """Per design: objectives aggregated over the points, constraints at their worst, per-point values, ok."""
    npts = len(spec.points)
    names = list(dict.fromkeys([o.output for o in spec.objectives] + [c.output for c in spec.constraints]))
    mats = {n: runner.output_matrix(df, catalogue[n], n_designs, npts) for n in names}
    status = np.array(["missing"] * (n_designs * npts), dtype=object)
    errors = [None] * (n_designs * npts)
    warns = [[] for _ in range(n_designs * npts)]
    for r in df.to_dict("records"):
        status[int(r["row"])] = r["status"]
        errors[int(r["row"])] = r.get("error")
        warns[int(r["row"])] = parse_warnings(r.get("warnings"))
    status = status.reshape(n_designs, npts)
    labels = spec.point_labels
    out = []
    for i in range(n_designs):
        ok = bool((status[i] == "ok").all()) and all(np.isfinite(mats[n][i]).all() for n in names)
        rec = {"ok": ok, "status": list(status[i]), "objectives": {}, "constraints": {}, "points": [],
               "warnings": [{"code": w["code"], "message": (f"{labels[j]}: " if npts > 1 else "") + w["message"]}
                            for j in range(npts) for w in warns[i * npts + j]]}
        if not ok:
            bad = [j for j in range(npts) if status[i][j] != "ok"]
            rec["error"] = (errors[i * npts + bad[0]] or status[i][bad[0]]) if bad else \
                "missing output: " + ", ".join(n for n in names if not np.isfinite(mats[n][i]).all())
        for o in spec.objectives:
            rec["objectives"][o.output] = float(study.aggregate(mats[o.output][i:i + 1], o.aggregate, o.sense)[0])
        for c in spec.constraints:
            vals = mats[c.output][i]
            if c.low is not None and c.high is not None:
                rec["constraints"][c.output] = (float(vals.min()), float(vals.max()))
            else:
                rec["constraints"][c.output] = float(vals.max() if c.high is not None else vals.min())
        for j, p in enumerate(spec.points):
            rec["points"].append({**_point_json(p), **{n: study.finite_or_none(mats[n][i, j]) for n in names}})
        out.append(rec)
    return out


def _point_json(p: dict) -> dict:
    d = {}
    if "speed_rpm" in p:
        d["speed_rpm"] = p["speed_rpm"]
    if "load_pressure" in p:
        d["load_pressure_mpa"] = p["load_pressure"] / 1e6
    return d


def objective_vector(objectives, rec: dict) -> list[float]:
    if not rec["ok"]:
        return [FAILED_F] * len(objectives)
    return [(-1.0 if o.sense == "max" else 1.0) * rec["objectives"][o.output] for o in objectives]


def constraint_vector(constraints, rec: dict) -> list[float]:
    """g <= 0 when met, scaled by the limit; the last entry is the evaluation's success."""
    g = []
    for c in constraints:
        v = rec["constraints"].get(c.output)
        if v is None or not rec["ok"]:
            g.append(1.0)
            continue
        lo_v, hi_v = v if isinstance(v, tuple) else (v, v)
        parts = []
        if c.high is not None:   # tightened by the loop margin (the final check uses the limit itself)
            parts.append((hi_v * c.loop_margin - c.high) / max(abs(c.high), 1e-300))
        if c.low is not None:
            parts.append((c.low - lo_v * c.loop_margin) / max(abs(c.low), 1e-300))
        g.append(max(parts))
    g.append(-1.0 if rec["ok"] else 1.0)
    return g


def violations(constraints, values: dict) -> list[str]:
    out = []
    for c in constraints:
        v = values.get(c.output)
        if v is None:
            out.append(f"{c.output}: missing")
            continue
        lo_v, hi_v = v if isinstance(v, tuple) else (v, v)
        if c.high is not None and hi_v > c.high:
            out.append(f"{c.output} = {hi_v:.4g} > {c.high:.4g}")
        if c.low is not None and lo_v < c.low:
            out.append(f"{c.output} = {lo_v:.4g} < {c.low:.4g}")
    return out


def non_dominated(F: np.ndarray) -> np.ndarray:
    """Mask of the rows of F (minimised) that no other row dominates."""
    n = len(F)
    keep = np.ones(n, bool)
    for i in range(n):
        dom = np.all(F <= F[i], axis=1) & np.any(F < F[i], axis=1)
        keep[i] = not dom.any()
    return keep


def dominates(a: dict, b: dict, objectives) -> bool:
    """Design a dominates design b (their objective dicts, senses from ``objectives``)."""
    fa = np.array([(-1 if o.sense == "max" else 1) * a[o.output] for o in objectives])
    fb = np.array([(-1 if o.sense == "max" else 1) * b[o.output] for o in objectives])
    return bool(np.all(fa <= fb) and np.any(fa < fb))


# --------------------------------------------------------------------------- optimisers
def _nsga2(spec: DesignSpec, ev: Evaluator, progress: bool):
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
    from scipy.optimize import NonlinearConstraint, differential_evolution

    r = spec.run_dict
    d = len(spec.variables)
    bounds = [v.opt_bounds() for v in spec.variables]
    bar = _bar(progress, r["generations"])
    calls = {"n": 0}

    def f(Z):
        F, _ = ev.evaluate(np.asarray(Z).T)
        return F[:, 0]

    def g(Z):
        _, G = ev.evaluate(np.asarray(Z).T)
        calls["n"] += 1
        _tick(bar, ev)
        return G.T

    kw = {"rng" if "rng" in inspect.signature(differential_evolution).parameters else "seed": r["seed"]}
    try:
        res = differential_evolution(f, bounds, popsize=max(1, math.ceil(r["population"] / d)),
                                     maxiter=max(0, r["generations"] - 1), vectorized=True, updating="deferred",
                                     polish=False, constraints=NonlinearConstraint(g, -np.inf, 0.0), **kw)
    finally:
        if bar is not None:
            bar.close()
    return [tuple(float(x) for x in res.x)], int(res.nit)


def _bar(progress: bool, total: int):
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc="optimize", unit="generation", file=sys.stderr, smoothing=0.1)


def _tick(bar, ev: Evaluator):
    if bar is None:
        return
    feas = sum(1 for r in ev.cache.values() if all(x <= 0 for x in r["G"]))
    bar.set_postfix(designs=len(ev.cache), feasible=feas, computed=ev.computed, refresh=False)
    bar.update(1)


# --------------------------------------------------------------------------- the study
def run_optimize(spec: DesignSpec, out, *, scheduler: str | None = None, workers: int | None = None, client=None,
                 batch_size: int | None = None, force: bool = False, progress: bool = True) -> dict:
    """Run (or resume) an optimisation into folder ``out``; return the summary (CONTRACT.md)."""
    runner.check_study_arguments(spec, "optimize", out, scheduler=scheduler, workers=workers, batch_size=batch_size,
                                 force=force, progress=progress)
    t_start = time.perf_counter()
    out = Path(out)
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
    catalogue = study.outputs_catalogue(spec)
    recheck = spec.recheck_dict
    stages: dict = {}
    with runner.Cluster(scheduler, workers, client) as cluster, _reed_cache(out):
        cluster.check_reachable()
        runner.prepare_study(out, spec, force, SUBFOLDERS)
        base_path = study.write_base_model(out, model) if model is not None else None
        t0 = time.perf_counter()
        cal = study.calibrate(spec, model, base_path, cluster, out, progress) if study.needs_stress(spec) else None
        stages["calibration"] = time.perf_counter() - t0
        fixed = study.fixed_inputs(spec, base_path)
        module = study.EVALUATE if spec.model_kind == "pump" else spec.model
        ev = Evaluator(spec, cluster, out, fixed, module, catalogue, batch_size, progress, cal)
        t_loop = time.perf_counter()
        front_keys, generations = (_nsga2 if r["algorithm"] == "nsga2" else _de)(spec, ev, progress)
        loop_wall = time.perf_counter() - t_loop
        stages["loop"] = loop_wall
        n_workers = cluster.workers if cluster.client is not None else None
        front = [dict(ev.cache[k], key=k) for k in dict.fromkeys(front_keys)]
        # the baseline: the base model itself, fast (as in the loop)
        baseline = None
        t0 = time.perf_counter()
        if spec.model_kind == "pump":
            baseline = _baseline(spec, model, base_path, cluster, out, cal, catalogue, progress)
        stages["baseline"] = time.perf_counter() - t0
        do_fea = (spec.model_kind == "pump" and recheck.get("enabled", True) and bool(study.reed_positions(model))
                  and any(v.role == "key" for v in spec.variables))
        rechecked = _recheck(spec, model, base_path, cluster, out, cal, catalogue, front, baseline, do_fea,
                             recheck.get("enabled", True) and spec.model_kind == "pump", progress, stages)
        t0 = time.perf_counter()
        built = _build_on_workers(cluster, base_path, rechecked) if spec.model_kind == "pump" else {}
    designs = _finish(spec, model, out, catalogue, rechecked, baseline, built)
    from studies.sweeps.design import report

    files = {}
    rows, cols = report.pareto_rows(designs, spec.variables, spec.objectives, spec.constraints)
    files.update(report.write_pareto(out, rows, cols))
    feas = np.array([rec["F"] for rec in ev.records if all(x <= 0 for x in rec["G"])])
    files["front_plot"] = str(report.plot_front(out / "front.png", spec.objectives, catalogue,
                                                feas * _signs(spec) if len(feas) else None, designs, baseline))
    if designs:
        files["parallel_plot"] = str(report.plot_parallel(out / "parallel.png", spec.variables, spec.objectives,
                                                          catalogue, designs, baseline))
    stages["report"] = time.perf_counter() - t0
    wall = time.perf_counter() - t_start
    n_feasible = int(len(feas))
    result = {
        "command": "optimize", "algorithm": r["algorithm"], "model": spec.model, "out": str(out),
        "objectives": [{"output": o.output, "sense": o.sense, "aggregate": o.aggregate,
                        "unit": catalogue[o.output].unit} for o in spec.objectives],
        "constraints": [{"output": c.output, "min": c.low, "max": c.high, "unit": catalogue[c.output].unit,
                         "source": c.source} for c in spec.constraints],
        "variables": [v.describe() for v in spec.variables],
        "operating_points": [dict(_point_json(p), label=point_label(p)) for p in spec.points],
        "population": r["population"], "generations": generations, "evaluated_designs": len(ev.cache),
        "feasible_designs": n_feasible, "evaluations": len(ev.cache) * len(spec.points),
        "computed": ev.computed, "skipped": ev.skipped, "workers": n_workers,
        "stress_calibration": study.calibration_summary(cal),
        "designs": designs, "baseline": baseline,
        "dominating_baseline": sum(1 for d in designs if d.get("dominates_baseline")),
        "warnings": [{"code": w["code"], "message": f"{d['name']}: {w['message']}"}
                     for d in designs + ([dict(baseline, name="baseline")] if baseline else [])
                     for w in d.get("warnings", [])],
        "files": files, "complete": True, "wall_seconds": wall, "loop_wall_seconds": loop_wall,
        "stage_seconds": {k: round(v, 2) for k, v in stages.items()},
        "designs_per_hour": ev.computed / ev.eval_seconds * 3600.0 if ev.computed and ev.eval_seconds else None,
    }
    (out / "summary.json").write_text(json.dumps(_jsonable(result), indent=1, allow_nan=False))
    return _jsonable(result)


def _signs(spec) -> np.ndarray:
    """Objective value = F * sign (F is minimised: a maximised output enters negated)."""
    return np.array([-1.0 if o.sense == "max" else 1.0 for o in spec.objectives])


def _jsonable(x):
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


def _base_factors(cal) -> dict:
    return {f"stress_calibration_{p}": c for p, c in study.calibration_factors(cal, None, None).items()} if cal else {}


def _baseline(spec, model, base_path, cluster, out, cal, catalogue, progress) -> dict:
    """The base model as it is (no variable applied), evaluated as in the loop."""
    fixed = dict(study.fixed_inputs(spec, base_path), **_base_factors(cal))
    rows = [dict(p) for p in spec.points]
    if not rows[0]:
        rows = [{"speed_rpm": model.operating.speed_rpm}]
    df, _ = runner.evaluate_rows(cluster, Path(out) / "baseline" / "fast", study.EVALUATE, fixed, rows,
                                 group=len(rows), progress=False, desc="baseline")
    rec = design_records(spec, catalogue, df, 1)[0]
    return {"name": model.name if model.source.startswith("lumped/") else Path(model.source).stem or model.name,
            "variables": {v.name: base_value(model, v.name) for v in spec.variables}, "objectives_fast": rec["objectives"],
            "constraints_fast": rec["constraints"], "ok_fast": rec["ok"], "points_fast": rec["points"],
            "warnings": rec["warnings"]}


def base_value(model, path: str):
    """The value of a key path in a model (None if it cannot be read: an auxiliary variable, an effect off)."""
    from lumped.model.model_file import model_table

    if path == "speed_rpm":
        return model.operating.speed_rpm
    if path == "load_pressure_mpa":
        return None if model.operating.load_pressure is None else model.operating.load_pressure / 1e6
    parts = path.split(".")
    table = model_table(model)
    try:
        if parts[0] == "valves" and parts[1] not in ("inlet", "delivery"):
            parts = ["valves", "delivery", *parts[1:]]
        if parts[0] == "valves" and len(parts) > 3 and parts[2] == "geometry":
            v = model.valve(parts[1])
            if getattr(v, "reed", None) is None:
                return None
            from geometry.reed_io import reed_to_toml

            node = tomllib.loads(reed_to_toml(v.reed))["reed"]
            for p in parts[3:]:
                node = node[p]
            return node
        node = table
        for p in parts:
            node = node[p]
        return node if isinstance(node, (int, float, str, bool)) else None
    except (KeyError, TypeError, IndexError):
        return None


def _recheck(spec, model, base_path, cluster, out, cal, catalogue, front, baseline, do_fea, do_ref, progress,
             stages: dict | None = None):
    """FEA check of each front design's reeds (and the baseline's), then the reference integrator at every point
    (each row started from the fast path's cycle of its design); ``stages`` receives their wall seconds."""
    stages = {} if stages is None else stages
    t0 = time.perf_counter()
    recheck = spec.recheck_dict
    n_check = recheck.get("max_designs", len(front)) if spec.model_kind == "pump" else len(front)
    # the front sorted by its first objective; with a cap, designs spread evenly along it are re-checked
    front = sorted(front, key=lambda rec: rec["F"][0])
    pick = set(np.unique(np.linspace(0, len(front) - 1, min(n_check, len(front))).round().astype(int)).tolist()) \
        if front else set()
    items = [rec for i, rec in enumerate(front) if i in pick]
    unchecked = [rec for i, rec in enumerate(front) if i not in pick]
    extra = [dict(rec, fea=None, final=None, inputs=design_inputs(spec, rec["values"])
                  if spec.model_kind == "pump" else dict(rec["values"]), rechecked=False) for rec in unchecked]
    inputs = [design_inputs(spec, rec["values"]) if spec.model_kind == "pump" else dict(rec["values"])
              for rec in items]
    keys = [{k: (list(x) if isinstance(x, tuple) else x) for k, x in d.items()
             if k not in ("speed_rpm", "load_pressure")} for d in inputs]
    factors = [({f"stress_calibration_{p}": c for p, c in study.calibration_factors(cal, spec, rec["values"]).items()}
                if cal else {}) for rec in items]
    fea = [None] * len(items)
    fea_base = None
    positions = study.reed_positions(model) if model is not None else []
    if do_fea and items:
        fixed = {"model": base_path, "tolerance_pct": recheck["tolerance_pct"],
                 "stress_tolerance_pct": recheck["stress_tolerance_pct"]}
        if recheck.get("mesh_size"):
            fixed["mesh_size"] = recheck["mesh_size"]
        df, _ = runner.evaluate_rows(cluster, Path(out) / "recheck-fea" / "front", study.FEA_TASKS, fixed,
                                     [{"task": "fea", **k, **f} for k, f in zip(keys, factors)], progress=progress,
                                     desc="re-check: solid FEA")
        fea = df.to_dict("records")
        dfb, _ = runner.evaluate_rows(cluster, Path(out) / "recheck-fea" / "baseline", study.FEA_TASKS, fixed,
                                      [{"task": "fea", **_base_factors(cal)}], progress=False, desc="baseline FEA")
        fea_base = dfb.to_dict("records")[0]
    stages["recheck_fea"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if not do_ref:
        return [dict(rec, fea=f, inputs=i, final=None, rechecked=do_fea) for rec, f, i in zip(items, fea, inputs)] \
            + extra
    # the reference integrator: with the solid FEA's reed parameters where the check flagged the valve
    ref_fixed = dict(study.fixed_inputs(spec, base_path), method="reference")
    ref_fixed.pop("rtol"), ref_fixed.pop("atol")
    rows, fidelity = [], []
    for rec, k, f, fac in zip(items, keys, fea, factors):
        fid = {}
        for pos in positions:
            flagged = bool(f and f.get("status") == "ok" and flag_list(f.get(f"{pos}_flags")))
            fid[f"valves.{pos}.fidelity"] = "solid" if flagged else model.valve(pos).fidelity
        fidelity.append(fid)
        for p in spec.points:
            rows.append({**p, **k, **fac, **fid})
    df, _ = runner.evaluate_rows(cluster, Path(out) / "recheck-reference" / "front", study.EVALUATE, ref_fixed, rows,
                                 group=len(spec.points), progress=progress, desc="re-check: reference integrator")
    finals = design_records(spec, catalogue, df, len(items))
    out_items = []
    for rec, f, fin, fid, inp in zip(items, fea, finals, fidelity, inputs):
        out_items.append(dict(rec, fea=f, final=fin, fidelity_keys=fid, inputs=inp, rechecked=True))
    # the baseline, by the reference integrator (and its FEA check)
    if baseline is not None:
        bfid = {}
        for pos in positions:
            flagged = bool(fea_base and fea_base.get("status") == "ok" and flag_list(fea_base.get(f"{pos}_flags")))
            bfid[f"valves.{pos}.fidelity"] = "solid" if flagged else model.valve(pos).fidelity
        brows = [{**p, **bfid, **_base_factors(cal)} for p in spec.points]
        if not brows[0]:
            brows = [{"speed_rpm": model.operating.speed_rpm}]
        dfb, _ = runner.evaluate_rows(cluster, Path(out) / "baseline" / "reference", study.EVALUATE, ref_fixed,
                                      brows, group=len(brows), progress=False, desc="baseline reference")
        brec = design_records(spec, catalogue, dfb, 1)[0]
        baseline["final"] = brec
        baseline["fea"] = fea_base
        baseline["fidelity_keys"] = bfid
        # like for like: a design re-evaluated with the solid FEA's reed parameters is compared with the baseline
        # re-evaluated the same way
        if positions and do_fea and any(v != "solid" for v in bfid.values()):
            srows = [{**p, **{k: "solid" for k in bfid}, **_base_factors(cal)} for p in spec.points]
            dfs, _ = runner.evaluate_rows(cluster, Path(out) / "baseline" / "reference-solid", study.EVALUATE,
                                          ref_fixed, srows, group=len(srows), progress=False,
                                          desc="baseline reference, solid FEA reed")
            baseline["final_solid"] = design_records(spec, catalogue, dfs, 1)[0]
        elif positions and do_fea:
            baseline["final_solid"] = brec
    stages["recheck_reference"] = time.perf_counter() - t0
    return out_items + extra


def flag_list(x) -> list[str]:
    """The flags of an FEA check cell ("kappa,omega_n"; empty or missing: none)."""
    return [t for t in x.split(",") if t] if isinstance(x, str) else []


def _fea_json(f: dict | None, positions) -> dict | None:
    if not f:
        return None
    if f.get("status") != "ok":
        return {"flagged": True, "error": f.get("error") or f.get("status")}
    out = {"flagged": bool(f.get("flagged"))}
    for pos in positions:
        if f.get(f"{pos}_kappa_solid") is None:
            continue
        out[pos] = {
            "flags": flag_list(f.get(f"{pos}_flags")),
            "kappa_analytic_pa_m": f[f"{pos}_kappa_analytic"], "kappa_solid_pa_m": f[f"{pos}_kappa_solid"],
            "kappa_dev_pct": f[f"{pos}_kappa_dev_pct"],
            "omega_analytic_rad_s": f[f"{pos}_omega_analytic"], "omega_solid_rad_s": f[f"{pos}_omega_solid"],
            "omega_dev_pct": f[f"{pos}_omega_dev_pct"],
            "gamma_dev_pct": [f[f"{pos}_gamma{i}_dev_pct"] for i in (1, 2, 3)],
            "stress_estimate_mpa": None if f.get(f"{pos}_stress_estimate_pa") is None
            else f[f"{pos}_stress_estimate_pa"] / 1e6,
            "stress_solid_mpa": f[f"{pos}_stress_solid_pa"] / 1e6,
            "stress_solid_at_clamp_mpa": f[f"{pos}_stress_solid_max_pa"] / 1e6,
            "stress_dev_pct": f.get(f"{pos}_stress_dev_pct"),
            "solid_dofs": int(f[f"{pos}_solid_dofs"]) if f.get(f"{pos}_solid_dofs") is not None else None,
        }
    return out


def _final_constraints(spec, fin: dict, fea: dict | None, positions) -> dict:
    """The constraints' worst values after the re-check: the solid FEA's stress replaces the estimate."""
    cons = dict(fin["constraints"])
    if fea and "reed_stress_mpa" in cons:
        vals = [fea[f"{p}_stress_solid_pa"] / 1e6 for p in positions if fea.get(f"{p}_stress_solid_pa") is not None]
        if vals:
            cons["reed_stress_mpa"] = max(vals)
    for p in positions:
        k = f"{p}_reed_stress_mpa"
        if fea and k in cons and fea.get(f"{p}_stress_solid_pa") is not None:
            cons[k] = fea[f"{p}_stress_solid_pa"] / 1e6
    return cons


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


def _file_keys(rec: dict) -> dict:
    """The model-file keys of a re-checked design: its inputs and the fidelity it was re-checked with."""
    return {**{k: v for k, v in rec["inputs"].items() if k not in ("speed_rpm", "load_pressure")},
            **(rec.get("fidelity_keys") or {})}


def _build_on_workers(cluster, base_path: str, items) -> dict:
    """{repr(keys): PumpModel} of each design's model file, built on the workers: a design re-checked with the
    solid FEA's reed parameters needs that FEA again to be built, and the worker that re-ran it at the operating
    points still holds it (studies.sweeps.design.evaluate's model cache); built here it would cost a solid FEA
    per design in this one process."""
    from studies.sweeps.design.evaluate import build_design_model

    keys = list({repr(sorted(_file_keys(rec).items())): _file_keys(rec) for rec in items}.items())
    if not keys or cluster.client is None:
        return {}
    client = cluster.get()
    futures = client.map(build_design_model, [base_path] * len(keys), [k for _, k in keys], pure=False)
    out = {}
    for (name, _), f in zip(keys, futures):
        try:
            out[name] = f.result()
        except Exception:  # noqa: BLE001 - built again where the file is written, which reports the error
            pass
    return out


def _finish(spec, model, out, catalogue, items, baseline, built: dict | None = None) -> list[dict]:
    """Design entries of the JSON: final objectives and constraints, the front re-sorted, model files written."""
    from lumped.model.model_file import to_toml, with_values

    positions = study.reed_positions(model) if model is not None else []
    r = spec.run_dict
    entries = []
    for rec in items:
        fin = rec.get("final") or rec
        fea = rec.get("fea")
        objs = fin["objectives"] if fin.get("ok", True) else {o.output: None for o in spec.objectives}
        cons = _final_constraints(spec, fin, fea, positions) if fin.get("ok", True) else {}
        viol = violations(spec.constraints, cons) if fin.get("ok", True) else [fin.get("error") or "evaluation failed"]
        e = {"variables": rec["values"],
             "derived": {k: rec["inputs"][k] for k, _ in spec.derived} if spec.model_kind == "pump" else {},
             "objectives": objs, "objectives_fast": rec["objectives"], "constraints": cons,
             "constraints_fast": rec["constraints"], "constraints_met": not viol, "violations": viol,
             "fea_check": _fea_json(fea, positions), "fea_flagged": bool(fea and fea.get("flagged")),
             "fidelity": {k.split(".")[1]: v for k, v in (rec.get("fidelity_keys") or {}).items()} or None,
             "points": fin["points"], "ok": bool(fin.get("ok", True)), "rechecked": bool(rec.get("rechecked")),
             "warnings": fin.get("warnings", rec.get("warnings", [])),
             "generation_folder": rec.get("generation_folder")}
        if rec.get("final") is not None:
            e["fast_vs_reference_pct"] = {o.output: _pct(rec["objectives"][o.output], fin["objectives"][o.output])
                                          for o in spec.objectives} if fin["ok"] else None
        e["_keys"] = _file_keys(rec) if spec.model_kind == "pump" else None
        entries.append(e)
    # the front after the re-check, sorted by the first objective
    okm = [e["ok"] and e["constraints_met"] and all(v is not None for v in e["objectives"].values()) for e in entries]
    F = np.array([[((-1 if o.sense == "max" else 1) * e["objectives"][o.output]) if ok else FAILED_F
                   for o in spec.objectives] for e, ok in zip(entries, okm)]) if entries else np.zeros((0, 1))
    nd = non_dominated(F) if len(F) else np.zeros(0, bool)
    order = np.lexsort(F.T[::-1]) if len(F) else []
    entries = [entries[i] for i in order]
    nd = nd[order] if len(F) else nd
    okm = [okm[i] for i in order]
    base_final = base_solid = None
    if baseline is not None:
        base_final = (baseline.get("final") or {}).get("objectives") or baseline.get("objectives_fast")
        baseline["objectives"] = base_final
        fs = baseline.pop("final_solid", None)
        if fs is not None and fs.get("ok"):
            base_solid = fs["objectives"]
            baseline["objectives_solid_fea"] = base_solid
        if baseline.get("final"):
            fb = baseline["final"]
            baseline["constraints"] = _final_constraints(spec, fb, baseline.get("fea"), positions)
            baseline["constraints_met"] = not violations(spec.constraints, baseline["constraints"])
            baseline["points"] = fb["points"]
            baseline["warnings"] = fb.get("warnings", baseline.get("warnings", []))
        baseline["fea_check"] = _fea_json(baseline.pop("fea", None), positions)
        baseline["fidelity"] = {k.split(".")[1]: v for k, v in (baseline.pop("fidelity_keys", None) or {}).items()} \
            or None
        baseline.pop("final", None)
        baseline["model_file"] = str(Path(out) / study.BASE_MODEL_FILE)
    base = study.base_model(spec) if spec.model_kind == "pump" else None
    for i, (e, front_ok, ok) in enumerate(zip(entries, nd, okm), start=1):
        e["name"] = f"design_{i:03d}"
        e["on_front"] = bool(front_ok and ok)
        if base_final is not None and ok:
            solid = bool(e["fidelity"]) and any(v == "solid" for v in e["fidelity"].values())
            ref = base_solid if (solid and base_solid is not None) else base_final
            e["dominates_baseline"] = dominates(e["objectives"], ref, spec.objectives)
            e["baseline_compared"] = "solid FEA reed parameters" if ref is base_solid else "as the baseline"
        else:
            e["dominates_baseline"] = None if base_final is None else False
        keys = e.pop("_keys")
        if base is not None:
            path = Path(out) / f"{e['name']}.toml"
            m = (built or {}).get(repr(sorted(keys.items()))) or with_values(base, keys)
            from dataclasses import replace

            m = replace(m, name=e["name"])
            header = (f"# {e['name']} of `valvelab optimize` ({spec.model}); objectives "
                      + ", ".join(f"{o.label} = {e['objectives'][o.output]!r}" for o in spec.objectives) + "\n")
            text = header + to_toml(m)
            if not path.is_file() or path.read_text() != text:
                tmp = path.with_suffix(".tmp")
                tmp.write_text(text)
                tmp.replace(path)
            e["model_file"] = str(path)
            e["commands"] = [PUMP_COMMAND.format(file=path, speed=p.get("speed_rpm", m.operating.speed_rpm),
                                                 load=p.get("load_pressure_mpa",
                                                            (m.operating.load_pressure or 0) / 1e6),
                                                 rev=r["revolutions"], maxrev=r["max_revolutions"])
                             for p in e["points"]]
        else:
            e["model_file"] = None
    return entries


def _pct(a, b):
    if a is None or b is None or b == 0:
        return None
    return (a - b) / abs(b) * 100.0
