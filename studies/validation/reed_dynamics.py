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
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from studies.validation import reed_dynamics_report as report
from studies.validation.reed_dynamics_report import as_json, fmt as _fmt

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
#: wall seconds per simulated revolution of one run on the reference stepper, by model (the six reeds of
#: :func:`study_reeds` at the first two cases of Table 5.6, 3 revolutions, on the project's 2-core machine at
#: load average 7-8: eq 3.21 2.1-7.5 s, modal 1.6-10 s, FE reed 14-22 s per run; medians): the estimate
#: :func:`estimate_seconds` announces
SECONDS_PER_REVOLUTION = {"one-mode": 0.8, "modal": 1.4, "fe": 6.0}
#: wall seconds of the solid FEA behind one reed's peak root stress (same machine and load: 5.7 s)
STRESS_SECONDS = 6.0
#: wall seconds of one fast-stepper run of the numerics check, its compiled solver cached (0.03-0.6 s)
FAST_RUN_SECONDS = 0.5


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
    """A port off a reed's axis, whose load twists the reed.

    s from 0.3 L to 0.8 L, 0.3 of the narrowest width there across, centred a quarter of that
    width off the centre line (inside the outline of any reed).

    Parameters
    ----------
    reed : geometry.reed.Reed

    Returns
    -------
    dict
        ``s_start``, ``s_end``, ``width``, ``y_center`` [m] (the model file's ``valves.port`` keys).
    """
    length = reed.length
    w = float(np.min(reed.width(np.linspace(0.3 * length, 0.8 * length, 101))))
    return {"s_start": 0.3 * length, "s_end": 0.8 * length, "width": 0.3 * w, "y_center": 0.25 * w}


def mid_port(reed) -> dict:
    """A port on a reed's axis near the clamp, where the first mode hardly moves.

    s from 0.1 L to 0.5 L, 0.9 of the narrowest width there across: the static shape of its load
    is far from the first mode's (docs/reed_dynamics.md).

    Parameters
    ----------
    reed : geometry.reed.Reed

    Returns
    -------
    dict
        ``s_start``, ``s_end``, ``width`` [m].
    """
    length = reed.length
    w = float(np.min(reed.width(np.linspace(0.1 * length, 0.5 * length, 101))))
    return {"s_start": 0.1 * length, "s_end": 0.5 * length, "width": 0.9 * w}


def study_reeds(reed) -> list[ReedCase]:
    """The reeds of the study: the reed, and five made from it.

    Three where one mode should fail: twice as long and half as thick (Reed.scaled), a port off
    its axis (torsion, plate modes), a heavy tip (Reed.with_heavy_tip: the rounded tip three
    times as thick); two designed so that it does: three times as long and half as thick, and a
    port on the axis near the clamp (:func:`mid_port`).

    Parameters
    ----------
    reed : geometry.reed.Reed

    Returns
    -------
    list of ReedCase
    """
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
    """The models compared on a reed.

    Parameters
    ----------
    case : ReedCase
    modes : sequence of int
        The modal reeds' numbers of modes.
    fe : bool
        Include the whole FE reed (where it is the reference).

    Returns
    -------
    list of (str, dict)
        (label, how): eq 3.21 (``one-mode``), ``modalN``, ``fe``.
    """
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
    """An operating point's name.

    Parameters
    ----------
    op : dict
        With ``condition`` and ``measured_valve``.

    Returns
    -------
    str
        e.g. ``low_speed_inlet`` (the thesis figure's condition and valve).
    """
    return f"{op['condition']}_{op['measured_valve']}"


