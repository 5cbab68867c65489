"""The pump validation of chapter 5: the 12 cases of Tables 5.3-5.6, their errors, tables and plots.

Each case (``studies/data/experiments.toml``) is simulated with the shipped thesis model
of its valve type (``thesis-disc``, ``thesis-reed``: lumped/data/models) on the reference
integrator until cyclic steady state; the modeled delivery is compared with the measured
one and with the thesis's modeled value.
"""

from __future__ import annotations

import inspect
import os
import sys
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path

from lumped.run.simulate import PumpResult, simulate
from lumped.model.pump_model import PumpModel
from lumped.model.model_file import load_model
from studies.outputs import Table
from studies.tables.thesis import experiments

#: (valve, measured valve, condition) -> thesis figure of that valve's position trace
FIGURES = {
    ("disc", "inlet", "baseline"): "5.7", ("disc", "inlet", "high_speed"): "5.8",
    ("disc", "inlet", "high_pressure"): "5.9", ("disc", "delivery", "baseline"): "5.10",
    ("disc", "delivery", "high_speed"): "5.11", ("disc", "delivery", "high_pressure"): "5.12",
    ("reed", "inlet", "low_speed"): "5.16", ("reed", "inlet", "medium_speed"): "5.17",
    ("reed", "inlet", "high_speed"): "5.18", ("reed", "delivery", "low_speed"): "5.19",
    ("reed", "delivery", "medium_speed"): "5.20", ("reed", "delivery", "high_speed"): "5.21",
}

#: run settings: at least ``revolutions`` (the traced ones), then until cyclic steady state
#: (lumped.run.revolutions.StopRule, STEADY_TOL), at most ``max_revolutions``; each case starts from the
#: fast path's cycle (lumped.run.warmstart.fast_start), so the reference is steady from its first revolution
FULL = dict(revolutions=3, max_revolutions=12, trace_revolutions=3)
QUICK = dict(revolutions=2, max_revolutions=3, trace_revolutions=1)
#: the settings before the warm start (five revolutions from today's start): benchmarks compare with them
LEGACY = dict(revolutions=5, max_revolutions=12, trace_revolutions=3)


def cases(valve: str | None = None, table: str | None = None) -> list[dict]:
    """The validation cases, optionally of one valve type or one table ("5.4", "5.6")."""
    out = experiments()
    if valve is not None:
        out = [c for c in out if c["valve"] == valve]
    if table is not None:
        out = [c for c in out if c["table"] == table]
    return out


def case_name(case: dict) -> str:
    """A file-name friendly id, e.g. ``disc_inlet_baseline``."""
    return f"{case['valve']}_{case['measured_valve']}_{case['condition']}"


def thesis_model_of(case: dict) -> PumpModel:
    """The shipped thesis model of the case's valve type."""
    return load_model(f"thesis-{case['valve']}")


def run_case(case: dict, *, params: PumpModel | None = None, quick: bool = False, trace: bool = True,
             progress: bool = False, method: str = "reference", settings: dict | None = None,
             warm: bool = True) -> PumpResult:
    """Simulate one validation case to cyclic steady state (the thesis model unless ``params``).

    ``method``: the stepper of :func:`lumped.run.simulate.simulate`, "reference" (scipy Radau, the
    validation's default) or "fast" (compiled, delivery within 0.1 % of the reference).
    ``settings``: FULL (default), QUICK (``quick``) or LEGACY; ``warm``: the reference starts from
    the fast path's cycle (:func:`lumped.run.warmstart.fast_start`), else from today's start. The
    steady-state test then passes at once, so the run is its ``revolutions`` traced revolutions.
    """
    from lumped.run.revolutions import STEADY_TOL, StopRule
    from lumped.run.warmstart import fast_start

    s = settings or (QUICK if quick else FULL)
    model = params if params is not None else thesis_model_of(case)
    legacy = s is LEGACY
    start = None
    if warm and not legacy and method != "fast":
        start = fast_start(model, case["speed_rpm"], case["load_pressure"], air_content=case["air_content"])
    stop = StopRule(s["revolutions"], s["max_revolutions"], 1e-4 if legacy else STEADY_TOL)
    return simulate(model, case["speed_rpm"], case["load_pressure"], air_content=case["air_content"], stop=stop,
                    trace=trace, trace_revolutions=s["trace_revolutions"], progress=progress, method=method,
                    initial_state=start)


def _run_one(args):
    case, params, run = args
    return run_case(case, params=params, **run)


