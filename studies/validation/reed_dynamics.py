"""When is one mode enough? The reed valve in the pump with 1..6 modes against the whole FE reed.

:func:`dynamics_study` runs the reed pump (thesis-reed's flow and damping data, Table 3.13) with a
reed geometry at both valves, on the six operating points of Table 5.6, with the thesis's one-mode
model (eq 3.21), the modal reed with N modes and the whole FE reed (lumped/reed_dynamics.py), and
tabulates per case and model: delivery, each valve's opening and closing angle, peak opening, seat
and stop impact speeds, and the peak root stress (the solid FEA's stress per unit tip deflection
under a uniform pressure, fea.reed_stress.max_opening_stress, times the peak opening, as the reed
stress check does). Per reed it says how many modes are needed for 0.1 % delivery and 0.5 deg
timing against the reference, and whether eq 3.21's one mode is enough.

The reference is the whole FE reed on the reference stepper (beam elements: bending only). A
reed whose port sits off its axis twists, which only the plate and solid fidelities carry; the
whole plate FE reed (~900 DOFs) is not affordable in the pump, so there the reference is the
plate's modal reed with six modes, and the convergence in N says how far that holds.
"""

from __future__ import annotations

import math
import sys
import tomllib
from dataclasses import dataclass, field

import numpy as np

#: modal reeds tried (modes), besides eq 3.21 and the FE reed
MODES = (1, 2, 3, 6)
#: the fast stepper's rtol in the study (its default, 1e-3, leaves 0.01-0.4 % on a six-mode reed)
FAST_RTOL = 1e-5
#: a model "needs" N modes when every case is within these of the reference
DELIVERY_TOL = 1e-3
ANGLE_TOL_DEG = 0.5
#: the outputs compared, per valve: (name, attribute of lumped.cycle.ValveResult, scale to the table's unit)
VALVE_OUTPUTS = (("opening_deg", "opening_angle", 180 / math.pi), ("closing_deg", "closing_angle", 180 / math.pi),
                 ("peak_opening_mm", "peak_opening", 1e3), ("seat_impact_m_s", "seat_impact_velocity", 1.0),
                 ("stop_impact_m_s", "stop_impact_velocity", 1.0))


@dataclass(frozen=True)
class ReedCase:
    """A reed to study: its name, geometry (a geometry.Reed), fidelity, the port footprint keys (none: the whole
    face) and why it is in the study."""

    name: str
    reed: object
    fidelity: str = "beam"
    port: dict = field(default_factory=dict)
    why: str = ""

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


def study_reeds(reed) -> list[ReedCase]:
    """The reed and three made from it where one mode should fail: twice as long and half as thick
    (Reed.scaled), a port off its axis (torsion, plate modes), and a heavy tip (Reed.with_heavy_tip: the
    rounded tip three times as thick)."""
    return [
        ReedCase(reed.name, reed, "beam", {}, "the reed as given"),
        ReedCase("long_thin", reed.scaled(2.0, 0.5, name="long_thin"), "beam", {},
                 "twice as long, half as thick: its frequencies fall 8x toward the pump's"),
        ReedCase("off_axis_port", reed, "plate", off_axis_port(reed), "a port off the reed's axis: the load twists it"),
        ReedCase("heavy_tip", reed.with_heavy_tip(3.0, name="heavy_tip"), "beam", {},
                 "its tip three times as thick: more of its mass where the first mode moves most"),
    ]


def _model(case: ReedCase, dynamics: str, modes: int | None = None):
    from geometry.reed_io import reed_to_toml
    from lumped import load_model, with_values

    values = {"valves.geometry": tomllib.loads(reed_to_toml(case.reed))["reed"], "valves.fidelity": case.fidelity}
    if dynamics != "one-mode":
        values["valves.dynamics"] = dynamics
        values.update({f"valves.port.{k}": v for k, v in case.port.items()})
    if modes is not None:
        values["valves.modes"] = modes
    return with_values(load_model("thesis-reed"), values)


def variants(case: ReedCase) -> list[tuple[str, dict]]:
    """(label, how) of the models compared: eq 3.21, N modes, the reference."""
    out = [("one-mode", {"dynamics": "one-mode"})]
    out += [(f"modal{n}", {"dynamics": "modal", "modes": n}) for n in MODES]
    if case.reference == "fe":
        out.append(("fe", {"dynamics": "fe"}))
    return out


def _row(label: str, res) -> dict:
    row = {"model": label, "delivery_cc": res.delivery_per_rev * 1e6, "steps": res.steps,
           "stop_contacts": res.delivery.stop_contacts + res.inlet.stop_contacts}
    for pos, v in res.valves.items():
        for name, attr, scale in VALVE_OUTPUTS:
            val = getattr(v, attr)
            row[f"{pos}_{name}"] = None if val is None else val * scale
    return row


