"""When is one mode enough? The reed valve in the pump with 1..6 modes against the whole FE reed.

:func:`dynamics_study` runs the reed pump (thesis-reed's flow and damping data, Table 3.13) with a
reed geometry at both valves, on the six operating points of Table 5.6, with the thesis's one-mode
model (eq 3.21), the modal reed with N modes and the whole FE reed (lumped/reed/structure.py), and
tabulates per case and model: delivery, each valve's opening and closing angle, peak opening, seat
and stop impact speeds, and the peak root stress (the solid FEA's stress per unit tip deflection
under a uniform pressure, fea.reed_stress.max_opening_stress, times the peak opening, as the reed
stress check does). Per reed it says how many modes are needed for 0.1 % delivery and 0.5 deg
timing against the reference, and whether eq 3.21's one mode is enough.

The reference is the whole FE reed on the reference stepper (beam elements: bending only). A
reed whose port sits off its axis twists, which only the plate and solid fidelities carry; the
whole plate FE reed (~900 DOFs) is not affordable in the pump, so there the reference is the
plate's modal reed with six modes, and the convergence in N says how far that holds. Eq 3.21 loads
the whole face: beside a reed with a port it measures what leaving the port out costs, and the
modal reed with one mode (N = 1) is the one-mode model of the port's load.

:func:`prototype_adequacy` is the validation chain's part (``valvelab validate``): the same
comparison for the prototype reed at one operating point of Table 5.6.
"""

from __future__ import annotations

import math
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: modal reeds tried (modes), besides eq 3.21 and the FE reed
MODES = (1, 2, 3, 6)
#: the fast stepper's rtol where the comparison runs on it (validate's): the reference stepper's numerics are
#: what the study's 0.1 % needs, and on the reeds that fly past X(x)'s end (1.37 mm: a kink in the load, no
#: event) the fast stepper at 1e-5 and 1e-6 strayed by up to 0.06 % in one case of six (measured)
FAST_RTOL = 1e-5
#: a model "needs" N modes when every case is within these of the reference
DELIVERY_TOL = 1e-3
ANGLE_TOL_DEG = 0.5
#: the outputs compared, per valve: (name, attribute of lumped.run.simulate.ValveResult, scale to the table's unit)
VALVE_OUTPUTS = (("opening_deg", "opening_angle", 180 / math.pi), ("closing_deg", "closing_angle", 180 / math.pi),
                 ("peak_opening_mm", "peak_opening", 1e3), ("seat_impact_m_s", "seat_impact_velocity", 1.0),
                 ("stop_impact_m_s", "stop_impact_velocity", 1.0))
#: the operating point of Table 5.6 the validation chain compares the models at (the fastest)
VALIDATE_CASE = "high_speed_delivery"
#: the validation chain's FE reed: this many beam elements (the study's default has 24; a third of the cost)
VALIDATE_FE_ELEMENTS = 12


@dataclass(frozen=True)
class ReedCase:
    """A reed to study: its name, geometry (a geometry.Reed), fidelity, the port footprint keys (none: the whole
    face) and why it is in the study."""

    name: str
    reed: object
    fidelity: str = "beam"
    port: dict = field(default_factory=dict)
    why: str = ""
    fe_mesh: float | None = None     # the FE reed's element size [m] (None: the fidelity's default)

    @property
    def reference(self) -> str:
        """"fe" (the whole beam FE reed), or "modal6" where the port twists the reed (plate modes)."""
        return "modal6" if self.port and self.port.get("y_center", 0.0) != 0.0 else "fe"


def off_axis_port(reed) -> dict:
    """A port off the reed's axis: s from 0.3 L to 0.8 L, 0.3 of the narrowest width there across, centred a
    quarter of that width off the centre line (inside the outline of any reed; the load twists it)."""
    length = reed.length
    w = float(np.min(reed.width(np.linspace(0.3 * length, 0.8 * length, 101))))
    return {"s_start": 0.3 * length, "s_end": 0.8 * length, "width": 0.3 * w, "y_center": 0.25 * w}


def mid_port(reed) -> dict:
    """A port on the axis from 0.1 L to 0.5 L, 0.9 of the narrowest width there across: the load sits where the
    first mode hardly moves, so its static shape is far from that mode's (one mode misses 12 % of the static
    opening of the prototype, three modes 0.05 %: docs/reed_dynamics.md)."""
    length = reed.length
    w = float(np.min(reed.width(np.linspace(0.1 * length, 0.5 * length, 101))))
    return {"s_start": 0.1 * length, "s_end": 0.5 * length, "width": 0.9 * w}


