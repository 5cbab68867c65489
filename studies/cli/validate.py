"""``valvelab validate``: the multi-fidelity chain and the 12 pump cases of chapter 5, written to ``out/``.

Steps: 1. reed parameters, analytic vs FEA (``studies.validation.reed_check``), with the V&V 20
table of the analytic model against each FEA fidelity, and the one-mode reed (eq 3.21) against N modes
and the whole FE reed in the pump (``studies.validation.reed_dynamics.prototype_adequacy``); 2. the 12 pump cases of Tables 5.4 and
5.6 to cyclic steady state, with their numerical, input and measurement uncertainty (ASME
V&V 20, ``studies.validation.vv20``); 3. tables (Markdown and CSV) and plots (valve positions
and pressures over three revolutions, the model's Figures 5.7-5.21; E with U_val); 4. a summary
of errors vs measured and vs the thesis's model, and the verdicts.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from geometry.errors import InputError
from studies.cli import flags
from studies.outputs import finite_or_none

HELP = "run the full validation (reed parameters, 12 pump cases) and write tables and plots to out/"


def configure(p):
    p.add_argument("--out", default="out", help="output folder (default out/)")
    p.add_argument("--quick", action="store_true", help="fewer revolutions, one traced revolution, coarse FEA (tests)")
    p.add_argument("--force", action="store_true", help="write into a non-empty folder valvelab did not create")
    p.add_argument("--jobs", type=flags.integer(1, 256), default=None,
                   help="processes for the pump cases, the reed chain and the plots (default one per core, at most 4, "
                        "or $VALVELAB_JOBS)")
    p.add_argument("--valve", choices=("disc", "reed"), default=None, help="only the cases of one valve type")
    p.add_argument("--skip-reed-chain", action="store_true", help="skip step 1 (reed parameters by fidelity)")
    p.add_argument("--no-uncertainty", action="store_true",
                   help="skip the validation uncertainty (u_num, u_input, u_D and the V&V 20 tables)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="dask scheduler for the Monte Carlo of u_input (default: a local cluster; --quick: this process)")
    p.add_argument("--workers", type=flags.integer(1, 256), default=None,
                   help="local dask workers for the Monte Carlo (default: one per core)")


def _log(msg: str) -> None:
    sys.stderr.write(msg + "\n")
    sys.stderr.flush()


def _reed_step(quick: bool, uncertainty: bool, progress: bool) -> tuple[dict, object]:
    """Step 1: the reed parameters by fidelity and (with the uncertainty) the V&V 20 table of the analytic model
    against each FEA fidelity; runs beside the pump cases (in a process of its own when there are jobs)."""
    from studies.validation import chain as V

    chain = V.reed_parameter_chain(quick=quick, progress=progress)
    reed_table = None
    if chain["rows"] and uncertainty and len(chain["rows"]) > 1:
        from geometry import load_reed
        from studies.validation.vv20 import reed_validation

        if progress:
            _log("  V&V 20: analytic against each FEA fidelity (GCI of each mesh, thickness tolerance)")
        reed_table = reed_validation(load_reed("prototype"), chain["rows"], quick=quick, progress=progress)
    return chain, reed_table


def run(args) -> dict:
    from concurrent.futures import ProcessPoolExecutor

    jobs = None if args.jobs is None else args.jobs
    if jobs is not None and jobs < 1:
        raise InputError("--jobs", f"must be at least 1, got {jobs}")
    if args.scheduler is not None and args.workers is not None:
        raise InputError("--workers", "applies to the local cluster only; the scheduler at --scheduler has its own")
    from studies.validation import chain as V

    jobs = V.default_jobs() if jobs is None else jobs
    # the pump cases, the reed chain (its FEA) and the plots share one pool of processes
    pool = ProcessPoolExecutor(max_workers=jobs) if jobs > 1 else None
    try:
        return _run(args, jobs, pool)
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)


def _run(args, jobs: int, pool) -> dict:
    from studies.validation import chain as V
    from studies.outputs import prepare_output_dir
    from studies.tables.pump import REED_NOTE, table_2_3

    uncertainty = not args.no_uncertainty
    out = prepare_output_dir(args.out, "--out", args.force, kind="validate")
    t_start = time.time()
    summary: dict = {"out": str(out), "quick": bool(args.quick), "steps": {}}
    files = []
    reed_table = None

    # 1. reed parameters by fidelity (beside step 2 when there is a pool)
    chain = {"status": "skipped", "reason": "--skip-reed-chain", "rows": [], "selected": None}
    reed_future = None
    if not args.skip_reed_chain and args.valve != "disc":
        _log("step 1/4: reed parameters of the prototype reed, analytic vs FEA"
             + (" (beside step 2)" if pool is not None else ""))
        if pool is not None:
            reed_future = pool.submit(_reed_step, args.quick, uncertainty, False)
        else:
            chain, reed_table = _reed_step(args.quick, uncertainty, True)

    # 2. the pump cases
    selected = V.cases(valve=args.valve)
    _log(f"step 2/4: {len(selected)} pump cases to cyclic steady state ({'quick' if args.quick else 'full'}), "
         "each from the fast path's cycle")
    results = V.run_cases(selected, quick=args.quick, progress=True, jobs=jobs, pool=pool)
    plots = []
    for c, r in zip(selected, results):
        fig = V.FIGURES[(c["valve"], c["measured_valve"], c["condition"])]
        path = out / f"fig_{fig.replace('.', '_')}_{V.case_name(c)}.png"
        plots.append(pool.submit(V.plot_case, c, r, path) if pool is not None else (c, r, path))
    if reed_future is not None:
        chain, reed_table = reed_future.result()
    if chain["status"] not in ("ok", "skipped"):
        _log(f"  {chain['reason']}: the pump uses Table 3.13 only")
    if chain["rows"]:
        if reed_table is not None:
            files += reed_table.write(out / "reed_validation")
            files.append(reed_table.plot(out / "reed_validation.png", relative=True))
        rows, notes = V.reed_parameter_table(chain)
        if reed_table is not None:                  # each FEA value's GCI band beside it
            from fea.convergence import GCI_STANDARD_FACTOR

            band = {(r["case"].split("/")[-1], r["output"]): r["u_num"] * GCI_STANDARD_FACTOR / abs(r["D"]) * 100
                    for r in reed_table.rows}
            for row in rows:
                for q in ("omega_n", "kappa", "gamma1", "gamma2", "gamma3"):
                    b = band.get((row["fidelity"], q))
                    row[f"{q} GCI [%]"] = None if b is None else round(b, 4)
            notes.append("GCI [%]: the band of each FEA value at its mesh (meshes 2h, h, h/2; Celik et al. 2008); "
                         "reed_validation.md compares each fidelity with the analytic model (ASME V&V 20).")
        V.write_table([_plain(r) for r in rows], out / "reed_parameters",
                      "Prototype reed parameters by fidelity (step 1), beside the thesis's FEA", notes)
    summary["reed_dynamics"] = _reed_dynamics(args, out, files)
    sel = chain["selected"]
    summary["steps"]["reed_parameters"] = {
        "status": chain["status"], "reason": chain["reason"], "fidelities": len(chain["rows"]),
        "flagged": list(chain.get("flagged", [])),
        "selected": None if sel is None else {
            "fidelity": sel.fidelity,
            **{k: finite_or_none(getattr(sel, k)) for k in ("omega_n", "kappa", "gamma1", "gamma2", "gamma3", "h_eff")}},
    }

    geo_results = {}
    reed_sel = [c for c in selected if c["valve"] == "reed"]
    if sel is not None and reed_sel:
        _log(f"  and the {len(reed_sel)} reed cases with kappa, gammas, h_eff of the {sel.fidelity} model")
        model = V.reed_model_from(sel)
        # an auxiliary column: the fast path (within 0.1 %), cheap in this process; five revolutions from
        # today's start as ever (its last digits are the fast path's revolution-to-revolution noise)
        rs = V.run_cases(reed_sel, params_for=lambda c: model, quick=args.quick, trace=False, progress=True,
                         method="fast", settings=None if args.quick else V.LEGACY)
        geo_results = {V.case_name(c): r for c, r in zip(reed_sel, rs)}
    pump_table = extra = None
    t_unc = time.time()
    if uncertainty:
        _log("  validation uncertainty: u_num (tolerance ladder), u_input (Monte Carlo), u_D (paired runs)"
             + (" - quick: cheaper and coarser" if args.quick else ""))
        pump_table, extra = _pump_uncertainty(args, selected, results)

    # 3. tables and plots
    _log("step 3/4: tables and plots")
    tables = {}
    for table, valve in (("5.4", "disc"), ("5.6", "reed")):
        pairs = [(c, r) for c, r in zip(selected, results) if c["table"] == table]
        if not pairs:
            continue
        rows = V.table_rows([c for c, _ in pairs], [r for _, r in pairs])
        for row, (c, _) in zip(rows, pairs):
            g = geo_results.get(V.case_name(c))
            if g is not None:
                row[f"modeled_cc_{sel.fidelity}"] = round(g.delivery_per_rev * 1e6, 5)
        notes = []
        if valve == "reed":
            _log("  reed cases again with Table 5.1's dead volume (docs/errata.md)")
            V.add_table_5_1_column([c for c, _ in pairs], rows, quick=args.quick, progress=True)
            notes = [REED_NOTE]
        files += V.write_table(rows, out / f"table_{table.replace('.', '_')}",
                               f"Table {table}: {valve} valve pump delivery (cc/rev)", notes)
        tables[table] = rows
    t23 = table_2_3()
    files += V.write_table(t23["rows"], out / "table_2_3", "Table 2.3: disc valve parameters", t23["notes"])
    for p in plots:
        files.append(p.result() if pool is not None else V.plot_case(*p))

    if args.valve != "reed":      # the disc's fluid references (studies.validation.fluid)
        from studies.validation.fluid import fluid_validation

        _log("  fluid references: the disc's fluid parameters; Table 5.4 with fluid = \"predicted\"")
        fl = fluid_validation(out, quick=args.quick, progress=True)
        summary.update(fluid_validation=fl["fluid_validation"], fluid_pump=fl["fluid_pump"])
        files += [Path(f) for f in fl["files"]]

    # 4. summary
    _log("step 4/4: summary")
    cpu = {}
    for valve in ("disc", "reed"):
        rs = [r for c, r in zip(selected, results) if c["valve"] == valve]
        if rs:
            cpu[valve] = round(float(sum(r.cpu_seconds for r in rs) / sum(r.simulated_seconds for r in rs)), 2)
    summary["steps"]["pump_cases"] = {
        "cases": len(selected), "all_cyclic_steady": all(r.cyclic_steady for r in results),
        "max_mass_balance_error": max(r.mass_balance_error for r in results),
        "cpu_seconds_per_simulated_second": cpu,
    }
    summary["tables"] = {t: V.error_summary(rows) for t, rows in tables.items()}
    # the validity envelope (lumped.validity) of every case: none is expected on the thesis's own cases
    summary["warnings"] = [{"code": w.code, "message": f"{V.case_name(c)}: {w.message}"}
                           for c, r in [*zip(selected, results), *((c, geo_results[V.case_name(c)]) for c in reed_sel
                                                                   if V.case_name(c) in geo_results)]
                           for w in r.warnings]
    if "5.6" in tables and all(V.TABLE_5_1_COLUMN in r for r in tables["5.6"]):
        summary["tables"]["5.6"]["table_5_1_dead_volume_max_abs_diff_from_thesis_model_pct"] = round(
            max(abs(r["table_5_1_vs_thesis_model_pct"]) for r in tables["5.6"]), 3)
    summary["cases"] = [
        {"table": c["table"], "case": V.case_name(c), "modeled_cc": round(r.delivery_per_rev * 1e6, 5),
         "measured_cc": c["measured_delivery"] * 1e6, "thesis_modeled_cc": c["thesis_modeled_delivery"] * 1e6,
         "peak_opening_mm": [round(v.peak_opening * 1e3, 4) for v in r.valves.values()],
         "stop_contacts": [v.stop_contacts for v in r.valves.values()]}
        for c, r in zip(selected, results)
    ]
    if pump_table is not None:
        files += pump_table.write(out / "validation")
        files.append(pump_table.plot(out / "validation.png"))
    summary["validation"] = pump_table.to_json() if pump_table is not None else []
    summary["reed_validation"] = reed_table.to_json() if reed_table is not None else []
    summary["area_metric"] = dict(pump_table.area_metric) if pump_table is not None else {"disc": None, "reed": None}
    if uncertainty:
        summary["uncertainty"] = {
            "quick": bool(args.quick),
            "note": ("cheaper: a two-level tolerance ladder (Fs = 3), 64 draws per case, two FEA meshes (Fs = 3); "
                     "run without --quick for the full estimate") if args.quick else
                    "tolerance ladder of three levels (GCI, Fs = 1.25), draws until u_input is known within 10 %, "
                    "FEA meshes 2h, h, h/2",
            "draws": extra["draws"] if extra else {}, "worst_u_input_precision": extra["worst_precision"] if extra else None,
            "predictions": extra["predictions"] if extra else {}, "measurement": extra["measurement"] if extra else {},
            "area_metric_detail": extra["area_metric_detail"] if extra else {},
            "wall_seconds": round(time.time() - t_unc, 1) if extra else None,
        }
    summary["wall_seconds"] = round(time.time() - t_start, 1)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "summary.md").write_text(_summary_md(summary))
    summary["files"] = sorted(str(Path(f).name) for f in files) + ["summary.json", "summary.md"]
    return summary


def _reed_dynamics(args, out: Path, files: list) -> dict:
    """Step 1's pump check of the prototype reed: eq 3.21 against N modes and the whole FE reed
    (studies.validation.reed_dynamics.prototype_adequacy), written to reed_dynamics.{md,csv}."""
    if args.skip_reed_chain or args.valve == "disc":
        return {"status": "skipped", "reason": "--skip-reed-chain" if args.skip_reed_chain else "--valve disc"}
    from studies.validation import reed_dynamics as rd

    _log("  the prototype reed in the pump: eq 3.21 against 1, 2, 3, 6 modes"
         + (" (quick: no FE reed)" if args.quick else " and the whole FE reed (one case of Table 5.6)"))
    t0 = time.time()
    result = rd.prototype_adequacy(quick=args.quick, progress=True)
    files += rd.write_adequacy(result, out / "reed_dynamics")
    return {"status": "ok", "verdict": rd.adequacy_words(result), **result, "wall_seconds": round(time.time() - t0, 1)}


def _pump_uncertainty(args, selected, results):
    """The V&V 20 table of the pump cases; the Monte Carlo on dask (--quick: in this process unless a cluster is named)."""
    from studies.sweeps.design.runner import Cluster
    from studies.validation.vv20 import pump_validation

    local = args.quick and args.scheduler is None and args.workers is None
    cluster = None if local else Cluster(scheduler=args.scheduler, workers=args.workers)
    try:
        if cluster is not None:
            cluster.check_reachable()
        return pump_validation(selected, results, quick=args.quick, cluster=cluster, progress=True)
    finally:
        if cluster is not None:
            cluster.close()


def _plain(row) -> dict:
    """A step-1 row as plain numbers/strings (rows may carry arrays or dataclasses)."""
    if hasattr(row, "as_contract"):
        row = row.as_contract("prototype")
    elif not isinstance(row, dict):
        row = dict(getattr(row, "__dict__", {}))
    return {k: (v if isinstance(v, (str, bool)) or v is None else finite_or_none(v)) for k, v in row.items()
            if not hasattr(v, "__len__") or isinstance(v, str)}


def _summary_md(s: dict) -> str:
    lines = ["# valvelab validate: summary", ""]
    rp = s["steps"]["reed_parameters"]
    lines.append(f"1. Reed parameters: {rp['status']} {('(' + rp['reason'] + ')') if rp['reason'] else ''}")
    if rp["selected"]:
        sel = rp["selected"]
        lines.append(f"   selected {sel['fidelity']}: kappa = {sel['kappa'] / 1e6:.4f} MPa/m, "
                     f"gamma1 = {sel['gamma1']:.4f}, h_eff = {sel['h_eff'] * 1e3:.4f} mm")
    rd = s.get("reed_dynamics", {})
    if rd.get("status") == "ok":
        lines.append(f"   in the pump: {rd['verdict']}; {rd['note']} (reed_dynamics.md)")
    pc = s["steps"]["pump_cases"]
    lines.append(f"2. Pump cases: {pc['cases']}, all cyclic steady: {pc['all_cyclic_steady']}, "
                 f"max mass-balance error {pc['max_mass_balance_error']:.1e}, CPU s per simulated s "
                 + ", ".join(f"{k} {v}" for k, v in pc["cpu_seconds_per_simulated_second"].items())
                 + " (thesis: 23)")
    lines.append("3. Tables: " + ", ".join(f"Table {t}" for t in s["tables"]) + " (Markdown and CSV), Table 2.3")
    lines += ["4. Errors (percent):", "",
              "| table | mean abs error | max abs error | thesis mean | thesis max | max diff from thesis model |",
              "|---|---|---|---|---|---|"]
    for t, e in s["tables"].items():
        lines.append(f"| {t} | {e['mean_abs_error_pct']} | {e['max_abs_error_pct']} | {e['thesis_mean_abs_error_pct']} "
                     f"| {e['thesis_max_abs_error_pct']} | {e['max_abs_diff_from_thesis_model_pct']} |")
    inf = s["tables"].get("5.6", {}).get("table_5_1_dead_volume_max_abs_diff_from_thesis_model_pct")
    if inf is not None:
        lines += ["", f"Table 5.6 with Table 5.1's dead volume (2.17e-5 m^3) instead of the inferred reed-manifold "
                      f"4.0e-5 m^3 (docs/errata.md): largest difference from the thesis's modeled deliveries {inf} %."]
    lines += ["", "| case | modeled | measured | thesis model | peak opening in/del (mm) | stop contacts |",
              "|---|---|---|---|---|---|"]
    for c in s["cases"]:
        lines.append(f"| {c['case']} | {c['modeled_cc']:.4f} | {c['measured_cc']:.3f} | {c['thesis_modeled_cc']:.3f} "
                     f"| {c['peak_opening_mm'][0]:.3f} / {c['peak_opening_mm'][1]:.3f} | {c['stop_contacts']} |")
    if s.get("validation") or s.get("reed_validation"):
        u = s.get("uncertainty", {})
        lines += ["", "## Validation uncertainty (ASME V&V 20)", "",
                  f"{'Quick, ' + u['note'] if u.get('quick') else 'Full: ' + u.get('note', '')}. "
                  "Tables: validation.md (pump cases), reed_validation.md (reed parameters).", ""]
        for r in s.get("validation", []):
            lines.append(f"- {r['case']}: E = {r['E']:+.4f} {r['unit']} ({r['E'] / r['D'] * 100:+.2f} %), "
                         f"{r['words']}; largest input: "
                         + (", ".join(f"{a} {b:.2g}" for a, b in r["contributors"]) or "none"))
        am = s.get("area_metric", {})
        if any(v is not None for v in am.values()):
            lines.append("- area validation metric (u-pooling): "
                         + ", ".join(f"{k} {v:.4g} cc/rev" for k, v in am.items() if v is not None))
        bad = [r for r in s.get("reed_validation", []) if r["verdict"] != "within"]
        if s.get("reed_validation"):
            lines.append(f"- reed parameters: {len(bad)} of {len(s['reed_validation'])} comparisons show a model-form "
                         "error: " + (", ".join(f"{r['case']} {r['output']}" for r in bad) or "none"))
    lines += ["", f"Wall time {s['wall_seconds']} s."]
    return "\n".join(lines) + "\n"


def render(s: dict) -> str:
    out = [f"validation written to {s['out']}/"]
    if s.get("reed_dynamics", {}).get("status") == "ok":
        out.append(f"  {s['reed_dynamics']['verdict']}")
    pc = s["steps"]["pump_cases"]
    out.append(f"  {pc['cases']} pump cases, all cyclic steady: {pc['all_cyclic_steady']}, "
               "CPU s per simulated s: " + ", ".join(f"{k} {v:.2f}" for k, v in pc["cpu_seconds_per_simulated_second"].items()))
    for t, e in s["tables"].items():
        out.append(f"  Table {t}: mean |error| {e['mean_abs_error_pct']} % (thesis {e['thesis_mean_abs_error_pct']} %), "
                   f"max diff from the thesis's model {e['max_abs_diff_from_thesis_model_pct']} %")
    if s.get("validation"):
        n_bad = sum(r["verdict"] != "within" for r in s["validation"])
        out.append(f"  V&V 20: {len(s['validation']) - n_bad} of {len(s['validation'])} pump cases within the validation "
                   f"uncertainty" + (" (quick: cheaper estimate)" if s.get("uncertainty", {}).get("quick") else ""))
    out.append(f"  {len(s['files'])} files, {s['wall_seconds']} s")
    return "\n".join(out)
