"""Global sensitivity of pump outputs to model parameters: Sobol indices and Morris screening (SALib).

Sobol (``method = "sobol"``, the default): the Saltelli scheme of SALib (``SALib.sample.sobol``,
scrambled Sobol sequence, first-order and total indices, no second order: N (D + 2) samples for
D variables) in the unit hypercube, mapped onto each variable (ranges, log ranges, levels or the
inverse CDF of its distribution); the estimators of ``SALib.analyze.sobol`` (Saltelli 2010 for
S1, Jansen for ST) with bootstrap confidence intervals (``num_resamples``, ``conf_level``).

Morris (``method = "morris"``): ``samples`` trajectories of D + 1 points on a ``num_levels`` grid
(``SALib.sample.morris``), analysed by ``SALib.analyze.morris`` in the unit hypercube: mu* and
sigma are in the output's unit per full range of the variable.

Each design runs at every operating point (one sweep row each, :mod:`studies.sweeps.design.runner`);
indices are computed per operating point and, with several, for the mean over them. A failed
evaluation (an error, or no cyclic steady state within ``max_revolutions``) or a missing output
(a valve that never opens) removes its whole Saltelli block (the base sample and its D + 1
companions) or Morris trajectory from that output's analysis: the estimators stay unbiased for
the remaining blocks, which are independent draws; the number dropped is reported.
"""

from __future__ import annotations

import json
import math
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from geometry.errors import InputError
from studies.sweeps.design import runner, study
from studies.sweeps.design.calibration import calibrate, calibration_summary
from studies.sweeps.design.spec import DesignSpec, check_size
from studies.sweeps.design.study import Study
from studies.sweeps.store import status_counts

SUBFOLDERS = ("runs", "calibration")


#: the bootstrap seed used for ``seed = 0``: SALib's ``sobol.analyze`` treats 0 as "no seed" (numpy's global
#: generator, a different interval at each run), and no spec can give this one (run.seed is at most 2**32 - 1)
SOBOL_SEED_FOR_ZERO = 2**32


def sample_unit(spec: DesignSpec) -> np.ndarray:
    """The study's samples in the unit hypercube.

    Parameters
    ----------
    spec : DesignSpec
        A sensitivity spec: ``run.method`` (``sobol``: Saltelli's scheme on a scrambled Sobol
        sequence, no second order; ``morris``: trajectories on a ``num_levels`` grid),
        ``samples``, ``seed``.

    Returns
    -------
    numpy.ndarray
        (:func:`n_samples`, variables), in [0, 1].

    References
    ----------
    Saltelli et al. (2010), Comput. Phys. Commun. 181, 259-270; Morris (1991), Technometrics 33,
    161-174; Herman and Usher (2017), SALib, J. Open Source Softw. 2(9), 97.
    """
    r = spec.run_dict
    problem = _problem(spec)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if r["method"] == "sobol":
            from SALib.sample import sobol as sobol_sample

            return sobol_sample.sample(problem, r["samples"], calc_second_order=False, scramble=True, seed=r["seed"])
        from SALib.sample import morris as morris_sample

        return morris_sample.sample(problem, r["samples"], num_levels=r["num_levels"], seed=r["seed"])


def n_samples(spec: DesignSpec) -> int:
    """The number of designs a sensitivity study evaluates at each operating point.

    Parameters
    ----------
    spec : DesignSpec

    Returns
    -------
    int
        N (D + 2) for Sobol (N base samples, D variables), N (D + 1) for Morris (N trajectories).
    """
    r = spec.run_dict
    d = len(spec.variables)
    return r["samples"] * (d + 2) if r["method"] == "sobol" else r["samples"] * (d + 1)


def designs_of(spec: DesignSpec, u: np.ndarray) -> list[dict]:
    """The designs of samples in the unit hypercube.

    Parameters
    ----------
    spec : DesignSpec
    u : numpy.ndarray
        (samples, variables) in [0, 1] (:func:`sample_unit`).

    Returns
    -------
    list of dict
        {variable: value in its unit} per sample (:meth:`~studies.sweeps.design.variables.Variable.from_unit`).
    """
    cols = [v.from_unit(u[:, j]) for j, v in enumerate(spec.variables)]
    names = [v.name for v in spec.variables]
    return [dict(zip(names, row)) for row in zip(*cols)]


def _problem(spec: DesignSpec) -> dict:
    """The SALib problem: every variable on [0, 1] (the mapping onto its range is :func:`designs_of`'s)."""
    d = len(spec.variables)
    return {"num_vars": d, "names": [v.name for v in spec.variables], "bounds": [[0.0, 1.0]] * d}