def study_reeds(reed) -> list[ReedCase]:
    """The reed and five made from it where one mode should fail: twice as long and half as thick
    (Reed.scaled), a port off its axis (torsion, plate modes), a heavy tip (Reed.with_heavy_tip: the rounded tip
    three times as thick), and two designed so that it does: three times as long and half as thick, and a port
    on the axis near the clamp (:func:`mid_port`)."""
    return [
        ReedCase(reed.name, reed, "beam", {}, "the reed as given"),
        ReedCase("long_thin", reed.scaled(2.0, 0.5, name="long_thin"), "beam", {},
                 "twice as long, half as thick: its frequencies fall 8x toward the pump's"),
        ReedCase("off_axis_port", reed, "plate", off_axis_port(reed), "a port off the reed's axis: the load twists it"),
        ReedCase("heavy_tip", reed.with_heavy_tip(3.0, name="heavy_tip"), "beam", {},
                 "its tip three times as thick: more of its mass where the first mode moves most"),
        ReedCase("longer_thin", reed.scaled(3.0, 0.5, name="longer_thin"), "beam", {},
                 "three times as long, half as thick: its frequencies fall 18x"),
        ReedCase("mid_port", reed, "beam", mid_port(reed), "a port on the axis near the clamp: the load far from the "
                 "first mode's shape"),
    ]


def _model(case: ReedCase, dynamics: str, modes: int | None = None):
    """thesis-reed with the case's reed at both valves and the given dynamics (the port with modal and fe)."""
    from geometry.reed_io import reed_to_toml
    from lumped import load_model, with_values

    values = {"valves.geometry": tomllib.loads(reed_to_toml(case.reed))["reed"], "valves.fidelity": case.fidelity}
    if dynamics != "one-mode":
        values["valves.dynamics"] = dynamics
        values.update({f"valves.port.{k}": v for k, v in case.port.items()})
    if modes is not None:
        values["valves.modes"] = modes
    if dynamics == "fe" and case.fe_mesh is not None:
        values["valves.mesh_size"] = case.fe_mesh
    return with_values(load_model("thesis-reed"), values)


def variants(case: ReedCase, modes=MODES, fe: bool = True) -> list[tuple[str, dict]]:
    """(label, how) of the models compared: eq 3.21, N modes, the FE reed (where it is the reference)."""
    out = [("one-mode", {"dynamics": "one-mode"})]
    out += [(f"modal{n}", {"dynamics": "modal", "modes": n}) for n in modes]
    if fe and case.reference == "fe":
        out.append(("fe", {"dynamics": "fe"}))
    return out


def _row(label: str, res) -> dict:
    """A run's outputs in the table's units: delivery [cc/rev], angles [deg], openings [mm], speeds [m/s]."""
    row = {"model": label, "delivery_cc": res.delivery_per_rev * 1e6, "steps": res.steps,
           "stop_contacts": res.delivery.stop_contacts + res.inlet.stop_contacts}
    for pos, v in res.valves.items():
        for name, attr, scale in VALVE_OUTPUTS:
            val = getattr(v, attr)
            row[f"{pos}_{name}"] = None if val is None else val * scale
    return row


def _angle_diff(a, b) -> float:
    """|a - b| [deg] on the circle; inf where a valve opens in one model and not the other."""
    if a is None or b is None:
        return 0.0 if a is None and b is None else math.inf
    d = abs(a - b) % 360.0
    return min(d, 360.0 - d)


def _worst_angle(row: dict, ref: dict) -> float:
    """The largest difference of the four valve timings (each valve's opening and closing) [deg]."""
    return max(_angle_diff(row[f"{pos}_{n}"], ref[f"{pos}_{n}"]) for pos in ("inlet", "delivery")
               for n in ("opening_deg", "closing_deg"))


def case_label(op: dict) -> str:
    """An operating point's name, e.g. ``low_speed_inlet`` (the thesis figure's condition and valve)."""
    return f"{op['condition']}_{op['measured_valve']}"


