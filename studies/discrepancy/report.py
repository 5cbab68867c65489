"""The discrepancy report folder: ranking table, disagreements in words, plots.

Written into a folder valvelab owns (``studies/outputs.py``): ``summary.json`` (the
command's JSON), ``ranking.csv`` and ``ranking.md`` (every candidate of every round),
``disagreements.txt`` (the baseline's outputs beyond their validation uncertainty first, and what
the final model leaves unexplained), ``validation.csv``/``validation.md`` (the baseline's V&V 20 table
per run and output), ``traces_<run>.png`` (measured vs baseline vs augmented
position over crank angle, with the residuals below), ``residuals.png`` (all runs'
residuals vs crank angle before and after) and ``gap_bars.png`` (position RMS and
delivery error before/after, pooled over every run as the command prints them, over the fitted and over the
held-out runs, each bar with its value).
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from studies.discrepancy.workflow import Outcome  # noqa: E402
from studies.discrepancy.gap import fold, predict, summary  # noqa: E402
from studies.discrepancy.records import values_text  # noqa: E402
from studies.discrepancy.words import window_sentences  # noqa: E402
from studies.discrepancy.validation import sentence  # noqa: E402
from studies.outputs import prepare_output_dir  # noqa: E402


def _ranking_frame(ranking: list[dict], outcome: Outcome) -> pd.DataFrame:
    rows = []
    for r in ranking:
        row = {k: v for k, v in r.items() if k != "parameters"}
        units = _units(outcome, r["effect"], r["target"])
        row["parameters"] = values_text(r["parameters"], units)
        rows.append(row)
    cols = ["round", "rank", "effect", "target", "parameters", "held_out_improvement_pct", "fit_improvement_pct",
            "delta_bic", "plausible", "accepted", "held_out_cost", "fit_cost", "simulations", "why_not_plausible",
            "failed"]
    return pd.DataFrame(rows, columns=cols)


def _units(outcome: Outcome, effect: str, target: str) -> dict:
    """The units of an effect's reported values in the outcome's context ({} for a name the library lacks)."""
    try:
        return outcome.library[effect].units(outcome.valve_type, target)
    except KeyError:
        return {}


def _markdown(df: pd.DataFrame) -> str:
    def cell(v):
        if v is None or (isinstance(v, float) and not np.isfinite(v)):
            return "-"
        if isinstance(v, float):
            return f"{v:.3g}"
        return str(v)

    head = "| " + " | ".join(df.columns) + " |"
    sep = "|" + "|".join("---" for _ in df.columns) + "|"
    body = ["| " + " | ".join(cell(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join([head, sep, *body]) + "\n"


def _trace_plot(path: Path, run, outcome: Outcome):
    f = fold(run)
    valves = list(f.position)
    fig, axes = plt.subplots(2, len(valves), figsize=(6.5 * len(valves) + 2.0, 6), sharex=True, squeeze=False,
                             gridspec_kw={"height_ratios": [3, 1.4]}, layout="constrained")
    for j, valve in enumerate(valves):
        th, m = f.crank_deg[valve], f.position[valve]
        base = predict(outcome.before.sims[run.name], valve, th, run.speed_rpm, outcome.before.nuisance)
        aug = predict(outcome.after.sims[run.name], valve, th, run.speed_rpm, outcome.after.nuisance)
        ax = axes[0, j]
        ax.plot(th, m * 1e3, ".", ms=1.5, color="0.55", label="measured")
        ax.plot(th, base * 1e3, "-", lw=1.2, color="tab:red", label="baseline")
        if outcome.model:
            ax.plot(th, aug * 1e3, "-", lw=1.2, color="tab:blue", label="augmented")
        ax.set_ylabel(f"{valve} valve position [mm]")
        ax.set_title(f"{run.name}: {valve} valve")
        ax.axhline(0.0, color="k", lw=0.5)
        ax2 = axes[1, j]
        ax2.plot(th, (m - base) * 1e3, "-", lw=0.8, color="tab:red", label="measured - baseline")
        if outcome.model:
            ax2.plot(th, (m - aug) * 1e3, "-", lw=0.8, color="tab:blue", label="measured - augmented")
        ax2.axhline(0.0, color="k", lw=0.5)
        ax2.set_xlabel("crank angle from TDC [deg]")
        ax2.set_ylabel("residual [mm]")
        ax2.set_xlim(0, 360)
        ax2.set_xticks(range(0, 361, 45))
    # legends beside the panels, off the traces (one for the positions, one for the residuals)
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="outside right upper", fontsize=8)
    fig.legend(*axes[1, 0].get_legend_handles_labels(), loc="outside right lower", fontsize=7)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _residual_plot(path: Path, runs, outcome: Outcome):
    fig, axes = plt.subplots(1, 2 if outcome.model else 1, figsize=(14.5 if outcome.model else 9.5, 4), squeeze=False,
                             sharey=True, layout="constrained")
    panels = [("baseline", outcome.before)] + ([("augmented", outcome.after)] if outcome.model else [])
    for ax, (label, ev) in zip(axes[0], panels):
        for g in ev.gaps:
            for v in g.valves:
                ax.plot(v.crank_deg, v.residual_m * 1e3, lw=0.7, label=f"{g.run} ({v.valve})")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_title(f"measured - {label}")
        ax.set_xlabel("crank angle from TDC [deg]")
        ax.set_xlim(0, 360)
        ax.set_xticks(range(0, 361, 45))
    axes[0, 0].set_ylabel("position residual [mm]")
    fig.legend(*axes[0, -1].get_legend_handles_labels(), loc="outside right upper", fontsize=6)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _bar_groups(outcome: Outcome) -> list[tuple[str, list[str]]]:
    """(label, run names) of the gap bars: every run (the gap the command prints as before/after), the fitted
    runs and the held-out runs, each label with its number of runs."""
    fit = [r.name for r in outcome.fit_runs]
    held = [r.name for r in outcome.held_runs]
    groups = [(f"all {len(fit) + len(held)} runs", fit + held)] if held else []
    groups.append((f"fitted ({len(fit)})", fit))
    if held:
        groups.append((f"held out ({len(held)})", held))
    return groups


def _bars(path: Path, outcome: Outcome):
    """The gap before and after, pooled over every run (as printed), over the fitted and over the held-out runs;
    each bar labelled with its value."""
    groups = _bar_groups(outcome)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    x = np.arange(len(groups))
    for ax, key, scale, unit, fmt in ((axes[0], "position_rms_m", 1e3, "position RMS [mm]", "%.3f"),
                                      (axes[1], "delivery_error_pct", 1.0, "delivery error RMS [%]", "%.2f")):
        for dx, ev, colour, label in ((-0.2, outcome.before, "tab:red", "baseline"),
                                      (0.2, outcome.after, "tab:blue", "augmented")):
            v = [summary([g for g in ev.gaps if g.run in names])[key] for _, names in groups]
            bars = ax.bar(x + dx, [np.nan if y is None else y * scale for y in v], 0.4, color=colour, label=label)
            ax.bar_label(bars, fmt=fmt, fontsize=7, padding=1)
        ax.set_xticks(x, [g for g, _ in groups])
        ax.set_ylabel(unit)
        ax.margins(y=0.12)                          # room for the value above the tallest bar
    added = ", ".join(a.key for a in outcome.model) or "nothing added"
    fig.suptitle(f"gap before and after ({added})", fontsize=10)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside upper right", ncol=2, fontsize=8)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_report(folder, outcome: Outcome, runs, result: dict, force: bool = False) -> Path:
    """Write the report folder for a workflow outcome; returns its path."""
    out = prepare_output_dir(folder, "--report", force=force, kind="report")
    (out / "summary.json").write_text(json.dumps(result, indent=2, allow_nan=False) + "\n")
    df = _ranking_frame(outcome.ranking, outcome)
    df.to_csv(out / "ranking.csv", index=False)
    text = "# Candidate effects, every round\n\n" + _markdown(df)
    if outcome.backward:
        bw = pd.DataFrame([{k: r.get(k) for k in ("round", "effect", "target", "held_out_cost", "held_out_cost_without",
                                                   "fit_improvement_pct", "delta_bic", "dropped", "why_dropped")}
                           for r in outcome.backward])
        text += ("\n# The backward step: each added effect taken out, the others refitted\n\n"
                 "An effect is dropped when the acceptance rule would not add it back (its `why_dropped`).\n\n"
                 + _markdown(bw))
    (out / "ranking.md").write_text(text)
    lines = ["Disagreements of the baseline model:"]
    lines += [f"  - {s}" for s in outcome.disagreements_before] or ["  (none beyond the tolerances)"]
    lines += ["", "Residual windows of the baseline, per run:"]
    lines += [f"  - {s}" for s in window_sentences(outcome.findings_before)] or ["  (none)"]
    lines += ["", "Effects added: " + (", ".join(a.key for a in outcome.model) or "none")]
    lines += [f"Effect dropped again in round {r['round']}: {r['effect']}"
              f"{'' if r['target'] in ('both', 'pump') else '@' + r['target']} (without it, the others refitted: "
              f"{r['why_dropped']})" for r in outcome.backward if r["dropped"]]
    lines += [f"Indistinguishable: {d['sentence']}" for d in outcome.indistinguishable]
    lines += [f"Baseline nuisance: {s}" for s in outcome.nuisance_sentences()]
    lines += ["Disagreements left after adding them:"]
    lines += [f"  - {s}" for s in outcome.disagreements_after] or ["  (none beyond the tolerances)"]
    lines += ["", "Left unexplained:"]
    lines += [f"  - {s}" for s in outcome.unexplained.get("sentences", [])] or ["  (nothing beyond the noise)"]
    lines += ["", *[f"note: {n}" for n in outcome.notes]]
    if outcome.validation is not None:
        lines = lines[:1] + [f"  - beyond the validation uncertainty: {sentence(b)}"
                             for b in outcome.validation["beyond"]] + lines[1:]
    (out / "disagreements.txt").write_text("\n".join(lines) + "\n")
    if outcome.validation is not None:
        vv = pd.DataFrame([{k: r.get(k) for k in ("run", "output", "unit", "S", "D", "E", "u_num", "u_input", "u_D",
                                                    "u_val", "U_val", "verdict")} for r in outcome.validation["rows"]])
        vv.to_csv(out / "validation.csv", index=False)
        (out / "validation.md").write_text("# The baseline against each run (ASME V&V 20)\n\n" + _markdown(vv))
    for run in runs:
        if run.trace is not None and run.name in outcome.before.sims:
            _trace_plot(out / f"traces_{run.name}.png", run, outcome)
    _residual_plot(out / "residuals.png", runs, outcome)
    _bars(out / "gap_bars.png", outcome)
    return out
