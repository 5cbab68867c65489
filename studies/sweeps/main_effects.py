"""Main effects of a sweep: the mean of each response against each factor, and their plot."""

from __future__ import annotations

import os
from pathlib import Path

from studies.sweeps.sweep_spec import SweepSpec


def main_effects(df, spec: SweepSpec, responses: list[str], bins: int = 8) -> dict:
    """The mean of each response against each factor (its levels, or quantile bins of a range).

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep's results (:func:`studies.sweeps.store.read_results`); designs with status
        ``ok`` only are used.
    spec : SweepSpec
        The sweep.
    responses : list of str
        Output columns.
    bins : int
        Quantile bins of a sampled range (a grid or a list uses its levels).

    Returns
    -------
    dict
        {response: {factor: {"x": [...], "mean": [...], "count": [...], "span": max - min of the means}}},
        x in the factor's unit, the means in the response's.
    """
    import pandas as pd

    ok = df[df["status"] == "ok"]
    effects: dict = {}
    for r in responses:
        y = pd.to_numeric(ok[r], errors="coerce")
        per: dict = {}
        for f in spec.factors:
            x = ok[f.name]
            if not f.is_range or spec.sampler == "grid" or x.nunique() <= bins:
                key = x
            else:
                key = pd.qcut(x.astype(float), q=bins, duplicates="drop")
            g = pd.DataFrame({"x": x, "y": y, "k": key}).dropna(subset=["y"]).groupby("k", observed=True)
            xs = g["x"].first() if (not f.is_range) else g["x"].mean()
            means = g["y"].mean()
            per[f.name] = {
                "x": [v.item() if hasattr(v, "item") else v for v in xs.tolist()],
                "mean": [float(v) for v in means.tolist()],
                "count": [int(v) for v in g["y"].count().tolist()],
                "span": float(means.max() - means.min()) if len(means) else 0.0,
            }
        effects[r] = per
    return effects


def plot_main_effects(effects: dict, path: Path, title: str = "", units: dict | None = None) -> Path:
    """Draw a grid of main-effect plots (rows: responses, columns: factors) and save it as PNG.

    Parameters
    ----------
    effects : dict
        :func:`main_effects`' result.
    path : pathlib.Path
        The PNG file (written atomically).
    title : str
        The figure's title.
    units : dict, optional
        {response or factor: unit} for the axes (``-`` where unknown).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    responses = list(effects)
    factors = list(effects[responses[0]]) if responses else []
    fig, axes = plt.subplots(len(responses), len(factors), squeeze=False,
                             figsize=(2.8 * len(factors) + 0.8, 2.4 * len(responses) + 0.6), sharey="row",
                             sharex="col")     # one x axis per factor, numbered and labelled on the bottom row
    for i, r in enumerate(responses):
        for j, f in enumerate(factors):
            ax, e = axes[i][j], effects[r][f]
            xs = e["x"]
            if xs and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in xs):
                ax.plot(xs, e["mean"], "o-")
            else:
                ax.plot(range(len(xs)), e["mean"], "o-")
                ax.set_xticks(range(len(xs)), [str(v) for v in xs])
            if i == len(responses) - 1:
                ax.set_xlabel(f"{f} [{(units or {}).get(f, '-')}]")
            if j == 0:
                ax.set_ylabel(f"{r} [{(units or {}).get(r, '-')}]")
            ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    tmp = path.with_name(path.name + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)
    return path