def analyse_sobol(problem: dict, y: np.ndarray, num_resamples: int, conf_level: float, seed: int) -> dict:
    """First-order and total Sobol indices of one output, with bootstrap confidence intervals.

    Parameters
    ----------
    problem : dict
        The SALib problem (``num_vars`` D).
    y : numpy.ndarray
        N (D + 2) values in Saltelli's order, NaN where an evaluation failed: a block with a NaN
        is dropped (the others stay independent draws, the estimators unbiased).
    num_resamples : int
        Bootstrap resamples.
    conf_level : float
        Confidence level of the intervals (0.95: 95 %).
    seed : int
        The bootstrap's seed (0 too gives the same intervals at every run, :data:`SOBOL_SEED_FOR_ZERO`).

    Returns
    -------
    dict
        ``S1``, ``S1_conf``, ``ST``, ``ST_conf`` per variable (dimensionless, the conf entries half
        widths of the intervals), ``mean`` and ``std`` of y (its unit), ``n_blocks``, ``n_used``,
        ``dropped``, ``constant`` and a ``note`` when no index could be estimated.

    References
    ----------
    Saltelli et al. (2010), Comput. Phys. Commun. 181, 259-270 (S1); Jansen (1999), Comput. Phys.
    Commun. 117, 35-43 (ST); SALib's ``sobol.analyze``.
    """
    from SALib.analyze import sobol as sobol_analyze

    d = problem["num_vars"]
    blocks = y.reshape(-1, d + 2)
    ok = np.isfinite(blocks).all(axis=1)
    res = {"n_blocks": int(len(blocks)), "n_used": int(ok.sum()), "dropped": int((~ok).sum()), "constant": False}
    if ok.sum() < 2:
        res["note"] = "fewer than two complete Saltelli blocks"
        return res
    yv = blocks[ok].ravel()
    if np.ptp(yv) <= 1e-12 * max(1.0, np.abs(yv).max()):
        res.update(constant=True, note="the output does not vary", S1=[0.0] * d, S1_conf=[0.0] * d, ST=[0.0] * d,
                   ST_conf=[0.0] * d)
        return res
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        si = sobol_analyze.analyze(problem, yv, calc_second_order=False, num_resamples=num_resamples,
                                   conf_level=conf_level, print_to_console=False, seed=seed or SOBOL_SEED_FOR_ZERO)
    for k in ("S1", "S1_conf", "ST", "ST_conf"):
        res[k] = [float(x) for x in si[k]]
    res["mean"], res["std"] = float(yv.mean()), float(yv.std())
    return res


def analyse_morris(problem: dict, u: np.ndarray, y: np.ndarray, num_levels: int, num_resamples: int,
                   conf_level: float, seed: int) -> dict:
    """Morris elementary effects of one output (mu*, sigma), with bootstrap confidence intervals of mu*.

    Parameters
    ----------
    problem : dict
        The SALib problem (``num_vars`` D).
    u : numpy.ndarray
        The trajectories' points in the unit hypercube, (N (D + 1), D).
    y : numpy.ndarray
        N (D + 1) values, NaN where an evaluation failed: a trajectory with a NaN is dropped.
    num_levels : int
        The grid's levels (even).
    num_resamples : int
        Bootstrap resamples.
    conf_level : float
        Confidence level of mu*'s interval.
    seed : int
        The bootstrap's seed.

    Returns
    -------
    dict
        ``mu``, ``mu_star``, ``mu_star_conf``, ``sigma`` per variable, in y's unit per full range
        of the variable; ``mean``, ``std``, ``n_blocks``, ``n_used``, ``dropped``, ``constant``, ``note``.

    References
    ----------
    Morris (1991), Technometrics 33, 161-174; Campolongo et al. (2007), Environ. Model. Softw. 22,
    1509-1518 (mu*); SALib's ``morris.analyze``.
    """
    from SALib.analyze import morris as morris_analyze

    d = problem["num_vars"]
    traj = y.reshape(-1, d + 1)
    ok = np.isfinite(traj).all(axis=1)
    res = {"n_blocks": int(len(traj)), "n_used": int(ok.sum()), "dropped": int((~ok).sum()), "constant": False}
    if ok.sum() < 2:
        res["note"] = "fewer than two complete trajectories"
        return res
    uv = u.reshape(-1, d + 1, d)[ok].reshape(-1, d)
    yv = traj[ok].ravel()
    if np.ptp(yv) <= 1e-12 * max(1.0, np.abs(yv).max()):
        res.update(constant=True, note="the output does not vary", mu=[0.0] * d, mu_star=[0.0] * d,
                   mu_star_conf=[0.0] * d, sigma=[0.0] * d)
        return res
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        si = morris_analyze.analyze(problem, uv, yv, num_resamples=num_resamples, conf_level=conf_level,
                                    num_levels=num_levels, seed=seed)
    for k in ("mu", "mu_star", "mu_star_conf", "sigma"):
        res[k] = [float(x) for x in np.asarray(si[k], dtype=float)]
    res["mean"], res["std"] = float(yv.mean()), float(yv.std())
    return res


