"""The validation table of ASME V&V 20-2009: comparison error, validation uncertainty, model-form interval.

Per case and output: E = S - D (simulation minus data), the validation uncertainty
u_val = sqrt(u_num^2 + u_input^2 + u_D^2) (V&V 20 eq 1-5.5, the three independent), the
expanded U_val = k u_val and the interval E - U_val <= delta_model <= E + U_val that holds the
model-form error. k = 2 unless the components' degrees of freedom are known: then the
Welch-Satterthwaite effective dof (GUM G.4.1, eq G.2b) gives k = t_p(nu_eff) at p = 95.45 %
(the coverage of k = 2 for a normal distribution). Verdict: ``within`` when |E| <= U_val
(the model-form error cannot be told from the uncertainties), else ``model_form_error``.

Pooled over the cases of a valve kind: the area validation metric with u-pooling (Ferson,
Oberkampf and Ginzburg 2008, Comput. Methods Appl. Mech. Engrg. 197, 2408-2430; Ferson and
Oberkampf 2009): each measurement through its own case's predictive distribution,
u_i = F_i(D_i); the area between the u's empirical distribution and the uniform one is the
metric in probability, and back through a reference predictive distribution G (every
case's draws about its own median, placed at the mean prediction) it is the area between
G and the u's image G^-1(u_i) in the output's units (scipy.stats.wasserstein_distance:
the area between two empirical distribution functions).

:class:`ValidationTable` holds the rows (the CONTRACT's JSON) with ``.to_frame()``,
``.plot(path)`` and the Markdown/CSV/JSON writers.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from studies.validation.measurement import welch_satterthwaite

#: coverage probability of U_val (k = 2 for a normal distribution)
COVERAGE = 0.9545
K_DEFAULT = 2.0
#: row keys of the CONTRACT, in order
ROW_KEYS = ("case", "output", "S", "D", "E", "u_num", "u_input", "u_D", "u_val", "k", "U_val", "delta_model",
            "verdict", "contributors", "dof", "interval")


def coverage_factor(dof: float, p: float = COVERAGE) -> float:
    """k for coverage probability ``p``: Student's t at ``dof`` (GUM G.3.2), the normal quantile for infinite dof."""
    from scipy.stats import norm, t

    q = 0.5 * (1.0 + p)
    if dof is None or not math.isfinite(dof):
        return K_DEFAULT if p == COVERAGE else float(norm.ppf(q))
    return float(t.ppf(q, dof))


@dataclass(frozen=True)
class Components:
    """The three standard uncertainties of a comparison (V&V 20 eq 1-5.5), in the output's units.

    ``u_num``: the numerics (solution verification), ``u_input``: the simulation's inputs, ``u_D``: the data;
    ``dof``: their degrees of freedom in that order (None or inf for a Type B estimate), for the
    Welch-Satterthwaite k.
    """

    u_num: float
    u_input: float
    u_D: float
    dof: tuple = (math.inf, math.inf, math.inf)


def vv20_row(case: str, output: str, unit: str, S: float, D: float, u: Components, contributors=(),
             coverage: tuple[float, str] | None = None) -> dict:
    """One row of the table (CONTRACT keys, plus ``unit``, ``nu_eff``, ``words``), output units throughout.

    ``u``: the three standard uncertainties and their degrees of freedom (:class:`Components`). ``coverage``:
    (k, "monte_carlo") from a Monte Carlo coverage interval (:func:`studies.validation.joint.interval`);
    default k = t(nu_eff) ("welch"). ``u_input_se`` (None here; the Monte Carlo's callers set it) is the
    standard error of u_input, a column of its own (the estimate's precision, not a degree of freedom).

    >>> r = vv20_row("c", "delivery_cc_per_rev", "cc/rev", 1.80, 1.72, Components(0.0, 0.03, 0.04))
    >>> round(r["E"], 4), round(r["u_val"], 4), r["k"], r["verdict"]
    (0.08, 0.05, 2.0, 'within')
    """
    comps = [float(u.u_num or 0.0), float(u.u_input or 0.0), float(u.u_D or 0.0)]
    dofs = [math.inf if d is None else float(d) for d in u.dof]
    E = float(S) - float(D)
    u_val = math.sqrt(sum(c * c for c in comps))
    nu = welch_satterthwaite(comps, dofs)
    k, how = (coverage_factor(nu), "welch") if coverage is None else (float(coverage[0]), coverage[1])
    U = k * u_val
    row = {"case": case, "output": output, "unit": unit, "S": float(S), "D": float(D), "E": E,
           "u_num": comps[0], "u_input": comps[1], "u_D": comps[2], "u_val": u_val, "k": k, "U_val": U,
           "delta_model": [E - U, E + U], "verdict": "within" if abs(E) <= U else "model_form_error",
           "contributors": [[str(a), float(b)] for a, b in contributors],
           "nu_eff": None if math.isinf(nu) else nu, "dof": None if math.isinf(nu) else nu, "interval": how,
           "u_input_se": None}
    row["words"] = verdict_words(row)
    return row