def run_cases(selected: list[dict], *, params_for=None, progress: bool = False, workers=1, **run) -> list[PumpResult]:
    """Simulate the cases, progress as a count on stderr.

    ``params_for(case) -> PumpModel | None`` overrides the thesis configuration per case; ``workers``: a number of
    processes, or an executor to map the cases on (the validate pipeline's pool); ``run``: :func:`run_case`'s
    keywords for every case (``quick``, ``trace``, ``method``, ``settings``, ``warm``), checked before any case runs.
    """
    unknown = sorted(set(run) - (set(inspect.signature(run_case).parameters) - {"case", "params", "progress"}))
    if unknown:
        raise TypeError(f"run_cases() got unexpected keyword arguments: {', '.join(unknown)}")
    from tqdm import tqdm

    work = [(c, params_for(c) if params_for else None, run) for c in selected]
    results: list[PumpResult] = []
    own = isinstance(workers, int) and workers > 1
    with tqdm(total=len(work), desc="pump cases", unit="case", file=sys.stderr, disable=not progress) as bar, \
            (ProcessPoolExecutor(max_workers=workers) if own else nullcontext(workers)) as ex:
        for r in (map if isinstance(ex, int) else ex.map)(_run_one, work):
            results.append(r)
            bar.update(1)
    return results


def table_rows(selected: list[dict], results: list[PumpResult]) -> list[dict]:
    """Rows of Table 5.4 / 5.6 (CONTRACT keys) with the thesis's modeled values beside ours."""
    rows = []
    for c, r in zip(selected, results):
        modeled = r.delivery_per_rev * 1e6
        measured = c["measured_delivery"] * 1e6
        thesis = c["thesis_modeled_delivery"] * 1e6
        err = (modeled - measured) / measured * 100
        thesis_err = c["thesis_error_pct"]
        rows.append({
            "condition": c["condition"], "measured_valve": c["measured_valve"],
            "speed_rpm": c["speed_rpm"], "load_pressure_pa": c["load_pressure"],
            "air_content": r.air_content,
            "modeled_cc": round(modeled, 5), "measured_cc": measured, "error_pct": round(err, 3),
            "thesis_modeled_cc": thesis, "thesis_error_pct": thesis_err,
            "vs_thesis_model_pct": round((modeled - thesis) / thesis * 100, 3),
            "abs_error_worse_than_thesis_pp": round(abs(err) - abs(thesis_err), 3),
            "cyclic_steady": r.cyclic_steady, "revolutions": r.revolutions,
            "cycle_change": float(f"{r.cycle_change:.2g}"),
        })
    return rows


def reed_parameter_chain(fidelities=("analytic", "beam", "plate", "solid"), quick: bool = False,
                         progress: bool = True) -> dict:
    """Step 1 of ``validate``: the prototype reed's omega_n, kappa, gammas, h_eff by each fidelity.

    Runs :func:`studies.validation.reed_check.multi_fidelity_check` on the prototype reed (``quick``:
    a 2 mm FEA mesh instead of each fidelity's converged default) and returns its rows,
    the selected :class:`~lumped.reed.mode_function.ReedProperties` that would feed the pump model, and why.
    """
    from geometry import load_reed
    from studies.validation.reed_check import multi_fidelity_check

    check = multi_fidelity_check(load_reed("prototype"), fidelities=tuple(fidelities),
                                 mesh_size=QUICK_FEA_MESH if quick else None, progress=progress)
    sel = check["selected"]
    return {"status": "ok", "reason": sel["reason"], "rows": check["rows"], "flagged": check["flagged"],
            "reference": check["reference"], "selected": sel["properties"],
            "tolerance_pct": check["tolerance_pct"]}


#: FEA element size [m] of ``validate --quick`` (coarse: for tests, not for numbers)
QUICK_FEA_MESH = 2.0e-3

#: columns of the reed-parameter table: (row key, column header with units, scale from SI)
REED_TABLE_COLUMNS = (
    ("omega_n", "omega_n [rad/s]", 1.0),
    ("kappa", "kappa [Pa/m]", 1.0),
    ("gamma1", "gamma1 [-]", 1.0),
    ("gamma2", "gamma2 [-]", 1.0),
    ("gamma3", "gamma3 [-]", 1.0),
    ("h_eff", "h_eff [m]", 1.0),
)


