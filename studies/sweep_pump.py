"""The piston pump as a sweep model (``model = "pump"`` in a sweep file; protocol in studies/sweep.py).

Inputs, each a factor or a fixed value (SI units; names in CONTRACT.md, "Sweeps"):

- operating point: ``valve`` ("disc" | "reed"), ``speed_rpm``, ``load_pressure`` [Pa, absolute],
  ``air_content`` (R of eq 4.11; default: the thesis's value for the valve type);
- run settings: ``revolutions`` (default 5), ``method`` ("fast", the default, or "reference"),
  ``rtol``, ``atol`` (default: each path's own);
- any parameter of the model: ``inlet.<field>``, ``delivery.<field>`` or ``valves.<field>``
  (both valves) for the fields of :class:`lumped.params.DiscValve` / ``ReedValve``,
  ``pump.<field>`` and ``oil.<field>`` for :class:`~lumped.params.Pump` / ``Oil``, and
  ``effect.<name>`` = true/false for the candidate effects of :data:`lumped.params.EFFECTS`.
  Everything else keeps the thesis configuration (:func:`lumped.params.thesis_model`).

Outputs: delivery per revolution (eq 4.17), volumetric efficiency (delivery / swept volume
2 A_p r), peak openings, opening and closing crank angles (rad from TDC), stop contacts,
cyclic steady state, mass balance error, CPU seconds. ``status`` is "ok", or
"not_cyclic" when the last two revolutions still differ by more than the steady tolerance
(or than rtol, if larger: lumped.pump.steady_threshold; below that it is integration noise).
"""

from __future__ import annotations

import math
from dataclasses import fields, replace

from geometry.errors import InputError
from lumped.params import CIRCUITS, EFFECTS, VALVES, DiscValve, Oil, Pump, ReedValve, set_effect, thesis_model, validate_model

OUTPUTS = {
    "delivery_m3_per_rev": "float64",
    "volumetric_efficiency": "float64",
    "inlet_peak_opening_m": "float64",
    "delivery_peak_opening_m": "float64",
    "inlet_opening_angle_rad": "float64",
    "inlet_closing_angle_rad": "float64",
    "delivery_opening_angle_rad": "float64",
    "delivery_closing_angle_rad": "float64",
    "inlet_stop_contacts": "int64",
    "delivery_stop_contacts": "int64",
    "cyclic_steady": "bool",
    "cycle_change": "float64",
    "mass_balance_error": "float64",
    "revolutions_run": "int64",
    "cpu_seconds": "float64",
}
MAIN_RESPONSES = ("delivery_m3_per_rev", "volumetric_efficiency", "delivery_peak_opening_m")
REQUIRED = ("valve", "speed_rpm", "load_pressure")
OPERATING = ("valve", "speed_rpm", "load_pressure", "air_content", "revolutions", "method", "rtol", "atol",
             "circuit")
COMPONENTS = {"inlet": (DiscValve, ReedValve), "delivery": (DiscValve, ReedValve),
              "valves": (DiscValve, ReedValve), "pump": (Pump,), "oil": (Oil,)}
_FIXED_FIELDS = {"position"}  # identity, not a parameter


def _field(kinds, name):
    for k in kinds:
        for f in fields(k):
            if f.name == name and name not in _FIXED_FIELDS:
                return f
    return None


def _positive(name, v, integer=False):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise InputError(name, f"must be a positive number, got {v!r}")
    if integer and int(v) != v:
        raise InputError(name, f"must be an integer, got {v!r}")