def _same_decimals(rows, keys) -> dict:
    """{key: the cells of that column}, the rows of one output to the same decimals (a value never shown to fewer
    digits than its neighbours: 1.72600 beside 1.70637, not 1.726; :func:`studies.outputs.format_column`)."""
    from studies.outputs import format_column

    out = {k: [""] * len(rows) for k in keys}
    for output in dict.fromkeys(r["output"] for r in rows):
        idx = [i for i, r in enumerate(rows) if r["output"] == output]
        for k in keys:
            for i, cell in zip(idx, format_column([float(rows[i][k]) for i in idx])):
                out[k][i] = cell
    return out


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def verdict_words(row: dict) -> str:
    """The verdict in words: within the validation uncertainty, or a model-form error between a and b."""
    unit = f" {row['unit']}" if row.get("unit") not in (None, "", "-") else ""
    if row["verdict"] == "within":
        return (f"within the validation uncertainty (abs(E) = {_fmt(abs(row['E']))} <= U_val = "
                f"{_fmt(row['U_val'])}{unit})")
    lo, hi = row["delta_model"]
    return f"model-form error between {_fmt(lo)} and {_fmt(hi)}{unit}"


# --------------------------------------------------------------------------- area metric
def area_metric(prediction, observations) -> float:
    """The area between the empirical distribution functions of ``prediction`` (draws) and ``observations``
    (Ferson et al. 2008), in their units: scipy.stats.wasserstein_distance."""
    from scipy.stats import wasserstein_distance

    return float(wasserstein_distance(np.ravel(prediction), np.ravel(observations)))


def u_pooling(predictions, observations, reference=None) -> dict:
    """The u-pooled area metric of observations made at different conditions (Ferson and Oberkampf 2009).

    ``predictions[i]``: draws of the model's predictive distribution at case i; ``observations[i]``
    its measurement. u_i = F_i(D_i) (the empirical CDF, mid-rank at ties, kept inside
    (1/(2n), 1 - 1/(2n))); ``area_u`` the area between their empirical CDF and the uniform one;
    ``area`` the same through ``reference`` (draws of G; default: every case's draws about their
    own median, placed at the mean of the medians), in the observations' units.
    """
    from scipy.stats import wasserstein_distance

    us = []
    for pred, d in zip(predictions, observations):
        x = np.sort(np.ravel(np.asarray(pred, dtype=float)))
        n = len(x)
        below = np.searchsorted(x, d, side="left")
        upto = np.searchsorted(x, d, side="right")
        u = (below + upto) / (2.0 * n)
        us.append(float(np.clip(u, 0.5 / n, 1.0 - 0.5 / n)))
    grid = (np.arange(4000) + 0.5) / 4000
    area_u = float(wasserstein_distance(us, grid))
    if reference is None:
        meds = [float(np.median(p)) for p in predictions]
        reference = np.concatenate([np.ravel(p) - m for p, m in zip(predictions, meds)]) + float(np.mean(meds))
    ref = np.sort(np.ravel(np.asarray(reference, dtype=float)))
    image = np.quantile(ref, us)
    return {"u_values": us, "area_u": area_u, "area": float(wasserstein_distance(image, ref))}