def _check(spec: DesignSpec, out: Path, force: bool):
    """Every check before any computation (the variables on the base model, the size, the folder, the stress);
    the base model."""
    r = spec.run_dict
    model = study.base_model(spec)
    study.check_variables(spec, model)
    check_size(n_samples(spec) * len(spec.points), "run.samples", out,
               f"{r['samples']} samples x {len(spec.variables) + (2 if r['method'] == 'sobol' else 1)}"
               f" x {len(spec.points)} operating points")
    from studies.outputs import check_output_dir

    check_output_dir(out, "--out", force, kind="sensitivity")
    if study.needs_stress(spec) and not study.reed_positions(model):
        raise InputError("run.outputs", "the reed stress needs a reed valve with a geometry "
                                        "(valves.<pos>.geometry); the base model has none")
    return model


def _evaluate(ctx: Study, designs: list[dict], batch_size: int | None):
    """The stress calibration, then every design at every operating point: (the study with its calibration, the
    evaluation table, the run's summary, its wall seconds)."""
    if study.needs_stress(ctx.spec):
        ctx = replace(ctx, calibration=calibrate(ctx))
    rows = study.rows_for(ctx.spec, designs, ctx.calibration)
    module = study.EVALUATE if ctx.spec.model_kind == "pump" else ctx.spec.model
    t_eval = time.perf_counter()
    df, summ = runner.evaluate_rows(ctx.cluster, ctx.out / "runs", module, study.fixed_inputs(ctx.spec, ctx.base_path),
                                    rows, group=len(ctx.spec.points), batch_size=batch_size, progress=ctx.progress,
                                    desc="sensitivity")
    return ctx, df, summ, time.perf_counter() - t_eval


def _index_rows(spec: DesignSpec, res: dict, output, label: str) -> list[dict]:
    """One row per variable of an analysis (the indices of ``res``, None where it has none)."""
    r = spec.run_dict
    keys = ("S1", "S1_conf", "ST", "ST_conf") if r["method"] == "sobol" else ("mu_star", "mu_star_conf", "sigma", "mu")
    rows = []
    for i, v in enumerate(spec.variables):
        row = {"output": output.name, "output_unit": output.unit, "operating_point": label, "variable": v.name,
               "variable_unit": v.unit, "method": r["method"]}
        for k in keys:
            row[k] = study.finite_or_none(res[k][i]) if k in res else None
        row["samples_used"] = res["n_used"]
        row["samples_dropped"] = res["dropped"]
        rows.append(row)
    return rows


def analyse(spec: DesignSpec, df, u: np.ndarray, outputs: list) -> tuple[list, list]:
    """The indices of every output at every operating point and, with several, for their mean.

    Parameters
    ----------
    spec : DesignSpec
    df : pandas.DataFrame
        The evaluation table (design-major rows).
    u : numpy.ndarray
        The samples in the unit hypercube (Morris needs them).
    outputs : list of Output
        The outputs analysed (:mod:`studies.sweeps.design.outputs`).

    Returns
    -------
    indices : list of dict
        One row per output, point and variable (CONTRACT.md, "Sensitivity").
    analyses : list of dict
        One per output and point: :func:`analyse_sobol` or :func:`analyse_morris`'s result.
    """
    r = spec.run_dict
    problem = _problem(spec)
    npts = len(spec.points)
    labels = spec.point_labels
    targets = [(j, labels[j]) for j in range(npts)] + ([(None, "mean")] if npts > 1 else [])
    indices, analyses = [], []
    for o in outputs:
        mat = runner.output_matrix(df, o, n_samples(spec), npts)
        for j, lab in targets:
            y = mat[:, j] if j is not None else mat.mean(axis=1)
            if r["method"] == "sobol":
                res = analyse_sobol(problem, y, r["num_resamples"], r["conf_level"], r["seed"])
            else:
                res = analyse_morris(problem, u, y, r["num_levels"], r["num_resamples"], r["conf_level"], r["seed"])
            res.update(output=o.name, unit=o.unit, operating_point=lab)
            analyses.append(res)
            indices += _index_rows(spec, res, o, lab)
    return indices, analyses