def reed_parameter_table(chain: dict) -> tuple[list[dict], list[str]]:
    """Rows and notes of ``out/reed_parameters.{md,csv}``: every fidelity's prototype reed values
    (units in the headers), the thesis's FEA values beside them (omega_n 2523 rad/s, Table 3.3;
    kappa 6.353 MPa/m, section 3.8.1; studies/data/thesis_values.toml) with each fidelity's %
    deviation from them, its % deviation from the check's reference and the check's flags."""
    from studies.tables.thesis import thesis_values

    tv = thesis_values()
    thesis = {"omega_n": tv["table_3_3"]["prototype"]["omega_fea"], "kappa": tv["table_3_13"]["kappa_fea"]}
    selected = chain["selected"].fidelity if chain.get("selected") is not None else None
    rows = []
    for r in chain["rows"]:
        row = {"fidelity": r["fidelity"]}
        for key, head, scale in REED_TABLE_COLUMNS:
            row[head] = r[key] * scale
            if key in thesis:
                row[f"thesis {head}"] = thesis[key] * scale
                row[f"{key} vs thesis [%]"] = round((r[key] - thesis[key]) / thesis[key] * 100.0, 3)
        for key, _, _ in REED_TABLE_COLUMNS[:5]:
            row[f"{key} vs {chain['reference']} [%]"] = round(r["deviation_pct"][key], 3)
        row["flags"] = ", ".join(f"{r['fidelity']}.{q}" for q in r["flags"]) or "-"
        row["feeds the pump"] = "yes" if r["fidelity"] == selected else ""
        row["dofs [-]"] = r["dofs"]
        row["mesh size [m]"] = r["mesh_size"]
        row["seconds [s]"] = r["seconds"]
        rows.append(row)
    nu = None
    try:
        from geometry import load_reed

        nu = load_reed("prototype").material.poisson_ratio
    except Exception:  # pragma: no cover - the preset always loads
        pass
    notes = [
        f"thesis values: the thesis's own FEA of the prototype reed, omega_n = {thesis['omega_n']:g} rad/s "
        f"(Table 3.3) and kappa = {thesis['kappa'] / 1e6:g} MPa/m (section 3.8.1); they are not inputs.",
        f"deviations 'vs {chain['reference']}' are from the check's reference fidelity; a flag marks a "
        f"deviation beyond the check's tolerance ({chain.get('tolerance_pct', 4.0):g} %), as `valvelab check` "
        "raises it.",
        f"the presets use nu = {nu:g} (Delrin datasheet; the thesis never states it): the solid lies about "
        "+1 % in omega_n and +1.5 % in kappa above the thesis's FEA, which nu = 0.3 reproduces within "
        "0.5 % (docs/errata.md).",
        "the plate takes each grooved strip as a thinner plate about its own mid-plane, so it is too soft "
        "for the grooved prototype (docs/errata.md, FEA section).",
        "selected for the pump: " + chain.get("reason", ""),
    ]
    return rows, notes

#: extra column of Table 5.6: the reed cases with Table 5.1's dead volume instead of the inferred one
TABLE_5_1_COLUMN = "modeled_cc_table_5_1_v_tdc"


def table_5_1_dead_volume_model(case: dict) -> PumpModel:
    """The thesis model with Table 5.1's V_tdc (thesis-disc's 2.17e-5 m^3; docs/errata.md, 'Reed pump
    delivery offset')."""
    m = thesis_model_of(case)
    return replace(m, pump=replace(m.pump, dead_volume=load_model("thesis-disc").pump.dead_volume))


def add_table_5_1_column(selected: list[dict], rows: list[dict], quick: bool = False, progress: bool = False,
                        jobs: int = 1, method: str = "fast") -> None:
    """Run the reed cases with Table 5.1's dead volume and add TABLE_5_1_COLUMN to their rows.

    An auxiliary column: by default on the fast path (delivery within 0.1 % of the reference).
    """
    pairs = [(c, r) for c, r in zip(selected, rows) if c["valve"] == "reed"]
    if not pairs:
        return
    res = run_cases([c for c, _ in pairs], params_for=table_5_1_dead_volume_model, quick=quick, trace=False,
                    progress=progress, workers=jobs, method=method, settings=None if quick or method != "fast" else LEGACY)
    for (c, row), r in zip(pairs, res):
        d = r.delivery_per_rev * 1e6
        row[TABLE_5_1_COLUMN] = round(d, 5)
        row["table_5_1_vs_thesis_model_pct"] = round((d - row["thesis_modeled_cc"]) / row["thesis_modeled_cc"] * 100, 3)
        row["table_5_1_error_pct"] = round((d - row["measured_cc"]) / row["measured_cc"] * 100, 3)


def reed_model_from(props) -> PumpModel:
    """Thesis reed pump with kappa, gammas and h_eff of a reed model (Table 3.13 empirical rest)."""
    m = load_model("thesis-reed")
    return replace(m, inlet=m.inlet.with_properties(props), delivery=m.delivery.with_properties(props))


# ----------------------------------------------------------------- output files
def write_table(rows: list[dict], stem: Path, title: str, notes: list[str] = ()) -> list[Path]:
    """Write rows as ``stem.csv`` and ``stem.md`` (Markdown table with notes): a :class:`studies.outputs.Table`."""
    return Table(title, tuple(rows), tuple(notes)).write(stem)


#: what a Table 5.6 geometry-chain column is (the summary's chain section says it once more)
GEOMETRY_NOTE = ("modeled_cc_{fidelity}: the same runs with kappa, gammas and h_eff of the {fidelity} model of the "
                 "prototype reed's geometry (the geometry chain, fast path) instead of Table 3.13's kappa identified "
                 "from the plucked reed's measured frequency; reed_dynamics.md runs this reed too.")