def run_point(case: ReedCase, op: dict, revolutions: int = 3, method: str = "reference", trace: bool = False,
              models=None, progress=None) -> tuple[dict, dict]:
    """Every model at one operating point.

    Parameters
    ----------
    case : ReedCase
    op : dict
        ``speed_rpm`` [rpm], ``load_pressure`` [Pa], ``air_content``, ``condition``, ``measured_valve``.
    revolutions : int
    method : str
        The stepper of eq 3.21 and the modal reeds (``fast``: at rtol :data:`FAST_RTOL`); the FE
        reed runs on the reference one.
    trace : bool
        Keep each run's trace.
    models : list, optional
        (label, how) pairs (default :func:`variants`).
    progress : callable, optional
        Called (reed, label) after each run.

    Returns
    -------
    rows : dict
        {label: row}: delivery [cc/rev], each valve's angles [deg], peak opening [mm], impact speeds [m/s].
    traces : dict
        {label: (trace, mode names)} with ``trace``.
    """
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


def estimate_seconds(reeds: list[ReedCase], cases, revolutions: int = 3, stress: bool = True,
                     numerics: bool = True) -> float:
    """The wall time :func:`dynamics_study` is expected to take, from measured per-run costs.

    Parameters
    ----------
    reeds : list of ReedCase
    cases : list of dict
        The operating points.
    revolutions : int
    stress, numerics : bool
        As :func:`dynamics_study`'s.

    Returns
    -------
    float
        Seconds on the project's 2-core machine (:data:`SECONDS_PER_REVOLUTION`, :data:`STRESS_SECONDS`,
        :data:`FAST_RUN_SECONDS`), without the fast stepper's one-off compilation.
    """
    per_case = sum(SECONDS_PER_REVOLUTION[how["dynamics"]] for r in reeds for _, how in variants(r)) * revolutions
    return (per_case * len(cases) + (STRESS_SECONDS * len(reeds) if stress else 0.0)
            + (FAST_RUN_SECONDS * len(reeds) if numerics else 0.0))


def runs_count(reeds: list[ReedCase], cases, stress: bool = True, numerics: bool = True) -> int:
    """The steps :func:`dynamics_study`'s progress counts: every run, each reed's stress FEA and numerics run.

    Parameters
    ----------
    reeds : list of ReedCase
    cases : list of dict
    stress, numerics : bool

    Returns
    -------
    int
    """
    return sum(len(variants(r)) for r in reeds) * len(cases) + len(reeds) * (int(stress) + int(numerics))


def plan_words(reeds: list[ReedCase], cases, revolutions: int = 3, stress: bool = True,
               numerics: bool = True) -> str:
    """What :func:`dynamics_study` will run, in words (announced before it starts).

    Parameters
    ----------
    reeds : list of ReedCase
    cases : list of dict
    revolutions : int
    stress, numerics : bool

    Returns
    -------
    str
        The runs and FEA counted, the reeds, cases and models.
    """
    runs = sum(len(variants(r)) for r in reeds) * len(cases) + (len(reeds) if numerics else 0)
    where = (f"the {reeds[0].name} reed" if len(reeds) == 1 else f"{len(reeds)} reeds") + (
        f" at the first case of Table 5.6 ({case_label(cases[0]).replace('_', ' ')}, {cases[0]['speed_rpm']:.0f} "
        f"rpm, {cases[0]['load_pressure'] / 1e6:.2f} MPa)" if len(cases) == 1 else f" at the {len(cases)} cases of "
                                                                                    "Table 5.6")
    fea = f" and {len(reeds)} solid FEA (root stress)" if stress else ""
    return (f"{runs} pump runs of {revolutions} revolutions{fea}: {where}; models eq 3.21, "
            f"{', '.join(map(str, MODES))} modes and the whole FE reed" + ("; a fast-stepper check per reed"
                                                                          if numerics else ""))