def run_point(case: ReedCase, op: dict, revolutions: int = 3, method: str = "reference", trace: bool = False,
              models=None, progress=None) -> tuple[dict, dict]:
    """Every model of ``models`` (default :func:`variants`) at one operating point: ({label: row}, {label:
    trace}). Eq 3.21 and the modal reeds on ``method``'s stepper ("fast": at rtol FAST_RTOL), the FE reed on
    the reference one."""
    from lumped import simulate

    by_label, traces = {}, {}
    for label, how in (models or variants(case)):
        model = _model(case, how["dynamics"], how.get("modes"))
        fast = method == "fast" and how["dynamics"] != "fe"
        tol = {"method": "fast", "rtol": FAST_RTOL} if fast else {"method": "reference"}
        res = simulate(model, op["speed_rpm"], op["load_pressure"], air_content=op["air_content"],
                       revolutions=revolutions, trace=trace, trace_points=720, **tol)
        by_label[label] = {"reed": case.name, "case": case_label(op), "speed_rpm": op["speed_rpm"],
                           "load_pressure_pa": op["load_pressure"], "method": tol["method"], **_row(label, res)}
        if trace:
            traces[label] = (res.trace, _mode_names(model))
        if progress is not None:
            progress(case.name, label)
    return by_label, traces


def _against(by_label: dict, reference: str) -> None:
    """Each row's difference from the reference's: delivery [%] and the worst valve timing [deg]."""
    ref = by_label[reference]
    for row in by_label.values():
        row["reference"] = reference
        row["delivery_vs_reference_pct"] = (row["delivery_cc"] / ref["delivery_cc"] - 1.0) * 100.0
        row["worst_angle_vs_reference_deg"] = _worst_angle(row, ref)


def dynamics_study(reeds: list[ReedCase] | None = None, cases=None, revolutions: int = 3, progress: bool = True,
                   stress: bool = True, traces: bool = True, method: str = "reference") -> dict:
    """Run the study (see the module docstring); returns {"reeds": [...], "rows": [...], "numerics": [...],
    "traces": {...}, "tolerances": {...}}.

    ``cases``: the operating points (dicts with condition, measured_valve, speed_rpm, load_pressure,
    air_content; default the six of Table 5.6); ``stress``: compute the peak root stress from the solid FEA
    (a static solve per reed); ``method``: the stepper of eq 3.21 and the modal reeds (the FE reed runs on the
    reference stepper). The study compares model forms, so its numerics must sit well below its 0.1 %: the
    reference stepper (rtol 1e-6) by default; per reed the first case's richest modal reed runs on the other
    stepper too (the fast one at its default tolerances), and ``numerics`` reports the difference.
    """
    from geometry import load_reed
    from studies.validation.chain import cases as all_cases

    reeds = study_reeds(load_reed("prototype")) if reeds is None else reeds
    cases = all_cases(valve="reed") if cases is None else cases
    rows, summaries, traces_out, numerics = [], [], {}, []
    counter = _Progress(sum(len(variants(r)) for r in reeds) * len(cases) + len(reeds), progress)
    for case in reeds:
        case_rows, tr, num = _study_reed(case, cases, revolutions, method, stress, traces, counter)
        rows += case_rows
        numerics.append(num)
        summaries.append(_summary(case, case_rows, num))
        if tr:
            traces_out[case.name] = tr
    counter.done()
    return {"reeds": summaries, "rows": rows, "numerics": numerics, "traces": traces_out,
            "tolerances": {"delivery_pct": DELIVERY_TOL * 100, "angle_deg": ANGLE_TOL_DEG, "method": method,
                           "fast_rtol": FAST_RTOL if method == "fast" else None}}


def _study_reed(case: ReedCase, cases, revolutions: int, method: str, stress: bool, traces: bool,
                counter) -> tuple[list, dict, dict]:
    """One reed over the cases: (its rows, against its reference and with the peak root stress; the first case's
    traces; the numerical part at the first case)."""
    sigma = _stress_per_tip(case.reed) if stress else None
    rows, traces_first, numerics = [], {}, None
    for op in cases:
        first = op is cases[0]
        by_label, tr = run_point(case, op, revolutions, method, trace=traces and first, progress=counter)
        _against(by_label, case.reference)
        for row in by_label.values():
            if sigma is not None:
                row["peak_root_stress_mpa"] = sigma * max(row["inlet_peak_opening_mm"],
                                                          row["delivery_peak_opening_mm"]) * 1e-3 / 1e6
        rows += list(by_label.values())
        if first:
            traces_first = tr
            numerics = _numerics(case, op, by_label[f"modal{MODES[-1]}"], revolutions, method)
            counter(case.name, "numerics")
    return rows, traces_first, numerics