def run_sensitivity(spec: DesignSpec, out, *, scheduler: str | None = None, workers: int | None = None,
                    client=None, batch_size: int | None = None, force: bool = False, progress: bool = True) -> dict:
    """Run (or resume) a sensitivity study into a study folder (see the module docstring).

    Parameters
    ----------
    spec : DesignSpec
        A ``sensitivity`` spec (:func:`studies.sweeps.design.spec.load_spec`).
    out : str or os.PathLike
        The study folder; a rerun computes only the evaluations not yet recorded.
    scheduler, workers, client, batch_size, force, progress
        How it runs: :class:`~studies.sweeps.design.runner.StudyRun`.

    Returns
    -------
    dict
        The summary (CONTRACT.md, "Sensitivity"), also written to ``summary.json``: the indices with
        their confidence intervals, the analyses, the files, timings and rates.
    """
    run = runner.StudyRun(scheduler, workers, client, batch_size, force, progress)
    runner.check_study_arguments(spec, "sensitivity", out, run)
    t_start = time.perf_counter()
    out = Path(out)
    model = _check(spec, out, force)
    u = sample_unit(spec)
    designs = designs_of(spec, u)
    study.rows_for(spec, designs)          # every design's derived keys, before anything is written
    with runner.open_study(spec, out, model, run, SUBFOLDERS) as ctx:
        ctx, df, summ, eval_wall = _evaluate(ctx, designs, batch_size)
        n_workers = ctx.cluster.workers if ctx.cluster.client is not None else None
    outputs = [ctx.catalogue[o] for o in spec.outputs]
    indices, analyses = analyse(spec, df, u, outputs)
    from studies.sweeps.design import report

    files = report.write_sensitivity(out, spec, indices, analyses, outputs)
    result = _summary(ctx, df, summ, indices, analyses, files, n_workers)
    computed, npts = summ.get("computed", 0), len(spec.points)
    result.update(wall_seconds=time.perf_counter() - t_start, evaluation_wall_seconds=eval_wall,
                  designs_per_hour=computed / eval_wall * 3600.0 if computed else None,
                  samples_per_hour=computed / npts / eval_wall * 3600.0 if computed else None)
    (out / "summary.json").write_text(json.dumps(result, indent=1, allow_nan=False))
    return result


def _summary(ctx: Study, df, summ: dict, indices: list, analyses: list, files: dict, n_workers: int | None) -> dict:
    """The summary of a sensitivity study (without its timings)."""
    spec = ctx.spec
    r = spec.run_dict
    outputs = [ctx.catalogue[o] for o in spec.outputs]
    n = n_samples(spec)
    return {
        "command": "sensitivity", "method": r["method"], "model": spec.model, "out": str(ctx.out),
        "variables": [v.describe() for v in spec.variables],
        "outputs": [{"name": o.name, "unit": o.unit, "label": o.label} for o in outputs],
        "operating_points": [dict(p, label=lab) for p, lab in zip(spec.points, spec.point_labels)],
        "samples": r["samples"], "designs": n, "evaluations": n * len(spec.points),
        "computed": summ.get("computed", 0), "skipped": summ.get("skipped", 0),
        "status_counts": status_counts(df), "failed": int((df["status"] != "ok").sum()) if len(df) else 0,
        "workers": n_workers, "indices": indices,
        "analyses": [{k: a.get(k) for k in ("output", "operating_point", "n_used", "dropped", "constant", "note")}
                     for a in analyses],
        "stress_calibration": calibration_summary(ctx.calibration), "files": files, "complete": True,
        "warnings": study.evaluation_warnings(df),
    }


def top_variables(result: dict, output: str, key: str = "ST", point: str | None = None) -> list[tuple[str, float]]:
    """The variables of an output sorted by an index, largest first.

    Parameters
    ----------
    result : dict
        :func:`run_sensitivity`'s summary.
    output : str
        The output.
    key : str
        The index (``ST``, ``S1``, ``mu_star``, ...).
    point : str, optional
        The operating point's label (default: ``mean``, or the only point).

    Returns
    -------
    list of (str, float)
        (variable, index) pairs.
    """
    rows = [r for r in result["indices"] if r["output"] == output]
    pts = [r["operating_point"] for r in rows]
    point = point or ("mean" if "mean" in pts else pts[0])
    rows = [r for r in rows if r["operating_point"] == point and r.get(key) is not None]
    return sorted(((r["variable"], r[key]) for r in rows), key=lambda t: -t[1])


def describe_index(v) -> str:
    """An index as a table cell: three decimals, ``-`` when missing.

    Parameters
    ----------
    v : float or None

    Returns
    -------
    str
    """
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.3f}"