def dynamics_study(reeds: list[ReedCase] | None = None, cases=None, revolutions: int = 3, progress: bool = True,
                   stress: bool = True, traces: bool = True, method: str = "reference",
                   numerics: bool = True) -> dict:
    """Run the study (see the module docstring).

    Parameters
    ----------
    reeds : list of ReedCase, optional
        Default :func:`study_reeds` of the prototype.
    cases : list of dict, optional
        The operating points (default the six of Table 5.6).
    revolutions : int
    progress : bool
        A count of the runs on stderr.
    stress : bool
        The peak root stress from the solid FEA (a static solve per reed).
    traces : bool
        Keep the first case's traces (for :func:`studies.validation.reed_dynamics_report.plot`).
    method : str
        The stepper of eq 3.21 and the modal reeds (the FE reed runs on the reference stepper). The
        study compares model forms, so its numerics must sit well below its 0.1 %: the reference
        stepper (rtol 1e-6) by default; per reed the first case's richest modal reed runs on the
        other stepper too, and ``numerics`` reports the difference.
    numerics : bool
        Run that check (False: ``numerics`` is empty; no fast-stepper run, so no compilation on a fresh
        install).

    Returns
    -------
    dict
        ``reeds`` (per reed: modes needed for 0.1 % delivery and 0.5 deg timing, eq 3.21's worst
        differences), ``rows`` (every run), ``numerics``, ``traces``, ``tolerances``.

    References
    ----------
    Knutson (2016), eq 3.21 (the one-mode reed) and Table 5.6.
    """
    from geometry import load_reed
    from studies.validation.chain import cases as all_cases

    reeds = study_reeds(load_reed("prototype")) if reeds is None else reeds
    cases = all_cases(valve="reed") if cases is None else cases
    rows, summaries, traces_out, checks = [], [], {}, []
    counter = _Progress(runs_count(reeds, cases, stress, numerics), progress)
    for case in reeds:
        case_rows, tr, num = _study_reed(case, cases, revolutions, method, (stress, traces, numerics), counter)
        rows += case_rows
        if num is not None:
            checks.append(num)
        summaries.append(_summary(case, case_rows, num))
        if tr:
            traces_out[case.name] = tr
    counter.done()
    return {"reeds": summaries, "rows": rows, "numerics": checks, "traces": traces_out,
            "tolerances": {"delivery_pct": DELIVERY_TOL * 100, "angle_deg": ANGLE_TOL_DEG, "method": method,
                           "fast_rtol": FAST_RTOL if method == "fast" else None}}


def _study_reed(case: ReedCase, cases, revolutions: int, method: str, what: tuple[bool, bool, bool],
                counter) -> tuple[list, dict, dict | None]:
    """One reed over the cases: (its rows, against its reference and with the peak root stress; the first case's
    traces; the numerical part at the first case), ``what`` = (stress, traces, numerics) asked for."""
    stress, traces, check_numerics = what
    sigma = None
    if stress:
        sigma = _stress_per_tip(case.reed)
        counter(case.name, "root stress (solid FEA)")
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
            if check_numerics:
                numerics = _numerics(case, op, by_label[f"modal{MODES[-1]}"], revolutions, method)
                counter(case.name, "numerics")
    return rows, traces_first, numerics


class _Progress:
    """A count of the steps on stderr (``enabled``), called (reed, label) after each, with the time taken and
    the time left at the mean step so far."""

    def __init__(self, total: int, enabled: bool):
        self.total, self.enabled, self.n = total, enabled, 0
        self.t0 = time.perf_counter()

    def __call__(self, reed: str, label: str) -> None:
        self.n += 1
        if self.enabled:
            took = time.perf_counter() - self.t0
            left = took / self.n * (self.total - self.n)
            sys.stderr.write(f"\rreed dynamics: {self.n}/{self.total} ({reed}, {label}); {took:.0f} s, "
                             f"about {left:.0f} s left   ")
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
def markdown(study: dict) -> str:
    """The study's tables in Markdown (:func:`studies.validation.reed_dynamics_report.markdown`).

    Parameters
    ----------
    study : dict
        :func:`dynamics_study`'s result.

    Returns
    -------
    str
        The verdict per reed, each reed's delivery differences per case [%], and its first case in full.
    """
    return report.markdown(study, MODES)