class _Progress:
    """A count of the runs on stderr (``enabled``), called (reed, label) after each."""

    def __init__(self, total: int, enabled: bool):
        self.total, self.enabled, self.n = total, enabled, 0

    def __call__(self, reed: str, label: str) -> None:
        self.n += 1
        if self.enabled:
            sys.stderr.write(f"\rreed dynamics: {self.n}/{self.total} runs ({reed}, {label})   ")
            sys.stderr.flush()

    def done(self) -> None:
        if self.enabled:
            sys.stderr.write("\n")


def _numerics(case: ReedCase, op: dict, row: dict, revolutions: int, method: str) -> dict:
    """The richest modal reed at one point on the other stepper (a study on the reference stepper: the fast one
    at its default tolerances; on the fast one: the reference) against ``row``, its run on ``method``'s."""
    from lumped import simulate

    other = "fast" if method == "reference" else "reference"
    res = simulate(_model(case, "modal", MODES[-1]), op["speed_rpm"], op["load_pressure"], method=other,
                   air_content=op["air_content"], revolutions=revolutions)
    fast, ref = (_row(row["model"], res), row) if other == "fast" else (row, _row(row["model"], res))
    return {"reed": case.name, "case": row["case"], "model": row["model"],
            "fast_stepper": "default tolerances" if other == "fast" else f"rtol {FAST_RTOL:g}",
            "fast_vs_reference_pct": (fast["delivery_cc"] / ref["delivery_cc"] - 1.0) * 100.0,
            "fast_vs_reference_deg": _worst_angle(fast, ref)}


def _worst(rows: list[dict], label: str) -> tuple[float, float]:
    """(largest |delivery difference| [%], largest timing difference [deg]) of a model over the cases."""
    mine = [r for r in rows if r["model"] == label]
    return (max(abs(r["delivery_vs_reference_pct"]) for r in mine),
            max(r["worst_angle_vs_reference_deg"] for r in mine))


def _within(worst: tuple[float, float]) -> bool:
    return bool(worst[0] <= DELIVERY_TOL * 100 and worst[1] <= ANGLE_TOL_DEG)


def _summary(case: ReedCase, rows: list[dict], numerics: dict | None = None, reference: str | None = None) -> dict:
    """How many modes a reed needs for 0.1 % delivery and 0.5 deg timing against its reference (default the
    case's), over the cases; eq 3.21's and every N's worst differences; the numerical part (fast vs
    reference stepper)."""
    reference = case.reference if reference is None else reference
    one = _worst(rows, "one-mode")
    modal = {n: _worst(rows, f"modal{n}") for n in MODES if any(r["model"] == f"modal{n}" for r in rows)}
    needed = next((n for n, w in modal.items() if _within(w) and f"modal{n}" != reference), None)
    out = {"reed": case.name, "why": case.why, "fidelity": case.fidelity, "reference": reference,
           "port": case.port or None, "cases": len({r["case"] for r in rows}),
           "one_mode_worst_delivery_pct": one[0], "one_mode_worst_angle_deg": one[1],
           "one_mode_enough": _within(one), "modes_needed": needed,
           "modal_worst": {f"modal{n}": {"delivery_pct": w[0], "angle_deg": w[1]} for n, w in modal.items()}}
    if numerics is not None:
        out["numerical_pct"] = abs(numerics["fast_vs_reference_pct"])
        out["numerical_deg"] = numerics["fast_vs_reference_deg"]
    return out


def _stress_per_tip(reed) -> float:
    """Root (von Mises, away from the clamp) stress per unit tip deflection under a uniform pressure [Pa/m]
    (the solid FEA of fea.reed_stress)."""
    from fea.reed_stress import max_opening_stress

    check = max_opening_stress(reed, x_stop=1e-3)
    return check.max_von_mises_away_from_clamp / 1e-3


def _mode_names(model) -> list | None:
    """The names of the delivery valve's modes (modal only; their shares of the opening are in the trace:
    lumped.run.postprocess.trace)."""
    from lumped.reed.structure import structure

    v = model.delivery
    if getattr(v, "dynamics", "one-mode") != "modal":
        return None
    return list(structure(v, model.oil.density).kinds)


