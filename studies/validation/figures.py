"""The validation figure: every comparison's E with its U_val bar per case, per rig (``validation.png``).

Per rig, one row per run: the comparison at the nominal inputs (open, grey: the air content's
prior range in U_val) and, for the runs not used to calibrate, the prediction with the
calibrated air content (filled: blue within, red a model-form error); the calibration runs are
marked; the rig tests at the bottom. E and U_val in % of the measured delivery; legends outside
the axes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _rel(r: dict) -> tuple[float, float]:
    """(E, U_val) in % of the measured delivery (a rig row is in % already)."""
    if r.get("unit") == "% of D":
        return r["E"], r["U_val"]
    return r["E"] / r["D"] * 100.0, r["U_val"] / r["D"] * 100.0


def plot_comparisons(extra: dict, validation_rows, path) -> Path:
    """validation.png: :func:`comparison_figure` saved."""
    import matplotlib.pyplot as plt

    fig = comparison_figure(extra, validation_rows)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return Path(path)


def comparison_figure(extra: dict, validation_rows):
    """E with U_val per case and rig (see the module docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rigs = list(dict.fromkeys(r["case"].split("_")[0] for r in validation_rows))
    fig, axes = plt.subplots(len(rigs), 1, figsize=(10.5, 1.6 + 2.9 * len(rigs)), squeeze=False,
                             constrained_layout=True)
    pred = {r["case"]: r for r in extra.get("prediction", [])}
    cal_runs = {n for e in extra.get("calibration", []) if e.get("u") is not None for n in e["runs"]}
    for ax, rig in zip(axes[:, 0], rigs):
        rows = [r for r in validation_rows if r["case"].startswith(rig + "_")]
        tests = [t for t in extra.get("rig_tests", []) if t["case"].startswith(rig + ":")]
        labels = [r["case"].removeprefix(rig + "_") + (" (calibration run)" if r["case"] in cal_runs else "")
                  + (" (suspect run)" if r.get("suspect") else "") for r in rows] + [t["case"] for t in tests]
        y = np.arange(len(labels))[::-1]
        for yi, r in zip(y, rows):
            e, u = _rel(r)
            ax.errorbar(e, yi + 0.15, xerr=u, fmt="o", mfc="none", color="tab:gray", capsize=3)
            if r["case"] in pred:
                _filled(ax, pred[r["case"]], yi - 0.15)
        for yi, t in zip(y[len(rows):], tests):
            if t["calibrated"]:
                _filled(ax, t, yi)
            else:
                e, u = _rel(t)
                ax.errorbar(e, yi, xerr=u, fmt="o", mfc="none", color="tab:gray", capsize=3)
        ax.axvline(0.0, color="k", lw=0.8)
        ax.set_yticks(y)
        ax.set_yticklabels(labels, fontsize=8)
        ax.set_ylabel(f"{rig} rig: run [-]")
        ax.set_xlabel("E = S - D with +-U_val [% of the measured delivery]")
    _legend(axes[0, 0])
    fig.suptitle("Delivery: each run at the nominal inputs and, calibrated on the baseline runs, the others "
                 "predicted (ASME V&V 20)", fontsize=9)
    return fig


def _filled(ax, r: dict, y: float) -> None:
    e, u = _rel(r)
    color = "tab:blue" if r["verdict"] == "within" else "tab:red"
    ax.errorbar(e, y, xerr=u, fmt="s", color=color, capsize=3)


def _legend(ax) -> None:
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], marker="o", mfc="none", color="tab:gray", ls="none",
                      label="nominal inputs (air content's prior range in U_val)"),
               Line2D([], [], marker="s", color="tab:blue", ls="none", label="predicted, calibrated: within U_val"),
               Line2D([], [], marker="s", color="tab:red", ls="none", label="predicted: model-form error |E| > U_val")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=8)
