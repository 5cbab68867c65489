"""``valvelab validate``'s summary: what the data can detect first, then the chain (which reed parameters fed which
pump case), the tables and the verdicts, in JSON (summary.json), Markdown (summary.md) and on the console.

Every number here is taken from the step that computed it (the procedure's rows, the tables, the reed chain), so
summary.md, validation.md, prediction.md and reed_dynamics.md agree; where two of them give different numbers for
one case (the thesis's printed reed parameters against the geometry chain's), the chain section says why.
"""

from __future__ import annotations

from studies.outputs import finite_or_none


def reed_parameter_rows(chain: dict, reed_table) -> tuple[list[dict], list[str]]:
    """reed_parameters.{md,csv}: every fidelity's values (studies.validation.chain.reed_parameter_table) and, with
    the V&V 20 table, each FEA value's GCI band beside it."""
    from studies.validation import chain as V

    rows, notes = V.reed_parameter_table(chain)
    if reed_table is not None:
        from fea.convergence import GCI_STANDARD_FACTOR

        band = {(r["case"].split("/")[-1], r["output"]): r["u_num"] * GCI_STANDARD_FACTOR / abs(r["D"]) * 100
                for r in reed_table.rows}
        for row in rows:
            for q in ("omega_n", "kappa", "gamma1", "gamma2", "gamma3"):
                b = band.get((row["fidelity"], q))
                row[f"{q} GCI [%]"] = None if b is None else round(b, 4)
        notes.append("GCI [%]: the band of each FEA value at its mesh (meshes 2h, h, h/2; Celik et al. 2008); "
                     "reed_validation.md compares each fidelity with the analytic model (ASME V&V 20).")
    plain = []
    for row in rows:
        plain.append({k: (v if isinstance(v, (str, bool)) or v is None else finite_or_none(v)) for k, v in row.items()
                      if not hasattr(v, "__len__") or isinstance(v, str)})
    return plain, notes


# --------------------------------------------------------------------------- summary.json
def build_summary(s: dict, state: dict) -> None:
    """Fill the summary dict from the steps' results (``state`` of the run)."""
    from studies.validation import chain as V

    selected, results, geo = state["selected"], state["results"], state.get("geometry", {})
    cpu = {}
    for valve in ("disc", "reed"):
        rs = [r for c, r in zip(selected, results) if c["valve"] == valve]
        if rs:
            cpu[valve] = round(float(sum(r.cpu_seconds for r in rs) / sum(r.simulated_seconds for r in rs)), 2)
    s["steps"]["pump_cases"] = {
        "cases": len(selected), "all_cyclic_steady": all(r.cyclic_steady for r in results),
        "max_mass_balance_error": max(r.mass_balance_error for r in results),
        "cpu_seconds_per_simulated_second": cpu, "stepper": "reference (scipy Radau, rtol 1e-6)",
    }
    tables = state.get("tables", {})
    s["tables"] = {t: V.error_summary(rows) for t, rows in tables.items()}
    if "5.6" in tables and all(V.TABLE_5_1_COLUMN in r for r in tables["5.6"]):
        s["tables"]["5.6"]["table_5_1_dead_volume_max_abs_diff_from_thesis_model_pct"] = round(
            max(abs(r["table_5_1_vs_thesis_model_pct"]) for r in tables["5.6"]), 3)
    s["warnings"] = [{"code": w.code, "message": f"{V.case_name(c)}: {w.message}"}
                     for c, r in [*zip(selected, results), *((c, geo[V.case_name(c)]) for c in selected
                                                              if V.case_name(c) in geo)]
                     for w in r.warnings]
    s["cases"] = [
        {"table": c["table"], "case": V.case_name(c), "modeled_cc": round(r.delivery_per_rev * 1e6, 5),
         "measured_cc": c["measured_delivery"] * 1e6, "thesis_modeled_cc": c["thesis_modeled_delivery"] * 1e6,
         "peak_opening_mm": [round(v.peak_opening * 1e3, 4) for v in r.valves.values()],
         "stop_contacts": [v.stop_contacts for v in r.valves.values()]}
        for c, r in zip(selected, results)]
    s["chain"] = chain_statement(s, state)
    _uncertainty(s, state)