def _angle_diff(a, b) -> float:
    if a is None or b is None:
        return 0.0 if a is None and b is None else math.inf
    d = abs(a - b) % 360.0
    return min(d, 360.0 - d)


def dynamics_study(reeds: list[ReedCase] | None = None, cases=None, revolutions: int = 3, progress: bool = True,
                   stress: bool = True, traces: bool = True, rtol: float = FAST_RTOL) -> dict:
    """Run the study (see the module docstring); returns {"reeds": [...], "rows": [...], "numerics": [...],
    "traces": {...}}.

    ``cases``: the operating points (dicts with speed_rpm, load_pressure, air_content; default the six of
    Table 5.6); ``stress``: compute the peak root stress from the solid FEA (a static solve per reed);
    ``rtol``: the fast stepper's tolerance for eq 3.21 and the modal reeds (the FE reed runs on the
    reference stepper). The study compares model forms, so its numerics must sit well below its 0.1 %:
    per reed the first case's richest modal reed runs on the reference stepper too, and ``numerics``
    reports the difference.
    """
    from geometry import load_reed
    from lumped import simulate
    from studies.validation.chain import cases as all_cases

    reeds = study_reeds(load_reed("prototype")) if reeds is None else reeds
    cases = all_cases(valve="reed") if cases is None else cases
    rows, summaries, traces_out, numerics = [], [], {}, []
    total = len(reeds) * len(cases) * (len(MODES) + 2)
    done = 0
    for case in reeds:
        sigma = _stress_per_tip(case.reed) if stress else None
        case_rows = []
        for c in cases:
            by_label = {}
            for label, how in variants(case):
                model = _model(case, how["dynamics"], how.get("modes"))
                tol = {"method": "reference"} if how["dynamics"] == "fe" else {"method": "fast", "rtol": rtol}
                trace = traces and c is cases[0]
                res = simulate(model, c["speed_rpm"], c["load_pressure"], air_content=c["air_content"],
                               revolutions=revolutions, trace=trace, trace_points=720, **tol)
                row = {"reed": case.name, "case": f"{c['condition']}_{c['measured_valve']}",
                       "speed_rpm": c["speed_rpm"], "load_pressure_pa": c["load_pressure"],
                       "method": tol["method"], **_row(label, res)}
                if sigma is not None:
                    row["peak_root_stress_mpa"] = sigma * max(v.peak_opening for v in res.valves.values()) / 1e6
                by_label[label] = row
                if trace:
                    traces_out.setdefault(case.name, {})[label] = (res.trace, _participation(model, res))
                done += 1
                if progress:
                    sys.stderr.write(f"\rreed dynamics: {done}/{total} runs ({case.name}, {label})   ")
                    sys.stderr.flush()
            ref = by_label["fe" if case.reference == "fe" else "modal6"]
            for row in by_label.values():
                row["reference"] = ref["model"]
                row["delivery_vs_reference_pct"] = (row["delivery_cc"] / ref["delivery_cc"] - 1.0) * 100.0
                row["worst_angle_vs_reference_deg"] = max(
                    _angle_diff(row[f"{pos}_{n}"], ref[f"{pos}_{n}"]) for pos in ("inlet", "delivery")
                    for n in ("opening_deg", "closing_deg"))
            case_rows += list(by_label.values())
            if c is cases[0]:
                numerics.append(_numerics(case, c, by_label[f"modal{MODES[-1]}"], revolutions))
        rows += case_rows
        summaries.append(_summary(case, case_rows))
    if progress:
        sys.stderr.write("\n")
    return {"reeds": summaries, "rows": rows, "numerics": numerics, "traces": traces_out,
            "tolerances": {"delivery_pct": DELIVERY_TOL * 100, "angle_deg": ANGLE_TOL_DEG, "fast_rtol": rtol}}


def _numerics(case: ReedCase, c: dict, fast_row: dict, revolutions: int) -> dict:
    """The richest modal reed of the first case on the reference stepper against the fast run: the numerical
    part of every difference the study reports."""
    from lumped import simulate

    res = simulate(_model(case, "modal", MODES[-1]), c["speed_rpm"], c["load_pressure"], method="reference",
                   air_content=c["air_content"], revolutions=revolutions)
    ref = _row(f"modal{MODES[-1]}", res)
    return {"reed": case.name, "case": fast_row["case"], "model": ref["model"],
            "fast_vs_reference_pct": (fast_row["delivery_cc"] / ref["delivery_cc"] - 1.0) * 100.0,
            "fast_vs_reference_deg": max(_angle_diff(fast_row[f"{pos}_{n}"], ref[f"{pos}_{n}"])
                                         for pos in ("inlet", "delivery") for n in ("opening_deg", "closing_deg"))}


