"""The reed dynamics study's report: the Markdown tables and the plots of
:func:`studies.validation.reed_dynamics.dynamics_study`'s result, and the result as JSON types.

Every value is read from the study's result (its tolerances too); the numbers of modes tried are
passed in (:data:`studies.validation.reed_dynamics.MODES`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from studies.plots import legend_outside

LABELS = {"one-mode": "eq 3.21 (one mode)", "fe": "whole FE reed"}


def as_json(study: dict) -> dict:
    """The study as JSON types, without its traces.

    Parameters
    ----------
    study : dict

    Returns
    -------
    dict
        A timing difference that cannot be taken (a valve that opens in one model and not the other) as null.
    """
    def clean(v):
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, np.generic):          # numpy scalars (a bool_ is no JSON bool)
            v = v.item()
        return None if isinstance(v, float) and not math.isfinite(v) else v

    return clean({k: v for k, v in study.items() if k != "traces"})


def fmt(v, spec: str, missing: str = "n/a (opens in one model only)") -> str:
    """A number of a table cell, or ``missing`` where a difference cannot be taken (None, infinite).

    Parameters
    ----------
    v : float or None
    spec : str
        Its format (``.3f``).
    missing : str

    Returns
    -------
    str
    """
    return missing if v is None or not math.isfinite(v) else format(v, spec)


def _md(header: list[str], rows: list[list[str]]) -> list[str]:
    """A Markdown table's lines."""
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |" for r in rows]


def _summary_table(study: dict, modes: tuple) -> list[str]:
    """Per reed: eq 3.21's and each N's worst difference from the reference, and the modes needed."""
    tol = study["tolerances"]
    header = ["reed", "reference", "eq 3.21: delivery % / timing deg"]
    header += [f"N = {n}" for n in modes] + [f"modes for {tol['delivery_pct']:g} % and {tol['angle_deg']:g} deg",
                                            "numerics: fast vs reference stepper"]
    rows = []
    for s in study["reeds"]:
        cells = [s["reed"], "whole FE reed (beam)" if s["reference"] == "fe" else f"{s['reference']} ({s['fidelity']})",
                 f"{fmt(s['one_mode_worst_delivery_pct'], '.3f', 'n/a')} / {fmt(s['one_mode_worst_angle_deg'], '.2f', 'n/a')}"]
        for n in modes:
            w = s["modal_worst"].get(f"modal{n}")
            cells.append("-" if w is None or f"modal{n}" == s["reference"] else
                         f"{fmt(w['delivery_pct'], '.4f', 'n/a')} / {fmt(w['angle_deg'], '.3f', 'n/a')}")
        need = "more than " + str(modes[-1]) if s["modes_needed"] is None else str(s["modes_needed"])
        cells.append(need + (" (eq 3.21 enough)" if s["one_mode_enough"] else " (eq 3.21 not enough)"))
        cells.append(f"{fmt(s.get('numerical_pct'), '.4f', '-')} % / {fmt(s.get('numerical_deg'), '.3f', '-')} deg")
        rows.append(cells)
    return _md(header, rows)


def _case_table(study: dict, reed: str) -> list[str]:
    """One reed: each model's delivery against the reference per case [%], and its worst timing [deg]."""
    mine = [r for r in study["rows"] if r["reed"] == reed]
    cases = list(dict.fromkeys(r["case"] for r in mine))
    models = list(dict.fromkeys(r["model"] for r in mine))
    header = ["model"] + [c.replace("_", " ") + " [%]" for c in cases] + ["worst timing [deg]"]
    rows = []
    for m in models:
        by_case = {r["case"]: r for r in mine if r["model"] == m}
        worst = max(r["worst_angle_vs_reference_deg"] for r in by_case.values())
        rows.append([LABELS.get(m, m)] + [f"{by_case[c]['delivery_vs_reference_pct']:+.4f}" for c in cases]
                    + [fmt(worst, ".3f", "n/a")])
    return _md(header, rows)


