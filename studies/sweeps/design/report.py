"""Tables and plots of the design studies (units on every axis)."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import numpy as np

from studies.plots import legend_outside


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _write_csv(path: Path, rows: list[dict], columns: list[str]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in columns})
    os.replace(tmp, path)


def _save(fig, path: Path) -> None:
    import matplotlib.pyplot as plt

    tmp = path.with_name(path.name + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


# --------------------------------------------------------------------------- sensitivity
def write_sensitivity(out: Path, spec, indices: list[dict], analyses: list[dict], outputs) -> dict:
    """Write a sensitivity study's tables and plots.

    Parameters
    ----------
    out : pathlib.Path
        The study folder.
    spec : DesignSpec
    indices : list of dict
        One row per output, operating point and variable (:func:`studies.sweeps.design.sensitivity.analyse`).
    analyses : list of dict
        One per output and point.
    outputs : list of Output
        The outputs analysed.

    Returns
    -------
    dict
        ``csv`` (indices.csv), ``markdown`` (indices.md, the indices sorted per output and point)
        and ``plots`` {output: bar plot, one panel per operating point}.
    """
    method = spec.run_dict["method"]
    keys = ["S1", "S1_conf", "ST", "ST_conf"] if method == "sobol" else ["mu_star", "mu_star_conf", "sigma", "mu"]
    cols = ["output", "output_unit", "operating_point", "variable", "variable_unit", "method", *keys,
            "samples_used", "samples_dropped"]
    _write_csv(out / "indices.csv", indices, cols)
    (out / "indices.md").write_text(_sensitivity_markdown(spec, indices, analyses))
    plots = {}
    conf = int(round(spec.run_dict["conf_level"] * 100))
    for o in outputs:
        path = out / f"sensitivity_{_safe(o.name)}.png"
        plot_indices(indices, analyses, o, method, path, conf)
        plots[o.name] = str(path)
    return {"csv": str(out / "indices.csv"), "markdown": str(out / "indices.md"), "plots": plots}


def _sensitivity_markdown(spec, indices: list[dict], analyses: list[dict]) -> str:
    """indices.md: the method, then per output and point the indices sorted by ST (or mu*)."""
    method = spec.run_dict["method"]
    lines = [f"# Sensitivity ({method}) of {spec.model}", ""]
    if spec.description:
        lines += [spec.description, ""]
    r = spec.run_dict
    conf = int(round(r["conf_level"] * 100))
    if method == "sobol":
        lines += [f"First-order (S1) and total (ST) Sobol indices, {conf} % bootstrap intervals (+/-), "
                  f"{r['samples']} base samples x {len(spec.variables) + 2} (Saltelli), seed {r['seed']}.", ""]
    else:
        lines += [f"Morris screening: mu* and sigma of the elementary effects in the output's unit per full range "
                  f"of each variable, {r['samples']} trajectories, {r['num_levels']} levels, {conf} % intervals.", ""]
    sort_key = "ST" if method == "sobol" else "mu_star"
    for a in analyses:
        rows = [x for x in indices if x["output"] == a["output"] and x["operating_point"] == a["operating_point"]]
        rows.sort(key=lambda x: -(x.get(sort_key) or -1e300))
        lines += [f"## {a['output']} [{a['unit']}] at {a['operating_point']}", ""]
        note = f"{a['n_used']} of {a['n_blocks']} {'blocks' if method == 'sobol' else 'trajectories'} used"
        if a["dropped"]:
            note += f" ({a['dropped']} dropped: a failed evaluation or a missing output)"
        if a.get("note"):
            note += f"; {a['note']}"
        lines += [note + ".", ""]
        if method == "sobol":
            lines += ["| variable | S1 | +/- | ST | +/- |", "| --- | ---: | ---: | ---: | ---: |"]
            lines += [f"| {x['variable']} [{x['variable_unit']}] | {_fmt(x['S1'])} | {_fmt(x['S1_conf'])} | "
                      f"{_fmt(x['ST'])} | {_fmt(x['ST_conf'])} |" for x in rows]
        else:
            u = a["unit"]
            lines += [f"| variable | mu* [{u}] | +/- | sigma [{u}] | mu [{u}] |", "| --- | ---: | ---: | ---: | ---: |"]
            lines += [f"| {x['variable']} [{x['variable_unit']}] | {_fmt(x['mu_star'])} | {_fmt(x['mu_star_conf'])} | "
                      f"{_fmt(x['sigma'])} | {_fmt(x['mu'])} |" for x in rows]
        lines.append("")
    return "\n".join(lines)


def plot_indices(indices, analyses, output, method, path: Path, conf: int) -> Path:
    """Draw an output's indices as bars with their intervals, one panel per operating point.

    Parameters
    ----------
    indices, analyses : list of dict
        As :func:`write_sensitivity`.
    output : Output
    method : str
        ``sobol`` (S1 and ST [-]) or ``morris`` (mu* and sigma, in the output's unit per full range).
    path : pathlib.Path
        The PNG file.
    conf : int
        The intervals' confidence level [%].

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    plt = _plt()
    pts = [a["operating_point"] for a in analyses if a["output"] == output.name]
    variables = list(dict.fromkeys(x["variable"] for x in indices if x["output"] == output.name))
    units = {x["variable"]: x["variable_unit"] for x in indices}
    fig, axes = plt.subplots(len(pts), 1, squeeze=False, figsize=(max(6.0, 0.8 * len(variables) + 2.5),
                                                                   2.9 * len(pts) + 1.4))
    x = np.arange(len(variables))
    for ax, pt in zip(axes[:, 0], pts):
        rows = {r["variable"]: r for r in indices if r["output"] == output.name and r["operating_point"] == pt}
        if method == "sobol":
            pairs = (("S1", "S1_conf", "first order S1"), ("ST", "ST_conf", "total ST"))
            ax.set_ylabel("Sobol index [-]\n(share of variance)")
        else:
            pairs = (("mu_star", "mu_star_conf", "mu*"), ("sigma", None, "sigma"))
            ax.set_ylabel(f"elementary effect\n[{output.unit} per range]")
        for k, (key, ck, lab) in enumerate(pairs):
            vals = np.array([rows[v].get(key) if rows[v].get(key) is not None else np.nan for v in variables])
            err = None
            if ck is not None:
                err = np.array([rows[v].get(ck) if rows[v].get(ck) is not None else 0.0 for v in variables])
            ax.bar(x + (k - 0.5) * 0.38, vals, 0.36, yerr=err, capsize=3, label=lab + (f" ({conf} % interval)"
                                                                                          if ck else ""))
        ax.set_title(f"{output.label} [{output.unit}]" + ("" if pt == "default" else f" at {pt}"), fontsize=10)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.grid(axis="y", alpha=0.3)
        ax.set_xticks(x, [f"{v} [{units[v]}]" for v in variables], rotation=35, ha="right", fontsize=8)
        legend_outside(ax, fontsize=8)
    axes[-1, 0].set_xlabel("variable [its unit]")
    fig.tight_layout()
    _save(fig, path)
    return path


# --------------------------------------------------------------------------- optimisation
def plot_front(path: Path, objectives, catalogue, all_f: np.ndarray | None, front: list[dict], baseline: dict | None,
               records: list[dict] | None = None):
    """Draw the objective space: every feasible design evaluated, the front (fast and re-checked), the baseline.

    Parameters
    ----------
    path : pathlib.Path
        The PNG file.
    objectives : sequence of Objective
    catalogue : dict
        The outputs (units for the axes).
    all_f : numpy.ndarray or None
        The objective values of every feasible design evaluated, (designs, objectives).
    front : list of dict
        The design entries (:func:`studies.sweeps.design.entries.finish`).
    baseline : dict or None
    records : list of dict, optional
        Every design evaluated, with its ``generation_folder`` (one objective: drawn per generation).

    Returns
    -------
    pathlib.Path
        ``path``; with one objective there is no front to draw: :func:`plot_generations`.
    """
    if len(objectives) == 1:
        return plot_generations(path, objectives[0], catalogue, records or [], front, baseline)
    plt = _plt()
    m = len(objectives)
    pairs = [(i, j) for i in range(m) for j in range(i + 1, m)]
    fig, axes = plt.subplots(1, len(pairs), squeeze=False, figsize=(5.4 * len(pairs) + 2.6, 4.6))
    for ax, (i, j) in zip(axes[0], pairs):
        oi, oj = objectives[i], objectives[j]
        if all_f is not None and len(all_f):
            ax.plot(all_f[:, i], all_f[:, j], ".", color="0.75", ms=3, label="feasible designs (fast, in the loop)")
        fx = [d["objectives_fast"][oi.output] for d in front]
        fy = [d["objectives_fast"][oj.output] for d in front]
        ax.plot(fx, fy, "o", mfc="none", color="C0", label="front (fast, in the loop)")
        checked = [d for d in front if d.get("rechecked", True)]   # recheck.max_designs: only those re-checked
        rx = [d["objectives"][oi.output] for d in checked]
        ry = [d["objectives"][oj.output] for d in checked]
        flagged = [d.get("fea_flagged") for d in checked]
        ax.plot([a for a, f in zip(rx, flagged) if not f], [b for b, f in zip(ry, flagged) if not f], "x",
                color="C1", label="front re-checked (reference integrator)")
        if any(flagged):
            ax.plot([a for a, f in zip(rx, flagged) if f], [b for b, f in zip(ry, flagged) if f], "s", mfc="none",
                    color="C3", label="FEA-flagged, re-evaluated with solid FEA parameters")
        if baseline is not None:
            ax.plot(baseline["objectives"][oi.output], baseline["objectives"][oj.output], "*", ms=14, color="C2",
                    label=f"baseline ({baseline['name']})")
        ax.set_xlabel(f"{oi.aggregate} {catalogue[oi.output].axis_label} ({oi.sense})")
        ax.set_ylabel(f"{oj.aggregate} {catalogue[oj.output].axis_label} ({oj.sense})")
        ax.grid(alpha=0.3)
        legend_outside(ax, fontsize=7)
    fig.tight_layout()
    _save(fig, path)
    return path


def plot_generations(path: Path, objective, catalogue, records: list[dict], front: list[dict],
                     baseline: dict | None) -> Path:
    """Draw a single-objective optimisation: the objective of every design against its generation.

    Each generation's feasible designs (fast integrator, in the loop), the best feasible design so far,
    the best design re-checked by the reference integrator and the baseline.

    Parameters
    ----------
    path : pathlib.Path
        The PNG file.
    objective : Objective
    catalogue : dict
        The outputs (the unit of the axis).
    records : list of dict
        Every design evaluated (:attr:`studies.sweeps.design.evaluator.Evaluator.records`): ``generation_folder``
        (``gen-NNNN``), ``G`` (feasible when every entry <= 0) and ``objectives``.
    front : list of dict
        The best design's entry (:func:`studies.sweeps.design.entries.finish`).
    baseline : dict or None

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    plt = _plt()
    name = objective.output
    feasible = [(int(r["generation_folder"].split("-")[-1]), r["objectives"][name]) for r in records
                if "generation_folder" in r and all(x <= 0 for x in r["G"]) and r["objectives"].get(name) is not None]
    fig, ax = plt.subplots(figsize=(8.4, 4.4))
    if feasible:
        g, v = np.array(feasible, dtype=float).T
        ax.plot(g, v, ".", color="0.6", ms=5, label="designs of the generation (fast, feasible)")
        gens = np.unique(g)
        pick = np.max if objective.sense == "max" else np.min
        best = [pick(v[g <= k]) for k in gens]
        ax.step(gens, best, where="post", color="C0", lw=1.5, label=f"best so far ({objective.sense})")
    for d in front:
        if d.get("rechecked", True) and feasible:
            ax.plot(gens[-1], d["objectives"][name], "x", ms=9, mew=2, color="C1",
                    label=f"{d['name']} re-checked (reference integrator)")
    if baseline is not None and baseline["objectives"].get(name) is not None:
        ax.axhline(baseline["objectives"][name], color="C2", ls="--", label=f"baseline ({baseline['name']})")
    ax.set_xlabel("generation [-]")
    ax.set_ylabel(f"{objective.aggregate} {catalogue[name].axis_label}")
    ax.xaxis.get_major_locator().set_params(integer=True)
    ax.set_title(f"{objective.sense} {objective.aggregate} {catalogue[name].label}: one objective, no front")
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=7)
    fig.tight_layout()
    _save(fig, path)
    return path


def plot_parallel(path: Path, variables, objectives, catalogue, front: list[dict], baseline: dict | None):
    """Draw the front in parallel coordinates.

    Each design's variables as a fraction of their range and its objectives scaled to the front's
    span; the ticks give the physical ends and units; the baseline dashed.

    Parameters
    ----------
    path : pathlib.Path
        The PNG file.
    variables : sequence of Variable
    objectives : sequence of Objective
    catalogue : dict
        The outputs (units).
    front : list of dict
        The design entries.
    baseline : dict or None

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    plt = _plt()
    axes_names = [v.name for v in variables] + [o.output for o in objectives]
    lows, highs = _parallel_ranges(variables, objectives, front, baseline)
    fig, ax = plt.subplots(figsize=(max(7.0, 1.25 * len(axes_names) + 1.5), 4.8))
    cmap = plt.get_cmap("viridis")
    key = objectives[0].output

    def line(d, **kw):
        vals = [d["variables"].get(v.name) for v in variables] + [d["objectives"].get(o.output) for o in objectives]
        ys = [np.nan if x is None else (x - lo) / (hi - lo) for x, lo, hi in zip(vals, lows, highs)]
        ax.plot(range(len(ys)), ys, **kw)

    f0 = [d["objectives"][key] for d in front]
    lo0, hi0 = (min(f0), max(f0)) if f0 else (0, 1)
    for d in front:
        c = cmap(0.5 if hi0 <= lo0 else (d["objectives"][key] - lo0) / (hi0 - lo0))
        line(d, color=c, alpha=0.8, lw=1.2)
    if baseline is not None and baseline.get("variables"):
        line(baseline, color="C3", lw=2.4, ls="--", label=f"baseline ({baseline['name']})")
        legend_outside(ax, fontsize=8)
    units = {v.name: v.unit for v in variables}
    units.update({o.output: catalogue[o.output].unit for o in objectives})
    ax.set_xticks(range(len(axes_names)),
                  [f"{n}\n[{units[n]}]\n{lo:.3g} .. {hi:.3g}" for n, lo, hi in zip(axes_names, lows, highs)],
                  fontsize=7, rotation=0)
    ax.set_ylabel("position within the range [-]\n(variables: bounds; objectives: front)")
    ax.set_ylim(-0.05, 1.05)
    ax.grid(axis="x", alpha=0.4)
    ax.set_title(f"designs on the front, coloured by {key} [{units[key]}]", fontsize=10)
    fig.tight_layout()
    _save(fig, path)
    return path


def _parallel_ranges(variables, objectives, front: list[dict], baseline: dict | None) -> tuple[list, list]:
    """Each parallel axis's ends: a variable's bounds, an objective's span over the front and the baseline."""
    lows, highs = [v.low for v in variables], [v.high for v in variables]
    for o in objectives:
        vals = [d["objectives"][o.output] for d in front] + ([baseline["objectives"][o.output]] if baseline else [])
        vals = [x for x in vals if x is not None]
        lo, hi = (min(vals), max(vals)) if vals else (0.0, 1.0)
        if hi <= lo:
            hi = lo + (abs(lo) * 1e-6 or 1e-9)
        lows.append(lo)
        highs.append(hi)
    return lows, highs


def pareto_rows(designs: list[dict], variables, objectives, constraints) -> tuple[list[dict], list[str]]:
    """The Pareto table: one flat row per design.

    Parameters
    ----------
    designs : list of dict
        The design entries.
    variables, objectives, constraints : sequence
        Of the spec.

    Returns
    -------
    rows : list of dict
        Name, model file, flags, the variables (``name [unit]``), derived keys, objectives (re-checked
        and fast) and constraints.
    columns : list of str
        Their order.
    """
    rows = []
    for d in designs:
        r = {"design": d["name"], "model_file": d["model_file"], "on_front": d["on_front"],
             "constraints_met": d["constraints_met"], "fea_flagged": d.get("fea_flagged"),
             "fidelity": d.get("fidelity"), "dominates_baseline": d.get("dominates_baseline"),
             "warnings": json.dumps(d.get("warnings", []))}
        for v in variables:
            r[f"{v.name} [{v.unit}]"] = d["variables"].get(v.name)
        for k, x in d.get("derived", {}).items():
            r[f"{k} (derived)"] = x
        for o in objectives:
            r[f"{o.label}"] = d["objectives"][o.output]
            r[f"{o.label} fast"] = d["objectives_fast"][o.output]
        for c in constraints:
            r[f"{c.label}"] = d["constraints"].get(c.output)
        rows.append(r)
    cols = list(dict.fromkeys(k for r in rows for k in r))
    return rows, cols


def write_pareto(out: Path, rows: list[dict], cols: list[str]) -> dict:
    """Write the Pareto table as Parquet and CSV.

    Parameters
    ----------
    out : pathlib.Path
        The study folder.
    rows : list of dict
    columns : list of str
        (:func:`pareto_rows`).

    Returns
    -------
    dict
        ``parquet`` and ``csv`` paths.
    """
    import pandas as pd

    df = pd.DataFrame(rows, columns=cols)
    pq, cs = out / "pareto.parquet", out / "pareto.csv"
    tmp = out / "pareto.parquet.tmp"
    df.to_parquet(tmp, index=False)
    os.replace(tmp, pq)
    _write_csv(cs, rows, cols)
    return {"parquet": str(pq), "csv": str(cs)}