def _summary(case: ReedCase, rows: list[dict]) -> dict:
    """How many modes a reed needs for 0.1 % delivery and 0.5 deg timing against its reference, over the cases."""
    def worst(label):
        mine = [r for r in rows if r["model"] == label]
        return (max(abs(r["delivery_vs_reference_pct"]) for r in mine),
                max(r["worst_angle_vs_reference_deg"] for r in mine))

    one = worst("one-mode")
    needed = next((n for n in MODES if worst(f"modal{n}")[0] <= DELIVERY_TOL * 100
                   and worst(f"modal{n}")[1] <= ANGLE_TOL_DEG), None)
    return {"reed": case.name, "why": case.why, "fidelity": case.fidelity, "reference": case.reference,
            "port": case.port or None,
            "one_mode_worst_delivery_pct": one[0], "one_mode_worst_angle_deg": one[1],
            "one_mode_enough": one[0] <= DELIVERY_TOL * 100 and one[1] <= ANGLE_TOL_DEG,
            "modes_needed": needed,
            "modal_worst": {f"modal{n}": dict(zip(("delivery_pct", "angle_deg"), worst(f"modal{n}"))) for n in MODES}}


def _stress_per_tip(reed) -> float:
    """Root (von Mises, away from the clamp) stress per unit tip deflection under a uniform pressure [Pa/m]
    (the solid FEA of fea.reed_stress)."""
    from fea.reed_stress import max_opening_stress

    check = max_opening_stress(reed, x_stop=1e-3)
    return check.max_von_mises_away_from_clamp / 1e-3


def _participation(model, res) -> list | None:
    """The names of the delivery valve's modes (modal only; their shares of the opening are in the trace:
    lumped.postprocess.trace)."""
    from lumped.reed_dynamics import structure

    v = model.delivery
    if getattr(v, "dynamics", "one-mode") != "modal" or res.trace is None:
        return None
    return list(structure(v, model.oil.density).kinds)


def plot(study: dict, folder) -> list:
    """Per reed: the delivery valve's opening over a revolution for every model [mm vs deg], and the six-mode
    reed's modal participation (each mode's share e_i q_i of the opening) over the cycle."""
    import matplotlib

    matplotlib.use("Agg")
    from pathlib import Path

    import matplotlib.pyplot as plt

    out = []
    for reed, by_label in study["traces"].items():
        fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 7), sharex=True, constrained_layout=True)
        for label, (tr, _) in by_label.items():
            ax.plot(tr.crank_deg, tr.delivery_position * 1e3, lw=2.0 if label in ("fe", "one-mode") else 1.0,
                    ls="--" if label == "one-mode" else "-", label=label)
        ax.set_ylabel("delivery reed opening x [mm]")
        ax.set_title(f"{reed}: delivery valve opening by reed model (first case)")
        ax.legend(fontsize=8)
        tr, kinds = by_label.get("modal6", (None, None))
        if tr is not None and kinds:
            for i, kind in enumerate(kinds):
                bx.plot(tr.crank_deg, getattr(tr, f"delivery_mode{i + 1}_position") * 1e3, label=kind)
            bx.legend(fontsize=8)
        bx.set_xlabel("crank angle from TDC [deg]")
        bx.set_ylabel("share of the opening e_i q_i [mm]")
        bx.set_title("modal participation, six modes")
        path = Path(folder) / f"reed_dynamics_{reed}.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        out.append(path)
    return out


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


def _fmt(v, spec: str) -> str:
    return "n/a (opens in one model only)" if v is None or not math.isfinite(v) else format(v, spec)


def render(study: dict) -> str:
    """The per-reed verdicts as text, and the numerical part of the differences."""
    lines = [f"reed dynamics against the reference (tolerances {DELIVERY_TOL * 100:g} % delivery, "
             f"{ANGLE_TOL_DEG:g} deg timing):"]
    for s in study["reeds"]:
        need = "none of 1, 2, 3, 6" if s["modes_needed"] is None else str(s["modes_needed"])
        lines.append(f"  {s['reed']} ({s['why']}; reference {s['reference']}): one mode "
                     f"{_fmt(s['one_mode_worst_delivery_pct'], '.3f')} % / {_fmt(s['one_mode_worst_angle_deg'], '.2f')} deg -> "
                     f"{'enough' if s['one_mode_enough'] else 'not enough'}; modes needed: {need}")
    for n in study.get("numerics", []):
        lines.append(f"  numerics ({n['reed']}, {n['case']}, {n['model']}): fast vs reference stepper "
                     f"{n['fast_vs_reference_pct']:+.4f} % / {n['fast_vs_reference_deg']:.3f} deg")
    return "\n".join(lines)