def check(name: str, value) -> None:
    """Vet one input (name and value) before a sweep runs; InputError names what is wrong."""
    if name == "valve":
        if value not in VALVES:
            raise InputError(name, f"expected one of {', '.join(VALVES)}, got {value!r}")
    elif name in ("speed_rpm", "load_pressure"):
        _positive(name, value)
    elif name == "air_content":
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < 1:
            raise InputError(name, f"must be a volume fraction in [0, 1), got {value!r}")
    elif name == "revolutions":
        _positive(name, value, integer=True)
        if value < 2:
            raise InputError(name, "must be at least 2 (cyclic steady state compares two revolutions)")
    elif name in ("rtol", "atol"):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < 1:
            raise InputError(name, f"must be in (0, 1), got {value!r}")
    elif name == "method":
        if value not in ("fast", "reference"):
            raise InputError(name, f"expected 'fast' or 'reference', got {value!r}")
    elif name == "circuit":
        if value not in CIRCUITS:
            raise InputError(name, f"expected one of {', '.join(CIRCUITS)}, got {value!r}")
    elif "." in name:
        comp, attr = name.split(".", 1)
        if comp == "effect":
            if attr not in EFFECTS:
                raise InputError(name, f"unknown effect; expected one of {', '.join(EFFECTS)}")
            if not isinstance(value, bool):
                raise InputError(name, f"must be true or false, got {value!r}")
            return
        if comp not in COMPONENTS:
            raise InputError(name, f"unknown component {comp!r}; expected one of "
                                   f"{', '.join([*COMPONENTS, 'effect'])}")
        f = _field(COMPONENTS[comp], attr)
        if f is None:
            raise InputError(name, f"{attr!r} is not a parameter of {comp}")
        # apply it to the thesis model of each valve type that has it: the model's own checks
        for valve in VALVES:
            try:
                _apply(thesis_model(valve), {name: value})
            except _NotForValve:
                continue
    else:
        raise InputError(name, "unknown input; expected an operating input (" + ", ".join(OPERATING)
                         + ") or a parameter such as inlet.<field>, pump.<field>, effect.<name>")


class _NotForValve(Exception):
    pass


def _apply(model, params: dict):
    """``model`` with the dotted parameter overrides applied, validated (InputError on a bad value)."""
    for name, value in params.items():
        comp, attr = name.split(".", 1)
        if comp == "effect":
            model = set_effect(model, attr, bool(value))
            continue
        targets = ("inlet", "delivery") if comp == "valves" else (comp,)
        for t in targets:
            obj = getattr(model, t)
            f = next((f for f in fields(obj) if f.name == attr), None)
            if f is None:
                raise _NotForValve(name)
            old = getattr(obj, attr)
            if isinstance(old, bool) != isinstance(value, bool) or (isinstance(old, str) != isinstance(value, str)):
                raise InputError(name, f"must be of the type of {old!r}, got {value!r}")
            if isinstance(old, float) and isinstance(value, int):
                value = float(value)
            model = replace(model, **{t: replace(obj, **{attr: value})})
    try:
        validate_model(model)
    except InputError as exc:
        raise InputError(next(iter(params)) if len(params) == 1 else exc.field, exc.message) from None
    return model


def build_model(design: dict):
    """The PumpModel of a design: the thesis model of its valve type with its parameters applied."""
    valve = design["valve"]
    params = {k: v for k, v in design.items() if "." in k}
    try:
        return _apply(thesis_model(valve), params)
    except _NotForValve as exc:
        raise InputError(str(exc), f"is not a parameter of {valve} valves") from None


def evaluate(design: dict) -> dict:
    """Simulate one design (fast path by default) and return the sweep outputs."""
    for r in REQUIRED:
        if r not in design:
            raise InputError(r, "missing: give it as a factor or in [fixed]")
    model = build_model(design)
    method = design.get("method", "fast")
    if method == "fast":
        from lumped.pump_fast import simulate
    else:
        from lumped.pump import simulate
    kw = {k: design[k] for k in ("rtol", "atol") if k in design}
    res = simulate(design["valve"], float(design["speed_rpm"]), float(design["load_pressure"]),
                   air_content=design.get("air_content"), revolutions=int(design.get("revolutions", 5)),
                   circuit=design.get("circuit", "simplified"), params=model, **kw)
    (oi, od), (ci, cd) = res.opening_angle, res.closing_angle
    return {
        "delivery_m3_per_rev": res.delivery_per_rev,
        "volumetric_efficiency": res.delivery_per_rev / model.pump.displacement,
        "inlet_peak_opening_m": res.peak_opening[0],
        "delivery_peak_opening_m": res.peak_opening[1],
        "inlet_opening_angle_rad": oi, "inlet_closing_angle_rad": ci,
        "delivery_opening_angle_rad": od, "delivery_closing_angle_rad": cd,
        "inlet_stop_contacts": res.stop_contacts[0], "delivery_stop_contacts": res.stop_contacts[1],
        "cyclic_steady": res.cyclic_steady, "cycle_change": res.cycle_change,
        "mass_balance_error": res.mass_balance_error, "revolutions_run": res.revolutions,
        "cpu_seconds": res.cpu_seconds,
        "status": "ok" if res.cyclic_steady else "not_cyclic",
    }