def _detail_table(study: dict, reed: str) -> list[str]:
    """One reed at its first case: every model's outputs (delivery, timings, peak opening, impacts, stress)."""
    mine = [r for r in study["rows"] if r["reed"] == reed]
    first = mine[0]["case"]
    header = ["model", "delivery [cc/rev]", "inlet opens / closes [deg]", "delivery opens / closes [deg]",
              "delivery peak opening [mm]", "delivery seat / stop impact [m/s]", "peak root stress [MPa]"]
    rows = []
    for r in (r for r in mine if r["case"] == first):
        rows.append([LABELS.get(r["model"], r["model"]), f"{r['delivery_cc']:.5f}",
                     f"{fmt(r['inlet_opening_deg'], '.2f', '-')} / {fmt(r['inlet_closing_deg'], '.2f', '-')}",
                     f"{fmt(r['delivery_opening_deg'], '.2f', '-')} / {fmt(r['delivery_closing_deg'], '.2f', '-')}",
                     f"{r['delivery_peak_opening_mm']:.4f}",
                     f"{fmt(r['delivery_seat_impact_m_s'], '.4f', '-')} / {fmt(r['delivery_stop_impact_m_s'], '.4f', '-')}",
                     fmt(r.get("peak_root_stress_mpa"), ".2f", "-")])
    return _md(header, rows)


def markdown(study: dict, modes: tuple) -> str:
    """The study's tables in Markdown.

    Parameters
    ----------
    study : dict
        :func:`studies.validation.reed_dynamics.dynamics_study`'s result.
    modes : tuple of int
        The numbers of modes tried.

    Returns
    -------
    str
        The verdict per reed, each reed's delivery differences per case [%], and its first case in full.
    """
    t = study["tolerances"]
    steppers = ("every model on the reference stepper" if t["method"] == "reference" else
                f"the fast stepper at rtol {t['fast_rtol']:g}, the FE reed on the reference stepper")
    numerics = ("the six-mode reed at the first point, fast stepper "
                f"({study['numerics'][0]['fast_stepper']}) against the reference" if study["numerics"] else
                "not run (the quick study)")
    out = [f"Against each reed's reference, over {study['reeds'][0]['cases']} operating point(s) of Table 5.6 "
           f"({steppers}); largest |delivery difference| [%] / largest valve timing difference [deg]; the "
           f"numerics column: {numerics}:", ""]
    out += _summary_table(study, modes)
    for s in study["reeds"]:
        port = "" if not s["port"] else " Port: " + ", ".join(f"{k} {v * 1e3:.2f} mm" for k, v in s["port"].items()) + "."
        out += ["", f"**{s['reed']}** ({s['why']}; {s['fidelity']} modes).{port} Delivery against the reference:", ""]
        out += _case_table(study, s["reed"])
        first = next(r["case"] for r in study["rows"] if r["reed"] == s["reed"])
        out += ["", f"{s['reed']}, {first.replace('_', ' ')}:", ""]
        out += _detail_table(study, s["reed"])
    return "\n".join(out) + "\n"


def plot(study: dict, folder, modes: tuple) -> list:
    """Draw, per reed, the delivery valve's opening over a revolution for every model, and the six-mode reed's
    modal participation (each mode's share e_i q_i of the opening).

    Parameters
    ----------
    study : dict
        :func:`studies.validation.reed_dynamics.dynamics_study`'s result (with traces).
    folder : str or os.PathLike
    modes : tuple of int
        The numbers of modes tried (the largest's participation is drawn).

    Returns
    -------
    list of pathlib.Path
        One PNG per reed.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = []
    for reed, by_label in study["traces"].items():
        fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 7), sharex=True, constrained_layout=True)
        for label, (tr, _) in by_label.items():
            ax.plot(tr.crank_deg, tr.delivery_position * 1e3, lw=2.0 if label in ("fe", "one-mode") else 1.0,
                    ls="--" if label == "one-mode" else "-", label=LABELS.get(label, label))
        ax.set_ylabel("delivery reed opening x [mm]")
        first = next(r["case"] for r in study["rows"] if r["reed"] == reed)
        ax.set_title(f"{reed}: delivery valve opening by reed model ({first.replace('_', ' ')})")
        legend_outside(ax, fontsize=8)
        tr, kinds = by_label.get(f"modal{modes[-1]}", (None, None))
        if tr is not None and kinds:
            for i, kind in enumerate(kinds):
                bx.plot(tr.crank_deg, getattr(tr, f"delivery_mode{i + 1}_position") * 1e3, label=kind)
            legend_outside(bx, fontsize=8)
        bx.set_xlabel("crank angle from TDC [deg]")
        bx.set_ylabel("share of the opening e_i q_i [mm]")
        bx.set_title(f"modal participation, {modes[-1]} modes")
        path = Path(folder) / f"reed_dynamics_{reed}.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        out.append(path)
    return out