def write_outputs(study: dict, folder) -> list[Path]:
    """Write the study into a folder.

    Parameters
    ----------
    study : dict
    folder : str or os.PathLike

    Returns
    -------
    list of pathlib.Path
        reed_dynamics.json (without traces), .md (:func:`markdown`), the runs' CSV, the plots.
    """
    import json

    from studies.outputs import Table

    folder = Path(folder)
    (folder / "reed_dynamics.json").write_text(json.dumps(as_json(study), indent=2) + "\n")
    (folder / "reed_dynamics.md").write_text(markdown(study))
    csv = Table("reed dynamics", tuple(as_json({"rows": study["rows"]})["rows"])).write(folder / "reed_dynamics_runs")
    return [folder / "reed_dynamics.json", folder / "reed_dynamics.md", csv[0], *report.plot(study, folder, MODES)]


def render(study: dict) -> str:
    """The per-reed verdicts as text, and the numerical part of the differences.

    Parameters
    ----------
    study : dict

    Returns
    -------
    str
    """
    lines = [f"reed dynamics against the reference (tolerances {DELIVERY_TOL * 100:g} % delivery, "
             f"{ANGLE_TOL_DEG:g} deg timing):"]
    for s in study["reeds"]:
        need = f"more than {MODES[-1]}" if s["modes_needed"] is None else str(s["modes_needed"])
        lines.append(f"  {s['reed']} ({s['why']}; reference {s['reference']}): eq 3.21 (one mode, the whole face "
                     f"loaded) {_fmt(s['one_mode_worst_delivery_pct'], '.3f')} % / "
                     f"{_fmt(s['one_mode_worst_angle_deg'], '.2f')} deg: "
                     f"{'enough' if s['one_mode_enough'] else 'not enough'}; the modal reed (its port's load) needs "
                     f"{need} mode{'' if need == '1' else 's'}")
    for n in study.get("numerics", []):
        lines.append(f"  numerics ({n['reed']}, {n['case']}, {n['model']}): fast vs reference stepper "
                     f"{n['fast_vs_reference_pct']:+.4f} % / {n['fast_vs_reference_deg']:.3f} deg")
    return "\n".join(lines)


# --------------------------------------------------------------------------- the validation chain's part
def prototype_adequacy(quick: bool = False, progress: bool = True) -> dict:
    """Whether the one-mode model (eq 3.21) is adequate for the prototype reed: the validation chain's part.

    Eq 3.21, the modal reed with N = 1, 2, 3, 6 (beam modes) and the whole FE reed at the
    operating point :data:`VALIDATE_CASE` of Table 5.6 (one point: the FE reed runs on the
    reference stepper), with the numerical part of the differences (the six-mode reed on both steppers).

    Parameters
    ----------
    quick : bool
        No FE reed: the six-mode reed is the reference (cheaper; the note says so).
    progress : bool

    Returns
    -------
    dict
        ``case``, ``reference``, ``quick``, ``note``, ``rows`` and ``summary``.
    """
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
    """The verdict of :func:`prototype_adequacy` in one sentence, with the numerical part.

    Parameters
    ----------
    result : dict

    Returns
    -------
    str
    """
    s = result["summary"]
    ref = "the whole FE reed" if result["reference"] == "fe" else "the six-mode reed"
    enough = "adequate" if s["one_mode_enough"] else "not adequate"
    return (f"the one-mode model (eq 3.21) is {enough} for the prototype reed: {s['one_mode_worst_delivery_pct']:.3f} % "
            f"delivery and {s['one_mode_worst_angle_deg']:.3f} deg timing from {ref} (tolerances "
            f"{DELIVERY_TOL * 100:g} %, {ANGLE_TOL_DEG:g} deg; numerics {s['numerical_pct']:.2g} %, "
            f"{s['numerical_deg']:.2g} deg)")


def write_adequacy(result: dict, stem) -> list[Path]:
    """Write the rows of :func:`prototype_adequacy` with its verdict and note.

    Parameters
    ----------
    result : dict
    stem : str or os.PathLike
        The files' path without suffix.

    Returns
    -------
    list of pathlib.Path
        ``stem.csv`` and ``stem.md``.
    """
    from studies.outputs import Table

    title = "One mode against N modes and the whole FE reed: the prototype reed in the pump"
    return Table(title, tuple(result["rows"]), (adequacy_words(result), result["note"])).write(Path(stem))
