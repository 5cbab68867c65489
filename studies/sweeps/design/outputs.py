"""The outputs a sensitivity or optimisation spec may name, with their units (CONTRACT.md).

Each output is read from one row of the evaluation table (one design at one operating
point, the columns of :mod:`studies.sweeps.design.evaluate`). SI columns are converted only
where the name says so (``delivery_cc_per_rev``, ``*_mm``, ``*_deg``, ``*_mpa``, ``*_mj``).

Valve angles are unwrapped so that a valve closing around top dead centre gives a
continuous output: inlet angles lie in [0, 360) deg from TDC; delivery angles in
[180, 540) deg (an event just after the next TDC reads 360 + its angle). ``valvelab
pump`` prints the wrapped angles in [0, 360).

``kind``: ``point`` (depends on the operating point) or ``design`` (the same at every
operating point: the reed's kappa, omega and bending stress at maximum lift).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lumped.model.pump_model import POSITIONS


@dataclass(frozen=True)
class Output:
    """One named output: how to read it from an evaluation row, its unit and label."""

    name: str
    unit: str
    label: str
    columns: tuple[str, ...]          # evaluation columns it is made from
    scale: float = 1.0
    combine: str = "one"              # one | max (the max of the columns present) | angle_inlet | angle_delivery
    kind: str = "point"

    def value(self, row) -> float | None:
        """The output from an evaluation row (a mapping); None if missing (a valve that never opens, a disc's stress)."""
        vals = []
        for c in self.columns:
            v = row.get(c) if hasattr(row, "get") else row[c]
            if v is None or (isinstance(v, float) and math.isnan(v)):
                continue
            vals.append(float(v))
        if not vals:
            return None
        if self.combine in ("one", "angle_inlet", "angle_delivery"):
            if len(vals) != len(self.columns):
                return None
            v = vals[0]
            if self.combine == "angle_delivery" and v < math.pi:
                v += 2 * math.pi
            return v * self.scale
        return max(vals) * self.scale

    @property
    def axis_label(self) -> str:
        return f"{self.label} [{self.unit}]"


def _pump_catalogue() -> dict[str, Output]:
    out: list[Output] = [
        Output("delivery_cc_per_rev", "cc/rev", "delivery per revolution", ("delivery_m3_per_rev",), 1e6),
        Output("delivery_m3_per_rev", "m^3/rev", "delivery per revolution", ("delivery_m3_per_rev",)),
        Output("volumetric_efficiency", "-", "volumetric efficiency", ("volumetric_efficiency",)),
        Output("valve_loss_j", "J/rev", "valve throttling loss (both valves)", ("valve_loss_j",)),
        Output("valve_loss_mj", "mJ/rev", "valve throttling loss (both valves)", ("valve_loss_j",), 1e3),
        Output("min_cylinder_pressure_pa", "Pa", "minimum cylinder pressure", ("min_cylinder_pressure_pa",)),
        Output("max_cylinder_pressure_pa", "Pa", "maximum cylinder pressure", ("max_cylinder_pressure_pa",)),
        Output("min_cylinder_pressure_mpa", "MPa", "minimum cylinder pressure", ("min_cylinder_pressure_pa",), 1e-6),
        Output("max_cylinder_pressure_mpa", "MPa", "maximum cylinder pressure", ("max_cylinder_pressure_pa",), 1e-6),
        Output("seat_impact_m_s", "m/s", "largest seat impact speed (either valve)",
               ("inlet_seat_impact_m_s", "delivery_seat_impact_m_s"), combine="max"),
        Output("stop_impact_m_s", "m/s", "largest stop impact speed (either valve)",
               ("inlet_stop_impact_m_s", "delivery_stop_impact_m_s"), combine="max"),
        Output("reed_stress_mpa", "MPa", "reed bending stress at maximum lift (either reed valve)",
               ("inlet_reed_stress_pa", "delivery_reed_stress_pa"), 1e-6, combine="max", kind="design"),
        Output("reed_stress_peak_mpa", "MPa", "reed bending stress at the peak opening (either reed valve)",
               ("inlet_reed_stress_peak_pa", "delivery_reed_stress_peak_pa"), 1e-6, combine="max"),
    ]
    for pos in POSITIONS:
        angle = f"angle_{pos}"
        out += [
            Output(f"{pos}_peak_opening_m", "m", f"{pos} valve peak opening", (f"{pos}_peak_opening_m",)),
            Output(f"{pos}_peak_opening_mm", "mm", f"{pos} valve peak opening", (f"{pos}_peak_opening_m",), 1e3),
            Output(f"{pos}_opening_angle_deg", "deg", f"{pos} valve opening crank angle",
                   (f"{pos}_opening_angle_rad",), 180 / math.pi, combine=angle),
            Output(f"{pos}_closing_angle_deg", "deg", f"{pos} valve closing crank angle",
                   (f"{pos}_closing_angle_rad",), 180 / math.pi, combine=angle),
            Output(f"{pos}_opening_angle_rad", "rad", f"{pos} valve opening crank angle",
                   (f"{pos}_opening_angle_rad",), combine=angle),
            Output(f"{pos}_closing_angle_rad", "rad", f"{pos} valve closing crank angle",
                   (f"{pos}_closing_angle_rad",), combine=angle),
            Output(f"{pos}_stop_contacts", "-", f"{pos} valve stop contacts", (f"{pos}_stop_contacts",)),
            Output(f"{pos}_seat_impact_m_s", "m/s", f"{pos} valve seat impact speed", (f"{pos}_seat_impact_m_s",)),
            Output(f"{pos}_stop_impact_m_s", "m/s", f"{pos} valve stop impact speed", (f"{pos}_stop_impact_m_s",)),
            Output(f"{pos}_loss_j", "J/rev", f"{pos} valve throttling loss", (f"{pos}_loss_j",)),
            Output(f"{pos}_reed_stress_mpa", "MPa", f"{pos} reed bending stress at maximum lift",
                   (f"{pos}_reed_stress_pa",), 1e-6, kind="design"),
            Output(f"{pos}_reed_stress_peak_mpa", "MPa", f"{pos} reed bending stress at the peak opening",
                   (f"{pos}_reed_stress_peak_pa",), 1e-6),
            Output(f"{pos}_kappa_pa_m", "Pa/m", f"{pos} reed stiffness kappa", (f"{pos}_kappa_pa_m",), kind="design"),
            Output(f"{pos}_omega_rad_s", "rad/s", f"{pos} reed natural frequency", (f"{pos}_omega_rad_s",),
                   kind="design"),
        ]
    return {o.name: o for o in out}


#: every output of the pump by name
PUMP_OUTPUTS: dict[str, Output] = _pump_catalogue()
#: outputs that need the reed stress calibration
STRESS_OUTPUTS = tuple(n for n in PUMP_OUTPUTS if "reed_stress" in n)


def module_outputs(mod) -> dict[str, Output]:
    """The outputs of a sweep-model module (numeric OUTPUTS; units from its optional ``UNITS``)."""
    units = getattr(mod, "UNITS", {})
    return {n: Output(n, units.get(n, "-"), n, (n,)) for n, k in mod.OUTPUTS.items() if k in ("float64", "int64")}