# --------------------------------------------------------------------------- outputs
def plot(study: dict, folder) -> list:
    """Per reed: the delivery valve's opening over a revolution for every model [mm vs deg], and the six-mode
    reed's modal participation (each mode's share e_i q_i of the opening) over the cycle."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = []
    for reed, by_label in study["traces"].items():
        fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 7), sharex=True, constrained_layout=True)
        for label, (tr, _) in by_label.items():
            ax.plot(tr.crank_deg, tr.delivery_position * 1e3, lw=2.0 if label in ("fe", "one-mode") else 1.0,
                    ls="--" if label == "one-mode" else "-", label=_LABELS.get(label, label))
        ax.set_ylabel("delivery reed opening x [mm]")
        first = next(r["case"] for r in study["rows"] if r["reed"] == reed)
        ax.set_title(f"{reed}: delivery valve opening by reed model ({first.replace('_', ' ')})")
        ax.legend(fontsize=8)
        tr, kinds = by_label.get(f"modal{MODES[-1]}", (None, None))
        if tr is not None and kinds:
            for i, kind in enumerate(kinds):
                bx.plot(tr.crank_deg, getattr(tr, f"delivery_mode{i + 1}_position") * 1e3, label=kind)
            bx.legend(fontsize=8)
        bx.set_xlabel("crank angle from TDC [deg]")
        bx.set_ylabel("share of the opening e_i q_i [mm]")
        bx.set_title(f"modal participation, {MODES[-1]} modes")
        path = Path(folder) / f"reed_dynamics_{reed}.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        out.append(path)
    return out


_LABELS = {"one-mode": "eq 3.21 (one mode)", "fe": "whole FE reed"}


def as_json(study: dict) -> dict:
    """The study without its traces, a timing difference that cannot be taken (a valve that opens in one
    model and not the other) as null."""
    def clean(v):
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, np.generic):          # numpy scalars (a bool_ is no JSON bool)
            v = v.item()
        return None if isinstance(v, float) and not math.isfinite(v) else v

    return clean({k: v for k, v in study.items() if k != "traces"})


def _fmt(v, spec: str, missing: str = "n/a (opens in one model only)") -> str:
    return missing if v is None or not math.isfinite(v) else format(v, spec)


def _md(header: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |" for r in rows]


def _summary_table(study: dict) -> list[str]:
    """Per reed: eq 3.21's and each N's worst difference from the reference, and the modes needed."""
    header = ["reed", "reference", "eq 3.21: delivery % / timing deg"]
    header += [f"N = {n}" for n in MODES] + [f"modes for {DELIVERY_TOL * 100:g} % and {ANGLE_TOL_DEG:g} deg",
                                            "numerics: fast vs reference stepper"]
    rows = []
    for s in study["reeds"]:
        cells = [s["reed"], "whole FE reed (beam)" if s["reference"] == "fe" else f"{s['reference']} ({s['fidelity']})",
                 f"{_fmt(s['one_mode_worst_delivery_pct'], '.3f', 'n/a')} / {_fmt(s['one_mode_worst_angle_deg'], '.2f', 'n/a')}"]
        for n in MODES:
            w = s["modal_worst"].get(f"modal{n}")
            cells.append("-" if w is None or f"modal{n}" == s["reference"] else
                         f"{_fmt(w['delivery_pct'], '.4f', 'n/a')} / {_fmt(w['angle_deg'], '.3f', 'n/a')}")
        need = "more than " + str(MODES[-1]) if s["modes_needed"] is None else str(s["modes_needed"])
        cells.append(need + (" (eq 3.21 enough)" if s["one_mode_enough"] else " (eq 3.21 not enough)"))
        cells.append(f"{_fmt(s.get('numerical_pct'), '.4f', '-')} % / {_fmt(s.get('numerical_deg'), '.3f', '-')} deg")
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
        rows.append([_LABELS.get(m, m)] + [f"{by_case[c]['delivery_vs_reference_pct']:+.4f}" for c in cases]
                    + [_fmt(worst, ".3f", "n/a")])
    return _md(header, rows)


def _detail_table(study: dict, reed: str) -> list[str]:
    """One reed at its first case: every model's outputs (delivery, timings, peak opening, impacts, stress)."""
    mine = [r for r in study["rows"] if r["reed"] == reed]
    first = mine[0]["case"]
    header = ["model", "delivery [cc/rev]", "inlet opens / closes [deg]", "delivery opens / closes [deg]",
              "delivery peak opening [mm]", "delivery seat / stop impact [m/s]", "peak root stress [MPa]"]
    rows = []
    for r in (r for r in mine if r["case"] == first):
        rows.append([_LABELS.get(r["model"], r["model"]), f"{r['delivery_cc']:.5f}",
                     f"{_fmt(r['inlet_opening_deg'], '.2f', '-')} / {_fmt(r['inlet_closing_deg'], '.2f', '-')}",
                     f"{_fmt(r['delivery_opening_deg'], '.2f', '-')} / {_fmt(r['delivery_closing_deg'], '.2f', '-')}",
                     f"{r['delivery_peak_opening_mm']:.4f}",
                     f"{_fmt(r['delivery_seat_impact_m_s'], '.4f', '-')} / {_fmt(r['delivery_stop_impact_m_s'], '.4f', '-')}",
                     _fmt(r.get("peak_root_stress_mpa"), ".2f", "-")])
    return _md(header, rows)


