"""Fluid references against the thesis's fluid parameters, and the disc pump with predicted ones.

:func:`parameter_rows`: each fluid parameter of a disc valve, the thesis's (``empirical``: the
bench fit of eq 2.48, the closed forms of eqs 2.14-2.15, the estimates of sections 2.4.4 and
2.4.6, eq 2.18's orifice force) beside the fluid references' prediction (``predicted``: the
compact forms of :mod:`fea.fluid.compact` and the Reynolds film of :mod:`fea.fluid.disc_film`)
with its numerical uncertainty (GCI, three meshes). The verdict depends on what the thesis value
is:

- a measurement (Cd, eq 2.48 fitted to the flow bench): the ASME V&V 20 comparison
  (:func:`studies.validation.vv20.vv20_row`, E = S - D against U_val from u_num and the bench's
  2.5 % standard uncertainty the model file declares): ``within`` or ``model_form_error``;
- a closed form (C1, C2): code verification, ``agrees`` when |E| <= 2 u_num (or 0.5 %);
- an estimate or an assumption (f1, f2, the jet angle, c_visc, the orifice force coefficient):
  no reference to validate against, ``replaces_estimate``.

:func:`pump_rows`: Table 5.4's six cases with ``fluid = "predicted"`` on both disc valves
(nothing tuned to the pump: the forms come from geometry and oil), their deliveries against the
measured ones and the empirical model's, and V&V 20 rows (u_num by the tolerance ladder, u_D of
the measurement; u_input of the declared inputs other than the fluid parameters is the empirical
model's and is left out here, said in the notes).
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import numpy as np

#: Reynolds numbers (eq 2.46) of the Cd rows: the pump's range
CD_REYNOLDS = (10.0, 30.0, 60.0, 100.0)
#: columns of fluid_validation.{md,csv}
COLUMNS = ("valve", "parameter", "unit", "empirical", "predicted", "u_num", "verdict", "reference", "note")
#: the flow bench's relative standard uncertainty of Cd (thesis-disc.toml's declaration of discharge.cd_inf)
BENCH_CD_REL = 0.025


def _row(valve, parameter, unit, values, verdict, reference, note="") -> dict:
    """One row; ``values`` = (empirical, predicted, u_num)."""
    empirical, predicted, u_num = values
    return {"valve": valve, "parameter": parameter, "unit": unit, "empirical": empirical, "predicted": predicted,
            "u_num": u_num, "verdict": verdict, "reference": reference, "note": note}


def _closed_form_verdict(e: float, s: float, u: float | None) -> str:
    return "agrees" if abs(s - e) <= max(2 * (u or 0.0), 5e-3 * abs(e)) else "differs"


def _cd_rows(name: str, valve, data: dict) -> list[dict]:
    """Cd at the stop (the bench's shims set the lift; eq 2.48 holds for every lift) at CD_REYNOLDS."""
    from lumped.fluid.orifice import discharge_coefficient
    from studies.validation.vv20 import Components, vv20_row

    v = valve.params
    stop = max(p["lift"] for p in data["points"])
    rows = []
    for re in CD_REYNOLDS:
        pt = [p for p in data["points"] if p["lift"] == stop and p["reynolds"] == re]
        if not pt:
            continue
        pt = pt[0]
        bench = float(discharge_coefficient(math.sqrt(re), v.cd_inf, v.cd_a, v.cd_b, v.cd_c))
        vv = vv20_row(f"{name} Re {re:g}", "cd", "-", pt["cd"], bench,
                      Components(pt["u_num"].get("cd", 0.0), 0.0, BENCH_CD_REL * bench))
        rows.append(_row(name, f"Cd(Re = {re:g})", "-", (bench, pt["cd"], pt["u_num"].get("cd")), vv["verdict"],
                         "measured: eq 2.48 (flow bench, section 2.4.5)",
                         f"x = {stop * 1e3:.3g} mm; E = {vv['E']:+.4f} ({100 * vv['E'] / bench:+.1f} %), "
                         f"U_val = {vv['U_val']:.4f}"))
    return rows


def parameter_rows(model: str = "thesis-disc", progress: bool = True) -> list[dict]:
    """The fluid parameters of both disc valves of ``model``: empirical vs predicted (module docstring)."""
    import fea.fluid  # noqa: F401  (registers the predicted forms)
    from fea.fluid.compact import compact_forms
    from fea.fluid.disc_film import DiscFilm, film_ladder
    from fea.fluid.point import load_fluid_valve

    rows = []
    for pos in ("inlet", "delivery"):
        valve = load_fluid_valve(f"{model}:{pos}")
        if valve.kind != "disc":
            continue
        v = valve.params
        name = f"{model}:{pos}"
        data = compact_forms(valve, progress=progress)
        f = data["forms"]
        rows += _cd_rows(name, valve, data)
        lad = film_ladder(DiscFilm(v.inner_radius, v.outer_radius, v.bevel_angle), valve.viscosity, 16)
        for key, unit, label, emp in (("c1", "-", "C1", v.c1), ("c2", "N m^2 s", "C2", v.c2(valve.viscosity))):
            mid, g = lad["levels"][1], lad["gci"][key]
            u = g.band(1) / 1.15
            rows.append(_row(name, label, unit, (emp, getattr(mid, key), u),
                             _closed_form_verdict(emp, getattr(mid, key), u),
                             f"closed form: eq {'2.14' if key == 'c1' else '2.15'}", "Reynolds film FE, 2-D"))
        est = "estimate: section 2.4.6 (f1 = f2 = 1)"
        rows += [
            _row(name, "f1", "-", (v.f1, f["f1"], f["u_f1"]), "replaces_estimate", est, "mean over the orifice-regime "
                 "lifts at Re 10 and 60 (quasi-steady moving disc)"),
            _row(name, "f2", "-", (v.f2, f["f2"], f["u_f2"]), "replaces_estimate", est, "as f1"),
            _row(name, "jet angle", "deg", (math.degrees(v.jet_angle_value), math.degrees(f["jet_angle"]),
                 None if f["u_jet_angle"] is None else math.degrees(f["u_jet_angle"])), "replaces_estimate",
                 "assumption: eq 2.30, the bevel angle", "effective angle of eq 2.36, orifice regime, pump Re"),
            _row(name, "c_visc", "-", (v.viscous_drag, f["c_visc"], f["u_c_visc"]), "replaces_estimate",
                 "estimate: section 2.4.4 (a disc in unbounded oil, ~10)", "Stokes drag of the disc at the stop "
                 "in the modelled housing (depends on its assumed clearances, docs/fluid.md)"),
            _row(name, "force coefficient (orifice regime)", "-",
                 (v.force_coefficient, f["force_coefficient_orifice"], f["u_force_coefficient_orifice"]), "replaces_estimate", "assumption: eq 2.18, F = dP A_disc",
                 "F / (dP A_disc), mean over the orifice-regime lifts at the pump's Re"),
        ]
    return rows


#: the pump's warnings that say an opening or a Reynolds number left the range the fluid forms hold on
RANGE_WARNINGS = ("fluid_range", "multiplier_range")
#: tip openings [m] of the reed's X rows (eq 3.83 was fitted to the bench from 0.2 to 1.2 mm and beyond)
REED_X_OPENINGS = (0.2e-3, 0.5e-3, 0.8e-3, 1.2e-3)
#: relative standard numerical uncertainties of the reed's 3-D Cd and X on the default mesh: the change
#: from the default to the fine mesh of the mesh study (0.25 mm, Stokes limit; docs/fluid.md), taken
#: as u_num because the observed orders exceed the elements' and the GCI bands are not trusted
REED_U_NUM = {"cd": 1.0e-3, "X": 4.0e-4}


def reed_parameter_rows(model: str = "thesis-reed", progress: bool = True) -> list[dict]:
    """The fluid parameters of both reed valves of ``model``: the thesis's (eq 3.89's Cd and eq 3.83's
    X, bench fits; X's plateau from an assumed F4; f1, f2 tuned to the pump) against the 3-D flow's
    and the film's (:mod:`fea.fluid.reed_compact`, shipped for the thesis reed). Cd at the computed
    points of each valve's operating line (where the bench measured) and X by V&V 20 against the bench fits (u_D: the 2.5 % the model declares for Cd,
    the same assumed for X, whose scatter the thesis does not print)."""
    import fea.fluid  # noqa: F401  (registers the predicted forms)
    from fea.fluid.point import load_fluid_valve
    from fea.fluid.reed3d import point_flow
    from fea.fluid.reed_compact import compact_forms, equilibrium_points, fit_multiplier
    from lumped.valves.reed import pressure_load_multiplier
    from studies.validation.vv20 import Components, vv20_row

    rows = []
    for pos in ("inlet", "delivery"):
        valve = load_fluid_valve(f"{model}:{pos}")
        if valve.kind != "reed":
            continue
        v, name = valve.params, f"{model}:{pos}"
        flow = point_flow(valve)
        data = compact_forms(flow, progress=progress)
        f = data["forms"]
        rows += _reed_cd_rows(name, v, equilibrium_points(data["points"]["pressure"], flow, v.preload))
        table = f["multiplier"]
        for x in REED_X_OPENINGS:
            emp = pressure_load_multiplier(x, v.multiplier_poiseuille, v.multiplier_n1, v.multiplier_n0,
                                           v.multiplier_d2, v.multiplier_d1, v.multiplier_d0, v.multiplier_zero)
            S = float(np.interp(x, table["opening"], table["X"]))
            vv = vv20_row(f"{name} x {x * 1e3:g} mm", "X", "-", S, emp,
                          Components(REED_U_NUM["X"] * S, 0.0, BENCH_CD_REL * emp))
            beyond = x > table["opening"][-1]
            rows.append(_row(name, f"X(x = {x * 1e3:g} mm)", "-", (emp, S, REED_U_NUM["X"] * S), vv["verdict"],
                             "measured: eq 3.83 (flow bench, section 3.8.5)",
                             f"3-D table (mean over the pump's Re), linear between openings; E = {vv['E']:+.4f}, "
                             f"U_val = {vv['U_val']:.4f}" + ("; beyond the computed openings" if beyond else "")))
        fitted = fit_multiplier(table, f["multiplier_poiseuille"])
        rows += [
            _row(name, "X (Poiseuille regime)", "-", (v.multiplier_poiseuille, f["multiplier_poiseuille"], None),
                 "replaces_estimate", "assumption: Table 3.12 with F4 = 0.5 (band 0.824-0.845 for F4 0-1)",
                 f"sealing film with F4 computed ({f['base_fraction']:.3f})"),
            _row(name, "X = 0 at opening", "mm", (v.multiplier_zero * 1e3,
                 None if table["zero_opening"] is None else table["zero_opening"] * 1e3, None), "replaces_estimate",
                 "measured: eq 3.83's zero (flow bench)",
                 "not reached: X stays above 0 up to the largest computed opening "
                 f"({table['opening'][-1] * 1e3:.3g} mm); eq 3.83's form fitted to the table falls to 0 at "
                 f"{fitted['zero_opening'] * 1e3:.3g} mm" if table["zero_opening"] is None else "3-D table"),
            _row(name, "f1", "-", (v.f1, f["f1"], None), "replaces_estimate", "tuned to the pump (section 5.5.3)",
                 "moving-wall solves, closing tip speed 0.1 m/s, mean over the openings"),
            _row(name, "f2", "-", (v.f2, f["f2"], None), "replaces_estimate", "tuned to the pump (section 5.5.3)",
                 "as f1, opening"),
        ]
    return rows


def _reed_cd_rows(name: str, v, points) -> list[dict]:
    """V&V 20 rows of the reed's Cd at the computed points of its operating line against eq 3.89 (the bench fit
    in ``v``, the valve's parameters)."""
    from lumped.fluid.orifice import discharge_coefficient
    from studies.validation.vv20 import Components, vv20_row

    rows = []
    for pt in points:
        re, x = pt["reynolds"], pt["opening"]
        bench = float(discharge_coefficient(math.sqrt(re), v.cd_inf, v.cd_a, v.cd_b, v.cd_c))
        S = float(pt["cd"])
        vv = vv20_row(f"{name} x {x * 1e3:.3g} mm", "cd", "-", S, bench,
                      Components(REED_U_NUM["cd"] * S, 0.0, BENCH_CD_REL * bench))
        rows.append(_row(name, f"Cd(x = {x * 1e3:.3g} mm, Re = {re:.3g})", "-", (bench, S, REED_U_NUM["cd"] * S),
                         vv["verdict"], "measured: eq 3.89 (flow bench, section 3.8.6)",
                         f"3-D on the operating line kappa (x - x_0) = X dP (dP = {pt['dp'] / 1e3:.3g} kPa); "
                         f"E = {vv['E']:+.4f} ({100 * vv['E'] / bench:+.1f} %), U_val = {vv['U_val']:.4f}"))
    return rows


#: what ``fluid = "predicted"`` replaces, per valve kind (the notes of the pump rows)
PREDICTED_NOTE = {
    "disc": "Cd(Re, x), the orifice force coefficient, jet angle, f1, f2, c_visc",
    "reed": "Cd(Re) of eq 3.88 on each valve's operating line, X(x) of eq 3.83 with the film's plateau, f1, f2",
}
#: what remains assumed with predicted fluid parameters, per kind
ASSUMED_NOTE = {
    "disc": "the air content and the declared inputs",
    "reed": "the air content (R = 0.008, the thesis's for the reed rig), the reconstructed seat and chamber "
            "of the 3-D flow (docs/fluid.md) and the declared inputs",
}


def pump_rows(quick: bool = False, progress: bool = True, kind: str = "disc", method: str = "reference") -> dict:
    """Table 5.4's (disc) or 5.6's (reed) six cases with fluid = "predicted" on both valves of the
    thesis model of ``kind``, vs measured and vs the empirical model. ``method``: the stepper
    (:func:`studies.validation.chain.run_case`)."""
    import fea.fluid  # noqa: F401
    from lumped.model.model_file import load_model, with_values
    from studies.validation.chain import case_name, cases, run_case
    from studies.validation.measurement import delivery_uncertainty
    from studies.validation.numerical import numerical_uncertainty
    from studies.validation.point import Point
    from studies.validation.vv20 import Components, vv20_row

    predicted = with_values(load_model(f"thesis-{kind}"), {"valves.inlet.fluid": "predicted",
                                                          "valves.delivery.fluid": "predicted"})
    selected = cases(valve=kind)
    out, runs = [], {}
    for c in selected:
        n = case_name(c)
        if progress:
            print(f"fluid validation: {n}, empirical and predicted", file=sys.stderr, flush=True)
        emp = run_case(c, quick=quick, trace=False, method=method)
        m = with_values(predicted, {"oil.air_content": c["air_content"]})
        pre = run_case(c, params=m, quick=quick, trace=False, method=method)
        runs[n] = (c, emp, pre, m)
    ud = delivery_uncertainty(selected, {n: r[2].delivery_per_rev * 1e6 for n, r in runs.items()})
    for n, (c, emp, pre, m) in runs.items():
        S, D = pre.delivery_per_rev * 1e6, c["measured_delivery"] * 1e6
        un = numerical_uncertainty(Point(n, m, c["speed_rpm"], c["load_pressure"], 5),
                                   reported={"delivery_cc_per_rev": S}, quick=True,
                                   outputs={"delivery_cc_per_rev": "cc/rev"})["delivery_cc_per_rev"].u
        vv = vv20_row(n, "delivery_cc_per_rev", "cc/rev", S, D,
                      Components(un, 0.0, ud[n].u, (math.inf, math.inf, ud[n].dof)))
        out.append({"case": n, "measured_cc": D, "empirical_cc": emp.delivery_per_rev * 1e6, "predicted_cc": S,
                    "error_empirical_pct": 100 * (emp.delivery_per_rev * 1e6 - D) / D,
                    "error_predicted_pct": 100 * (S - D) / D, "vv20": vv,
                    "warnings": [w.message for w in pre.warnings if w.code in RANGE_WARNINGS]})
    table = "5.4" if kind == "disc" else "5.6"
    return {"kind": kind, "table": table, "rows": out, "notes": [
        f"predicted: thesis-{kind} with fluid = \"predicted\" on both valves ({PREDICTED_NOTE[kind]} from the fluid "
        f"references; nothing fitted to pump data); assumed: {ASSUMED_NOTE[kind]}.",
        "V&V 20: u_num from a two-level tolerance ladder, u_D from the paired runs and the flow meter; u_input of "
        "the declared inputs (air content, viscosity, spring) is not propagated here (see the main validation).",
    ]}


def write_fluid_validation(folder, rows: list[dict], pumps=None) -> list[Path]:
    """fluid_validation.csv (the rows) and fluid_validation.md (the rows, and the pumps' cases if given:
    a :func:`pump_rows` result or a list of them)."""
    folder = Path(folder)
    csv_path, md_path = folder / "fluid_validation.csv", folder / "fluid_validation.md"
    with open(csv_path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k) for k in COLUMNS})

    def fmt(x):
        return "-" if x is None else (f"{x:.4g}" if isinstance(x, float) else str(x))

    lines = ["# Fluid parameters: the thesis's (empirical) against the fluid references (predicted)", "",
             "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(fmt(r.get(k)) for k in COLUMNS) + " |" for r in rows]
    for pump in ([pumps] if isinstance(pumps, dict) else list(pumps or ())):
        kind, table = pump.get("kind", "disc"), pump.get("table", "5.4")
        lines += ["", f"## Table {table} with fluid = \"predicted\" on both {kind} valves", "",
                  "| case | measured [cc/rev] | empirical [cc/rev] | E emp. [%] | predicted [cc/rev] | E pred. [%] "
                  "| U_val [cc/rev] | verdict |", "|---|---|---|---|---|---|---|---|"]
        for r in pump["rows"]:
            lines.append(f"| {r['case']} | {r['measured_cc']:.4g} | {r['empirical_cc']:.4g} | "
                         f"{r['error_empirical_pct']:+.2f} | {r['predicted_cc']:.4g} | {r['error_predicted_pct']:+.2f} | "
                         f"{r['vv20']['U_val']:.3g} | {r['vv20']['words']} |")
        warned = [f"{r['case']}: {m}" for r in pump["rows"] for m in r.get("warnings", ())]
        lines += [""] + [f"- {n}" for n in pump["notes"] + warned]
    md_path.write_text("\n".join(lines) + "\n")
    return [md_path, csv_path]


def fluid_validation(folder=None, quick: bool = False, pump: bool = True, progress: bool = True,
                     kinds=("disc", "reed")) -> dict:
    """The rows, the predicted pumps (unless ``pump`` is False) and, with ``folder``, the files, for the
    thesis models of ``kinds`` (``fluid_pump``: the disc's Table 5.4, ``fluid_pump_reed``: Table 5.6)."""
    rows, pumps = [], {}
    if "disc" in kinds:
        rows += parameter_rows(progress=progress)
        pumps["disc"] = pump_rows(quick=quick, progress=progress) if pump else None
    if "reed" in kinds:
        rows += reed_parameter_rows(progress=progress)
        pumps["reed"] = pump_rows(quick=quick, progress=progress, kind="reed") if pump else None
    out = {"fluid_validation": rows, "fluid_pump": pumps.get("disc"), "fluid_pump_reed": pumps.get("reed")}
    if folder is not None:
        out["files"] = [str(x) for x in write_fluid_validation(folder, rows, [p for p in pumps.values() if p])]
    return out


# ------------------------------------------------------------------ valvelab check MODEL
#: lifts of the check as fractions of the stop, and its Reynolds number
CHECK_LIFTS = (0.1, 0.5, 1.0)
CHECK_REYNOLDS = 20.0


def disc_model_spec(spec: str) -> bool:
    """Whether ``spec`` (``MODEL[:position]``) names a pump model with a disc valve there (not a reed)."""
    from pathlib import Path

    from geometry.errors import InputError
    from lumped.model.model_file import SHIPPED, load_model

    model, _, pos = str(spec).partition(":")
    if model not in SHIPPED and not (Path(model).suffix == ".toml" and Path(model).is_file()):
        return False
    try:
        m = load_model(model, field="GEOMETRY")
    except InputError:
        return False
    return any(m.kind_at(p) == "disc" for p in ((pos,) if pos in ("inlet", "delivery") else ("inlet", "delivery")))


def fluid_check(spec: str, progress: bool = True) -> dict:
    """The ``fluid`` section of ``valvelab check``: orifice laws, thin film and axisymmetric Navier-Stokes at
    CHECK_LIFTS x x_stop and Re = CHECK_REYNOLDS, deviations from the axisymmetric model, and the
    parameter rows of the model's disc valves (:func:`parameter_rows`)."""
    from fea import fluid
    from fea.fluid.point import load_fluid_valve

    model, _, pos = str(spec).partition(":")
    positions = (pos,) if pos in ("inlet", "delivery") else ("inlet", "delivery")
    points = []
    for p in positions:
        valve = load_fluid_valve(f"{model}:{p}", "GEOMETRY")
        if valve.kind != "disc":
            continue
        for frac in CHECK_LIFTS:
            x = frac * valve.params.stop_gap
            ref = None
            for name in ("axisymmetric", "thin_film", "orifice"):
                if progress:
                    print(f"check {valve.name}: {name} at {x * 1e3:.3g} mm, Re {CHECK_REYNOLDS:g}", file=sys.stderr,
                          flush=True)
                pt = fluid.get(name, "disc").point(valve, x, CHECK_REYNOLDS, {})
                ref = ref or pt
                points.append({"valve": valve.name, "fidelity": name, "lift": x, "reynolds": CHECK_REYNOLDS,
                               "cd": pt.cd, "force_coefficient": pt.force_coefficient, "flow_force": pt.flow_force,
                               "cd_deviation_pct": 100 * (pt.cd / ref.cd - 1),
                               "force_deviation_pct": 100 * (pt.force_coefficient / ref.force_coefficient - 1)})
    return {"reference": "axisymmetric", "points": points, "parameters": parameter_rows(model, progress=progress)}


def render_check(f: dict) -> str:
    lines = [f"fluid fidelities at Re = {CHECK_REYNOLDS:g} (deviations from {f['reference']}):",
             f"{'valve':<22} {'fidelity':<13} {'lift [mm]':>9} {'Cd':>8} {'dev %':>7} {'F/(dP A)':>9} {'dev %':>7}"]
    for p in f["points"]:
        lines.append(f"{p['valve']:<22} {p['fidelity']:<13} {p['lift'] * 1e3:9.3g} {p['cd']:8.4f} "
                     f"{p['cd_deviation_pct']:7.1f} {p['force_coefficient']:9.4f} {p['force_deviation_pct']:7.1f}")
    lines += ["", "fluid parameters, empirical (thesis) vs predicted:"]
    for r in f["parameters"]:
        u = "" if r["u_num"] is None else f" +- {r['u_num']:.2g}"
        lines.append(f"{r['valve']:<22} {r['parameter']:<36} {r['empirical']:.4g} -> {r['predicted']:.4g}{u} "
                     f"({r['verdict']})")
    return "\n".join(lines)