# --------------------------------------------------------------------------- the table
@dataclass(frozen=True)
class ValidationTable:
    """V&V 20 rows with notes, the pooled area metric and how to write and draw them."""

    title: str
    rows: tuple[dict, ...]
    notes: tuple[str, ...] = ()
    area_metric: dict = field(default_factory=dict)

    def to_frame(self):
        """pandas DataFrame, one row per case and output (delta_model as two columns)."""
        import pandas as pd

        recs = []
        for r in self.rows:
            d = {k: r[k] for k in ROW_KEYS if k not in ("delta_model", "contributors")}
            d.update(unit=r.get("unit"), delta_model_low=r["delta_model"][0], delta_model_high=r["delta_model"][1],
                     nu_eff=r.get("nu_eff"), u_input_se=r.get("u_input_se"), detectable_pct=r.get("detectable_pct"),
                     contributors="; ".join(f"{a} {b:.3g}" for a, b in r["contributors"]))
            recs.append(d)
        return pd.DataFrame(recs)

    def to_json(self) -> list[dict]:
        """The rows as the CONTRACT's JSON (plus ``unit``, ``nu_eff``, ``words``)."""
        return [dict(r) for r in self.rows]

    def to_markdown(self) -> str:
        """A Markdown table with the verdict in words, the area metric and the notes."""
        lines = [f"# {self.title}", "",
                 "| case | output [unit] | S | D | E | u_num | u_input | se(u_input) | u_D | u_val | dof | k (interval) | "
                 "U_val | verdict | detectable (80 %) | largest input contributors |",
                 "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        same = _same_decimals(self.rows, ("S", "D"))
        for i, r in enumerate(self.rows):
            unit = r.get("unit") or "-"
            contrib = ", ".join(f"{a} ({b:.2g} {unit})" for a, b in r["contributors"]) or "-"
            se = r.get("u_input_se")
            det = r.get("detectable_pct")
            dof = r.get("dof")
            lines.append(f"| {r['case']} | {r['output']} [{unit}] | {same['S'][i]} | {same['D'][i]} | {r['E']:+.4g} | "
                         f"{r['u_num']:.2g} | {r['u_input']:.3g} | {'-' if se is None else f'{se:.2g}'} | "
                         f"{r['u_D']:.3g} | {r['u_val']:.3g} | {'inf' if dof is None else f'{dof:.3g}'} | "
                         f"{r['k']:.3g} ({r.get('interval', 'welch')}) | {r['U_val']:.3g} | {r['words']} | "
                         f"{'-' if det is None else f'{det:.3g} %'} | {contrib} |")
        if self.area_metric:
            lines += ["", "Area validation metric (u-pooling over the cases of each valve kind): "
                      + ", ".join(f"{k} {v:.4g}" for k, v in self.area_metric.items() if v is not None) + "."]
        if self.notes:
            lines += [""] + [f"- {n}" for n in self.notes]
        return "\n".join(lines) + "\n"

    def write(self, stem) -> list[Path]:
        """``stem.md``, ``stem.csv`` and ``stem.json``; returns the paths."""
        stem = Path(stem)
        md, cs, js = stem.with_suffix(".md"), stem.with_suffix(".csv"), stem.with_suffix(".json")
        md.write_text(self.to_markdown())
        df = self.to_frame()
        with open(cs, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(list(df.columns))
            for rec in df.itertuples(index=False):
                w.writerow(["" if v is None or (isinstance(v, float) and math.isnan(v)) else
                            (f"{v:.8g}" if isinstance(v, float) else v) for v in rec])
        js.write_text(json.dumps({"title": self.title, "rows": self.to_json(), "area_metric": self.area_metric,
                                  "notes": list(self.notes)}, indent=2, allow_nan=False) + "\n")
        return [md, cs, js]

    def plot(self, path, relative: bool = False):
        """E with its U_val bar per case, one panel per output (each in its unit; ``relative``: % of D)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        outputs = list(dict.fromkeys(r["output"] for r in self.rows))
        fig, axes = plt.subplots(len(outputs), 1, figsize=(10.5, 1.2 + 2.6 * len(outputs)), squeeze=False)
        for ax, out in zip(axes[:, 0], outputs):
            rows = [r for r in self.rows if r["output"] == out]
            scale = [100.0 / abs(r["D"]) if relative and r["D"] else 1.0 for r in rows]
            y = np.arange(len(rows))
            E = np.array([r["E"] * s for r, s in zip(rows, scale)])
            U = np.array([r["U_val"] * s for r, s in zip(rows, scale)])
            bad = np.array([r["verdict"] != "within" for r in rows])
            ax.errorbar(E[~bad], y[~bad], xerr=U[~bad], fmt="o", color="tab:blue", capsize=3,
                        label="within: |E| <= U_val")
            if bad.any():
                ax.errorbar(E[bad], y[bad], xerr=U[bad], fmt="s", color="tab:red", capsize=3,
                            label="model-form error: |E| > U_val")
            ax.axvline(0.0, color="k", lw=0.8)
            ax.set_yticks(y)
            ax.set_yticklabels([r["case"] for r in rows], fontsize=8)
            ax.set_ylabel("case [-]")
            unit = "% of D" if relative else (rows[0].get("unit") or "-")
            ax.set_xlabel(f"E = S - D of {out} with +-U_val [{unit}]")
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
        fig.suptitle(self.title, fontsize=9)
        fig.set_layout_engine("constrained")
        fig.savefig(path, dpi=120)
        plt.close(fig)
        return Path(path)


# --------------------------------------------------------------------------- the thesis's pump cases
#: the tolerance ladder's levels run at least this many revolutions from today's start (then until cyclic
#: steady state, at most max_revolutions): u_num is the difference of the levels, down to 1e-6 of the
#: delivery, and a level's last digits move with the revolution it stops at (the fast path's
#: revolution-to-revolution noise), so the ladder (36 fast runs, about a second) keeps the counts it was
#: measured with
LADDER = dict(revolutions=5, max_revolutions=12)
LADDER_QUICK = dict(revolutions=3, max_revolutions=3)


# --------------------------------------------------------------------------- the reed parameters
#: the reed thickness's standard uncertainty: +-5 % manufacturing tolerance (section 3.5.2), uniform
THICKNESS_REL = 0.05 / math.sqrt(3.0)
#: units of the reed quantities
REED_UNITS = {"omega_n": "rad/s", "kappa": "Pa/m", "gamma1": "-", "gamma2": "-", "gamma3": "-"}


def scaled_thickness(reed, factor: float):
    """``reed`` with every thickness (the reed's and each section's) times ``factor``; grooves keep their depth."""
    import tomllib

    from geometry.reed_io import parse_reed, reed_to_toml

    data = tomllib.loads(reed_to_toml(reed))
    r = data["reed"]
    if "thickness" in r:
        r["thickness"] *= factor
    for sec in r.get("sections", []):
        if "thickness" in sec:
            sec["thickness"] *= factor
    return parse_reed(data, source=f"{reed.name} x{factor:.4g} thick")


def reed_validation(reed, rows: list[dict], *, quick: bool = False, progress: bool = False) -> ValidationTable:
    """The V&V 20 table of the analytic reed model against each FEA fidelity (S analytic, D the FEA).

    ``rows``: the multi-fidelity check's rows (:func:`studies.validation.reed_check.multi_fidelity_check`).
    u_num: the GCI of the FEA value at the check's mesh (:func:`fea.convergence.gci_study`; the exact
    E-B model's own error is below 1e-9). u_input: the thickness tolerance (+-5 %, section 3.5.2,
    uniform) through both models at once: they see the same thickness, so only the difference of
    their sensitivities moves E, |E(h + u_h) - E(h - u_h)| / 2 (central difference).
    """
    import sys

    from fea.convergence import gci_study
    from fea.fidelities import get

    by = {r["fidelity"]: r for r in rows}
    if "analytic" not in by:
        raise ValueError("the reed validation compares the analytic model with the FEA: run it too")
    an = by["analytic"]
    plus, minus = scaled_thickness(reed, 1.0 + THICKNESS_REL), scaled_thickness(reed, 1.0 - THICKNESS_REL)
    an_p, an_m = get("analytic").reed_properties(plus), get("analytic").reed_properties(minus)
    out, notes = [], []
    for fid, r in by.items():
        if fid == "analytic":
            continue
        if progress:
            print(f"  reed validation: GCI and thickness tolerance of {fid}", file=sys.stderr, flush=True)
        h = r["mesh_size"]
        g = gci_study(reed, fid, mesh_size=h, quick=quick, progress=False)
        fp = get(fid).reed_properties(plus, mesh_size=h)
        fm = get(fid).reed_properties(minus, mesh_size=h)
        for q, unit in REED_UNITS.items():
            dE = ((getattr(an_p, q) - getattr(fp, q)) - (getattr(an_m, q) - getattr(fm, q))) / 2.0
            gq = g["quantities"][q]
            row = vv20_row(f"{reed.name}/{fid}", q, unit, an[q], r[q], Components(gq["u"], abs(dE), 0.0),
                           contributors=[("reed thickness (+-5 %, section 3.5.2)", abs(dE))])
            row["u_num_note"] = gq["gci"]["note"]
            out.append(row)
    moves = {q: (getattr(an_p, q) - getattr(an_m, q)) / 2.0 / an[q] * 100.0 for q in ("omega_n", "kappa")}
    notes += [
        "E = S - D: S the exact Euler-Bernoulli model (analytic), D the FEA fidelity at the check's mesh.",
        "u_num: the GCI of the FEA value (meshes 2h, h, h/2, Fs = 1.25 when converging monotonically, else Fs = 3 "
        "x the largest change; quick: 2h and h, Fs = 3, assumed order 1) / 1.15.",
        f"u_input: the thickness tolerance moves omega_n by {moves['omega_n']:+.2f} % and kappa by "
        f"{moves['kappa']:+.2f} % per standard uncertainty in both models alike; only the difference of their "
        "sensitivities enters E.",
        "A model-form error here is physics Euler-Bernoulli theory leaves out (plate stiffening, shear, the clamp), "
        "or the FEA's own simplification (the plate's grooves).",
        "settings: " + ("quick: two meshes per fidelity (Fs = 3), cheaper and coarser" if quick else
                        "three meshes per fidelity (2h, h, h/2)") + ".",
    ]
    return ValidationTable(f"Reed parameters of {reed.name}: analytic against each FEA fidelity (ASME V&V 20)",
                           tuple(out), tuple(notes))


# --------------------------------------------------------------------------- one operating point
#: outputs of ``valvelab pump --uncertainty``
POINT_OUTPUTS = ("delivery_cc_per_rev", "inlet_opening_angle_deg", "inlet_closing_angle_deg",
                 "delivery_opening_angle_deg", "delivery_closing_angle_deg")


def point_uncertainty(point, result, *, quick: bool = False, cluster=None, progress: bool = False,
                      outputs=POINT_OUTPUTS) -> dict:
    """u_num and u_input of one run of any model (``result``: its PumpResult, on either stepper) at ``point``
    (:class:`~studies.validation.point.Point`: the model, speed, load, revolutions and circuit of the run).

    u_num: the tolerance ladder from the run's own tolerance (fast) or the fast ladder against
    the reference run; u_input: the model's declared uncertainties by Monte Carlo (none
    declared: 0). Returns ``{output: {"u_num", "u_input", "contributors", "unit", ...}}``.
    """
    from studies.validation.input_uncertainty import propagate
    from studies.validation.numerical import OUTPUTS, numerical_uncertainty, output_values

    outs = {o: OUTPUTS[o] for o in outputs}
    reported = output_values(result, outs)
    fast = result.method == "fast"
    num = numerical_uncertainty(point, reported=reported, reported_method="fast" if fast else "reference",
                                reported_rtol=result.rtol if fast else None, quick=quick, outputs=outs)
    inp = propagate([point], quick=quick, cluster=cluster, progress=progress, outputs=tuple(outputs))[point.name]
    return {o: {"value": reported[o], "unit": outs[o], "u_num": num[o].u, "u_input": inp[o].u,
                "contributors": [list(c) for c in inp[o].contributors], "U_num": num[o].U,
                "u_num_converging": num[o].converging, "u_num_note": num[o].note,
                "u_input_precision": inp[o].precision, "draws": inp[o].samples + inp[o].missing,
                "u_input_note": inp[o].note}
            for o in outputs}