def _uncertainty(s: dict, state: dict) -> None:
    table, extra, reed_table = state.get("pump_table"), state.get("extra"), state.get("reed_table")
    s["validation"] = table.to_json() if table is not None else []
    s["reed_validation"] = reed_table.to_json() if reed_table is not None else []
    s["area_metric"] = dict(table.area_metric) if table is not None else {"disc": None, "reed": None}
    for key in ("calibration", "prediction", "differences", "detectable_error", "rig_tests", "repeatability"):
        s[key] = extra[key] if extra else ([] if key not in ("detectable_error", "repeatability") else {})
    if extra is None:
        return
    quick = s["quick"]
    s["uncertainty"] = {
        "quick": quick,
        "note": ("cheaper: a two-level tolerance ladder (Fs = 3), 64 joint draws per rig, two FEA meshes (Fs = 3); "
                 "run without --quick for the full estimate") if quick else
                "tolerance ladder of three levels (GCI, Fs = 1.25), 512 joint draws per rig, FEA meshes 2h, h, h/2",
        "draws": extra["draws"], "worst_u_input_precision": extra["worst_precision"],
        "predictions": extra["predictions"], "measurement": extra["measurement"],
        "area_metric_detail": extra["area_metric_detail"], "wall_seconds": round(state.get("t_unc", 0.0), 1)}


def chain_statement(s: dict, state: dict) -> list[dict]:
    """Which reed parameters fed which pump case, once, with the numbers that differ between them and why."""
    from studies.validation.chain import case_name
    from studies.validation.reed_dynamics import VALIDATE_CASE

    out = [{"what": "S of every V&V 20 table (validation, prediction, differences) and Tables 5.4, 5.6 modeled_cc",
            "cases": [case_name(c) for c in state["selected"]], "model": "thesis-disc, thesis-reed",
            "reed_parameters": "the thesis's printed ones (Table 3.13: kappa identified from the plucked reed's "
                               "measured frequency by eq 3.73, Table 3.10; f1, f2 tuned in section 5.5.3)",
            "why": "the pump model is judged with its best-known inputs: the measured reed, not the nominal geometry"}]
    sel = state["chain"]["selected"]
    geo = state.get("geometry", {})
    if sel is None or not geo:
        return out
    out.append({"what": f"Table 5.6 modeled_cc_{sel.fidelity}", "cases": sorted(geo),
                "model": f"thesis-reed with kappa, gammas, h_eff of the {sel.fidelity} model of the prototype's geometry",
                "reed_parameters": f"{sel.fidelity}: kappa {sel.kappa / 1e6:.4f} MPa/m against Table 3.13's "
                                   f"{_thesis_kappa() / 1e6:.4f} MPa/m identified from the measured frequency",
                "why": "the geometry chain's prediction of the same runs (fast path), beside the validated model"})
    rd = s.get("reed_dynamics", {})
    if rd.get("status") == "ok":
        name = "reed_" + "_".join(reversed(VALIDATE_CASE.rsplit("_", 1)))      # high_speed_delivery -> reed_delivery_high_speed
        one = next((r["delivery_cc"] for r in rd["rows"] if r["model"] == "one-mode"), None)
        g = geo.get(name)
        thesis = next((c["modeled_cc"] for c in s["cases"] if c["case"] == name), None)
        out.append({"what": "reed_dynamics.md (one case: " + name + ")", "cases": [name],
                    "model": "thesis-reed with the prototype's geometry at both valves (eq 3.21, modal, FE reed)",
                    "reed_parameters": "the geometry chain's (the reed geometry itself)",
                    "one_mode_delivery_cc": None if one is None else round(one, 5), "geometry_chain_delivery_cc": None if g is None else
                    round(g.delivery_per_rev * 1e6, 5), "thesis_parameters_delivery_cc": thesis,
                    "why": "its one-mode row is the geometry chain's reed (it equals modeled_cc_"
                           f"{sel.fidelity} there); the thesis parameters' {thesis} cc differs by the stiffer identified "
                           "kappa"})
    return out


def _thesis_kappa() -> float:
    from lumped.model.model_file import load_model

    return load_model("thesis-reed").inlet.stiffness


# --------------------------------------------------------------------------- words
def _pct(x, spec: str = ".1f") -> str:
    return "n/a" if x is None else f"{x:{spec}} %"


def detectable_lines(s: dict) -> list[str]:
    """What the data can detect, per rig (the summary's first lines)."""
    out = []
    for valve, d in s.get("detectable_error", {}).items():
        out.append(f"{valve}: a model-form error in delivery common to the predicted runs is detected with 80 % "
                   f"probability from {_pct(d['rig'])} (rig test), in one predicted run from {_pct(d['case'])}; "
                   f"without the calibration (the air content's prior range) from {_pct(d['uncalibrated_rig'])} and "
                   f"{_pct(d['uncalibrated_case'])}")
    return out