def markdown(study: dict) -> str:
    """The study's tables in Markdown: the verdict per reed, each reed's delivery differences per case, and its
    first case in full."""
    t = study["tolerances"]
    steppers = ("every model on the reference stepper" if t["method"] == "reference" else
                f"the fast stepper at rtol {t['fast_rtol']:g}, the FE reed on the reference stepper")
    out = [f"Against each reed's reference, over {study['reeds'][0]['cases']} operating point(s) of Table 5.6 "
           f"({steppers}); largest |delivery difference| [%] / largest valve timing difference [deg]; the "
           "numerics column: the six-mode reed at the first point, fast stepper "
           f"({study['numerics'][0]['fast_stepper'] if study['numerics'] else '-'}) against the reference:", ""]
    out += _summary_table(study)
    for s in study["reeds"]:
        port = "" if not s["port"] else " Port: " + ", ".join(f"{k} {v * 1e3:.2f} mm" for k, v in s["port"].items()) + "."
        out += ["", f"**{s['reed']}** ({s['why']}; {s['fidelity']} modes).{port} Delivery against the reference:", ""]
        out += _case_table(study, s["reed"])
        first = next(r["case"] for r in study["rows"] if r["reed"] == s["reed"])
        out += ["", f"{s['reed']}, {first.replace('_', ' ')}:", ""]
        out += _detail_table(study, s["reed"])
    return "\n".join(out) + "\n"


def write_outputs(study: dict, folder) -> list[Path]:
    """reed_dynamics.json (the study without traces), .md (:func:`markdown`), .csv (every run's row) and the
    plots (:func:`plot`) into ``folder``."""
    import json

    from studies.outputs import Table

    folder = Path(folder)
    (folder / "reed_dynamics.json").write_text(json.dumps(as_json(study), indent=2) + "\n")
    (folder / "reed_dynamics.md").write_text(markdown(study))
    csv = Table("reed dynamics", tuple(as_json({"rows": study["rows"]})["rows"])).write(folder / "reed_dynamics_runs")
    return [folder / "reed_dynamics.json", folder / "reed_dynamics.md", csv[0], *plot(study, folder)]


def render(study: dict) -> str:
    """The per-reed verdicts as text, and the numerical part of the differences."""
    lines = [f"reed dynamics against the reference (tolerances {DELIVERY_TOL * 100:g} % delivery, "
             f"{ANGLE_TOL_DEG:g} deg timing):"]
    for s in study["reeds"]:
        need = f"more than {MODES[-1]}" if s["modes_needed"] is None else str(s["modes_needed"])
        lines.append(f"  {s['reed']} ({s['why']}; reference {s['reference']}): eq 3.21 "
                     f"{_fmt(s['one_mode_worst_delivery_pct'], '.3f')} % / {_fmt(s['one_mode_worst_angle_deg'], '.2f')} deg -> "
                     f"{'enough' if s['one_mode_enough'] else 'not enough'}; modes needed: {need}")
    for n in study.get("numerics", []):
        lines.append(f"  numerics ({n['reed']}, {n['case']}, {n['model']}): fast vs reference stepper "
                     f"{n['fast_vs_reference_pct']:+.4f} % / {n['fast_vs_reference_deg']:.3f} deg")
    return "\n".join(lines)