#: a valve position below this [m] is drawn and explained as the seat compressing
SEAT_COMPRESSION_SHOWN = 1e-5


def plot_case(case: dict, result: PumpResult, path: Path) -> Path:
    """:func:`case_figure` saved to ``path`` (PNG)."""
    import matplotlib.pyplot as plt

    fig = case_figure(case, result)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def case_figure(case: dict, result: PumpResult):
    """Valve positions (both valves, the one the thesis measured in this run drawn thicker) and pressures over the
    traced revolutions: the model's version of the thesis figure (the measured traces are not available as data).
    Legends sit outside the axes; a valve below its seat (the disc delivery valve's O-ring, section 5.4.5) is shaded
    and labelled."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = result.trace
    t_ms = tr.time * 1e3
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10.0, 6.4), sharex=True, constrained_layout=True)
    meas = case["measured_valve"]
    for name, pos, color in (("inlet", tr.inlet_position, "tab:blue"), ("delivery", tr.delivery_position, "tab:red")):
        ax1.plot(t_ms, pos * 1e3, color=color, lw=2.0 if name == meas else 0.8,
                 label=_wrap(f"{name} valve, model" + (": the valve whose position the thesis measured in this run"
                                                       if name == meas else "")))
    _seat_compression(ax1, tr, case)
    ax1.set_ylabel("valve position [mm]")
    ax1.axhline(0.0, color="k", lw=0.5)
    ax1.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=8)
    fig_no = FIGURES.get((case["valve"], meas, case["condition"]), "")
    fig.suptitle(f"{case['valve']} valves, {case['condition'].replace('_', ' ')}: {case['speed_rpm']:.0f} rpm, "
                 f"{case['load_pressure'] / 1e6:.2f} MPa\nthe model's version of thesis Figure {fig_no} (the measured "
                 "traces are not available as data: only the model is drawn)", fontsize=9)
    ax2.plot(t_ms, tr.cylinder_pressure / 1e6, color="k", lw=1.0, label="cylinder pressure, model")
    ax2.plot(t_ms, tr.load_pressure / 1e6, color="tab:gray", lw=1.0, ls="--",
             label=_wrap("load pressure, constant (the simplified circuit, section 4.2.2)"))
    ax2.set_ylabel("pressure [MPa]")
    ax2.set_xlabel("time from top dead centre [ms]")
    ax2.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=8)
    return fig


def _seat_compression(ax, tr, case: dict) -> None:
    """Shade and label where a valve sits below its seat: the compliant seat compressing (for the disc delivery
    valve its housing's O-ring, section 5.4.5, modelled by the seat stiffness of section 2.4.3.2)."""
    for name, pos in (("delivery", tr.delivery_position), ("inlet", tr.inlet_position)):
        low = float(pos.min())
        if low > -SEAT_COMPRESSION_SHOWN:
            continue
        why = ("its housing's O-ring compressing (not fully seated, section 5.4.5)" if case["valve"] == "disc"
               and name == "delivery" else "the seat's compliance")
        ax.axhspan(low * 1e3, 0.0, color="tab:orange", alpha=0.15,
                   label=_wrap(f"{name} valve below its seat, down to {low * 1e3:.2f} mm: {why}"))


def _wrap(text: str, width: int = 38) -> str:
    """A legend label in lines of at most ``width`` characters (the legends sit beside the axes)."""
    import textwrap

    return "\n".join(textwrap.wrap(text, width))


def error_summary(rows: list[dict]) -> dict:
    """Mean/max absolute error vs measured, ours and the thesis's, and the largest gap to the thesis's model."""
    if not rows:
        return {}
    ours = [abs(r["error_pct"]) for r in rows]
    th = [abs(r["thesis_error_pct"]) for r in rows]
    gap = [abs(r["vs_thesis_model_pct"]) for r in rows]
    return {
        "mean_abs_error_pct": round(sum(ours) / len(ours), 3), "max_abs_error_pct": round(max(ours), 3),
        "thesis_mean_abs_error_pct": round(sum(th) / len(th), 3), "thesis_max_abs_error_pct": round(max(th), 3),
        "max_abs_diff_from_thesis_model_pct": round(max(gap), 3),
        "worst_vs_thesis_pp": round(max(r["abs_error_worse_than_thesis_pp"] for r in rows), 3),
    }


def default_jobs() -> int:
    """Processes for the case runs: one per core (at most 4) unless VALVELAB_JOBS says otherwise."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    try:
        return max(1, int(os.environ.get("VALVELAB_JOBS", str(min(4, cores)))))
    except ValueError:
        return 1