def calibration_lines(s: dict) -> list[str]:
    out = []
    for e in s.get("calibration", []):
        if e.get("u") is None:
            out.append(f"{e['parameter']} = {e['value']:g} ({e['rig']} rig): {e['how']}")
            continue
        out.append(f"{e['parameter']} ({e['rig']} rig) = {e['value']:.4g} +- {e['u']:.2g} (standard), fitted to "
                   f"{', '.join(e['runs'])}; prior {e['prior']:.4g} +- {e['prior_u']:.2g}"
                   + ("" if e["within_prior"] else " (outside the prior's range)"))
    return out


def _verdicts(rows: list[dict], relative: bool = True) -> str:
    """"n of m within U_val" and each model-form error with E and U_val (in % of D, or in the row's unit)."""
    bad = [r for r in rows if r["verdict"] != "within"]
    text = f"{len(rows) - len(bad)} of {len(rows)} within U_val"

    def size(r):
        if relative:
            return f"E {r['E'] / r['D'] * 100:+.2f} %, U_val {r['U_val'] / r['D'] * 100:.2f} %"
        return f"E {r['E']:+.4f} {r['unit']}, U_val {r['U_val']:.4f} {r['unit']}"

    if bad:
        text += "; model-form error: " + ", ".join(
            f"{r['case']} ({size(r)}" + (", suspect run" if r.get("suspect") else "") + ")" for r in bad)
    return text


def result_lines(s: dict) -> list[str]:
    """Predictions, rig tests, differences and the nominal-input rows in words, each verdict with its numbers."""
    out = []
    if s.get("prediction"):
        out.append("predicted runs (not used to calibrate): " + _verdicts(s["prediction"]))
    for t in s.get("rig_tests", []):
        verdict = "within" if t["verdict"] == "within" else "a model-form error"
        out.append(f"{t['case']}: one common model-form error E = {t['E']:+.2f} % of the delivery, U_val "
                   f"{t['U_val']:.2f} %: {verdict} (chi-square {t['chi2']:.2f} on {t['chi2_dof']} runs, "
                   f"p = {t['chi2_p']:.2g})")
    if s.get("differences"):
        out.append("differences between conditions: " + _verdicts(s["differences"], relative=False))
    if s.get("validation"):
        out.append("each run at the nominal inputs: " + _verdicts(s["validation"])
                   + " (the runs of a rig share the air content: not independent verdicts)")
    rep = s.get("repeatability") or {}
    if rep.get("s_pct") is not None:
        lo, hi = rep["s_interval_95_pct"]
        out.append(f"repeatability of one run: s = {rep['s_pct']:.2f} % ({rep['dof']} dof, sigma within {lo:.2f}-"
                   f"{hi:.2f} % at 95 %), pooled over both rigs (F = {rep['F']:.2f}, p = {rep['p']:.2f}); "
                   + ", ".join(rep.get("suspect", {})) + " left out (section 5.4.4)")
    return out


def summary_markdown(s: dict) -> str:
    lines = ["# valvelab validate: summary", ""]
    if s.get("detectable_error"):
        lines += ["## What the data can detect (ASME V&V 20)", ""]
        lines += [f"- {x}" for x in detectable_lines(s) + calibration_lines(s) + result_lines(s)]
        lines += ["", "Tables: prediction.md (calibration, predicted runs, rig tests), differences.md, validation.md "
                  "(each run), validation.png (E with U_val per case).", ""]
    lines += ["## The chain: which reed parameters fed which pump case", ""]
    for c in s.get("chain", []):
        lines.append(f"- {c['what']}: {c['model']}; reed parameters: {c['reed_parameters']}. Why: {c['why']}.")
        if "one_mode_delivery_cc" in c:
            lines.append(f"  Delivery there: one mode {c['one_mode_delivery_cc']} cc/rev (reed_dynamics.md), the geometry "
                         f"chain {c['geometry_chain_delivery_cc']} (Table 5.6), the thesis's parameters "
                         f"{c['thesis_parameters_delivery_cc']} (Table 5.6 modeled_cc, the V&V 20 S).")
    lines += [""] + _reed_lines(s) + _case_lines(s)
    lines += ["", f"Wall time {s['wall_seconds']} s."]
    return "\n".join(lines) + "\n"