# --------------------------------------------------------------------------- the validation chain's part
def prototype_adequacy(quick: bool = False, progress: bool = True) -> dict:
    """Is the one-mode model (eq 3.21) adequate for the prototype reed? Eq 3.21, the modal reed with N = 1, 2,
    3, 6 (beam modes) and the whole FE reed at the operating point ``VALIDATE_CASE`` of Table 5.6 (one point:
    the FE reed runs on the reference stepper), with the numerical part of the differences (the six-mode
    reed on both steppers). ``quick``: no FE reed, the six-mode reed is the reference (cheaper; says so).
    Returns {"case", "reference", "note", "rows", "summary"}."""
    from geometry import load_reed
    from studies.validation.chain import cases as all_cases

    op = next(c for c in all_cases(valve="reed") if case_label(c) == VALIDATE_CASE)
    reed = load_reed("prototype")
    case = ReedCase("prototype", reed, "beam", {}, "the thesis's reed", reed.length / VALIDATE_FE_ELEMENTS)
    reference = f"modal{MODES[-1]}" if quick else "fe"
    counter = _Progress(len(MODES) + (1 if quick else 2) + 1, progress)
    by_label, _ = run_point(case, op, method="fast", models=variants(case, fe=not quick), progress=counter)
    _against(by_label, reference)
    numerics = _numerics(case, op, by_label[f"modal{MODES[-1]}"], 3, "fast")
    counter(case.name, "numerics")
    counter.done()
    rows = list(by_label.values())
    summary = _summary(case, rows, numerics, reference)
    note = (f"one operating point of Table 5.6 ({VALIDATE_CASE.replace('_', ' ')}, {op['speed_rpm']:.0f} rpm, "
            f"{op['load_pressure'] / 1e6:.2f} MPa): the whole FE reed runs on the reference stepper, with "
            f"{_fe_mesh_note(case)}; valvelab check prototype --dynamics compares the six")
    if quick:
        note = note.split(": the whole")[0] + "; quick: no FE reed, the six-mode reed is the reference (cheaper)"
    return as_json({"case": VALIDATE_CASE, "reference": reference, "quick": quick, "note": note,
                    "rows": [_adequacy_row(r) for r in rows], "summary": summary})


def _fe_mesh_note(case: ReedCase) -> str:
    """The FE reed's elements and how far its first three frequencies are from the default mesh's."""
    from lumped.reed.modal_basis import fe_reed

    coarse, default = fe_reed(case.reed, None, "beam", case.fe_mesh), fe_reed(case.reed, None, "beam")
    off = np.max(np.abs(coarse.modes()[0][:3] / default.modes()[0][:3] - 1.0))
    return (f"{VALIDATE_FE_ELEMENTS} beam elements ({coarse.mass.shape[0]} DOFs; its first three frequencies within "
            f"{off:.1e} of the default mesh's {default.mass.shape[0]} DOFs)")


def _adequacy_row(r: dict) -> dict:
    """A run's row for the validation chain's table (units in the keys)."""
    keys = ("model", "method", "delivery_cc", "delivery_vs_reference_pct", "worst_angle_vs_reference_deg",
            "inlet_opening_deg", "inlet_closing_deg", "delivery_opening_deg", "delivery_closing_deg",
            "delivery_peak_opening_mm", "delivery_seat_impact_m_s")
    return {k: r[k] for k in keys}


def adequacy_words(result: dict) -> str:
    """The verdict of :func:`prototype_adequacy` in one sentence, with the numerical part."""
    s = result["summary"]
    ref = "the whole FE reed" if result["reference"] == "fe" else "the six-mode reed"
    enough = "adequate" if s["one_mode_enough"] else "not adequate"
    return (f"the one-mode model (eq 3.21) is {enough} for the prototype reed: {s['one_mode_worst_delivery_pct']:.3f} % "
            f"delivery and {s['one_mode_worst_angle_deg']:.3f} deg timing from {ref} (tolerances "
            f"{DELIVERY_TOL * 100:g} %, {ANGLE_TOL_DEG:g} deg; numerics {s['numerical_pct']:.2g} %, "
            f"{s['numerical_deg']:.2g} deg)")


def write_adequacy(result: dict, stem) -> list[Path]:
    """``stem.md`` and ``stem.csv``: the rows of :func:`prototype_adequacy` with its verdict and note."""
    from studies.outputs import Table

    title = "One mode against N modes and the whole FE reed: the prototype reed in the pump"
    return Table(title, tuple(result["rows"]), (adequacy_words(result), result["note"])).write(Path(stem))