def _reed_lines(s: dict) -> list[str]:
    rp = s["steps"].get("reed_parameters", {})
    out = ["## Reed parameters of the prototype reed", ""]
    if not rp or rp.get("status") == "skipped":
        return out + [f"Skipped ({rp.get('reason', '')}).", ""]
    sel = rp.get("selected")
    if sel:
        out.append(f"- selected for the geometry chain: {sel['fidelity']}, kappa = {sel['kappa'] / 1e6:.4f} MPa/m, "
                   f"gamma1 = {sel['gamma1']:.4f}, h_eff = {sel['h_eff'] * 1e3:.4f} mm ({rp['reason']}: a tolerance "
                   "check, not a V&V 20 verdict)")
    rv = s.get("reed_validation", [])
    if rv:
        bad = [r for r in rv if r["verdict"] != "within"]
        out.append(f"- V&V 20, the analytic model against each FEA fidelity (reed_validation.md): {len(bad)} of "
                   f"{len(rv)} comparisons beyond their validation uncertainty"
                   + (": " + ", ".join(f"{r['case']} {r['output']} {r['E'] / r['D'] * 100:+.2f} %" for r in bad)
                      if bad else ""))
    rd = s.get("reed_dynamics", {})
    if rd.get("status") == "ok":
        out.append(f"- in the pump: {rd['verdict']}; {rd['note']} (reed_dynamics.md)")
    return out + [""]


def _case_lines(s: dict) -> list[str]:
    pc = s["steps"]["pump_cases"]
    out = ["## Pump cases", "",
           f"{pc['cases']} cases, all cyclic steady: {pc['all_cyclic_steady']}, max mass-balance error "
           f"{pc['max_mass_balance_error']:.1e}; CPU s per simulated s on the {pc['stepper']} stepper: "
           + ", ".join(f"{k} {v}" for k, v in pc["cpu_seconds_per_simulated_second"].items())
           + " (it gives S; the thesis: 23 with Adams-Bashforth at 0.5 us; the fast path, which runs the draws and "
             "the sweeps: README 'Measured', benchmarks/bench_pump.py).", "",
           "| table | mean abs error [%] | max abs error [%] | thesis mean [%] | thesis max [%] | max diff from thesis model [%] |",
           "|---|---|---|---|---|---|"]
    for t, e in s["tables"].items():
        out.append(f"| {t} | {e['mean_abs_error_pct']} | {e['max_abs_error_pct']} | {e['thesis_mean_abs_error_pct']} "
                   f"| {e['thesis_max_abs_error_pct']} | {e['max_abs_diff_from_thesis_model_pct']} |")
    inf = s["tables"].get("5.6", {}).get("table_5_1_dead_volume_max_abs_diff_from_thesis_model_pct")
    if inf is not None:
        out += ["", f"Table 5.6 with Table 5.1's dead volume (2.17e-5 m^3) instead of the inferred reed-manifold "
                    f"4.0e-5 m^3 (docs/errata.md): largest difference from the thesis's modeled deliveries {inf} %."]
    out += ["", "| case | modeled | measured | thesis model | peak opening in/del (mm) | stop contacts |",
            "|---|---|---|---|---|---|"]
    for c in s["cases"]:
        out.append(f"| {c['case']} | {c['modeled_cc']:.4f} | {c['measured_cc']:.3f} | {c['thesis_modeled_cc']:.3f} "
                   f"| {c['peak_opening_mm'][0]:.3f} / {c['peak_opening_mm'][1]:.3f} | {c['stop_contacts']} |")
    return out


def console_lines(s: dict) -> list[str]:
    """What ``valvelab validate`` prints: the detectable errors and the calibrated values first."""
    out = [f"validation written to {s['out']}/"]
    out += [f"  {x}" for x in detectable_lines(s) + calibration_lines(s) + result_lines(s)]
    if s.get("reed_dynamics", {}).get("status") == "ok":
        out.append(f"  {s['reed_dynamics']['verdict']}")
    pc = s["steps"]["pump_cases"]
    out.append(f"  {pc['cases']} pump cases, all cyclic steady: {pc['all_cyclic_steady']}, CPU s per simulated s on the "
               f"{pc['stepper']} stepper: " + ", ".join(f"{k} {v:.2f}" for k, v in pc["cpu_seconds_per_simulated_second"].items())
               + " (it gives S; the fast path, which runs the draws and the sweeps: README 'Measured', "
                 "benchmarks/bench_pump.py)")
    for t, e in s["tables"].items():
        out.append(f"  Table {t}: mean |error| {e['mean_abs_error_pct']} % (thesis {e['thesis_mean_abs_error_pct']} %), "
                   f"max diff from the thesis's model {e['max_abs_diff_from_thesis_model_pct']} %")
    if s.get("uncertainty", {}).get("quick"):
        out.append("  quick: a cheaper, coarser estimate of the uncertainties")
    out.append(f"  {len(s['files'])} files, {s['wall_seconds']} s")
    return out
