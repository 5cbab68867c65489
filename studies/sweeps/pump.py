"""The piston pump as a sweep model (``model = "pump"`` or a pump model in a sweep file; protocol in studies/sweeps/sweep.py).

Inputs, each a factor or a fixed value (SI units; names in CONTRACT.md, "Sweeps"):

- the pump model: ``model`` (a shipped name or a model file; the sweep file's ``[sweep]
  model`` when that names a pump model), or ``valve`` ("disc" | "reed": the thesis model
  of that valve type);
- operating point: ``speed_rpm``, ``load_pressure`` [Pa, absolute] (default: the model's
  ``[operating]``), ``air_content`` (R of eq 4.11; default: the model's);
- run settings: how many revolutions (below), ``method`` ("fast", the default, or
  "reference"), ``rtol``, ``atol``, ``circuit``;
- any key of the model file by its path (:func:`lumped.model.model_file.with_values`):
  ``pump.dead_volume``, ``valves.delivery.spring.stiffness``, ``valves.spring.stiffness``
  (both valves), ``valves.delivery.geometry.thickness`` (a reed's geometry),
  ``effects.seat_compliance.delivery.k_seat``, ``effects.piston_leakage = true|false``.
  The names of the first sweep files (``inlet.<field>``, ``delivery.<field>``,
  ``valves.<field>`` with the Python field names, ``effect.<name>``) are translated.

How many revolutions: by default each design runs until the cyclic steady-state test passes
(:meth:`lumped.run.revolutions.StopRule.steady`: the relative change of the delivery and of the
state at TDC between the last two revolutions below ``steady_tol``, default 1e-3, or the
integrator's rtol if larger; the last revolution is then within 1e-4 of the cycle, the map
contracting by a factor 10 or more per revolution), two revolutions at least and ``max_revolutions`` (default
:data:`MAX_REVOLUTIONS`) at most, and starts from the TDC state predicted from the nearest designs
already solved in its batch (a warm start, :mod:`studies.sweeps.locality`; the batch's first design
starts from today's start; ``warm_start = false``: every design from today's start, so that its
answer does not depend on the batch it ran in). A warm-started design may stop after its first
revolution, when the state at TDC it ends with is the state it started from to a fifth of the
tolerance (:class:`lumped.run.revolutions.StopRule` ``single``; ``one_revolution = false``: two at
least). ``revolutions`` alone is a fixed count, as in the first sweep files; with
``max_revolutions`` it is the least number (above two, no run stops after one).

Outputs: delivery per revolution (eq 4.17), volumetric efficiency, per valve the peak
opening, opening and closing crank angles (rad from TDC), stop contacts, the largest
impact speeds on the seat and the stop, the energy dissipated by throttling per revolution, then the
cylinder pressure extremes, cyclic steady state, its residual ``cycle_change``, the revolutions
run, ``warm_started`` (whether the design started from a neighbour's state), mass balance error, CPU seconds, and
``warnings``: the result's validity warnings (lumped.validity) as JSON text, ``[]`` when none.
``status`` is "ok", or "not_cyclic" when the last two revolutions still differ by more
than the steady tolerance (or than rtol, if larger), or "outside" when the input
``on_warning = "exclude"`` is given and the result carries a warning (``"flag"``, the
default, keeps such designs "ok" with their warnings in the column).
"""

from __future__ import annotations

import json
import math
from functools import lru_cache

from geometry.declare import specs
from geometry.errors import InputError

#: the sweep's output columns and their dtypes (CONTRACT.md, "Sweeps")
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
    "inlet_seat_impact_m_s": "float64",
    "delivery_seat_impact_m_s": "float64",
    "inlet_stop_impact_m_s": "float64",
    "delivery_stop_impact_m_s": "float64",
    "inlet_loss_j": "float64",
    "delivery_loss_j": "float64",
    "valve_loss_j": "float64",
    "min_cylinder_pressure_pa": "float64",
    "max_cylinder_pressure_pa": "float64",
    "cyclic_steady": "bool",
    "cycle_change": "float64",
    "mass_balance_error": "float64",
    "revolutions_run": "int64",
    "warm_started": "bool",
    "cpu_seconds": "float64",
    "warnings": "string",
}
#: the units of the numeric outputs and operating inputs (plot axes; SI, as the names say)
UNITS = {"delivery_m3_per_rev": "m^3/rev", "volumetric_efficiency": "-", "valve_loss_j": "J/rev",
         "min_cylinder_pressure_pa": "Pa", "max_cylinder_pressure_pa": "Pa", "cycle_change": "-",
         "mass_balance_error": "-", "revolutions_run": "-", "cpu_seconds": "s",
         **{f"{pos}_{k}": u for pos in ("inlet", "delivery") for k, u in (
             ("peak_opening_m", "m"), ("opening_angle_rad", "rad"), ("closing_angle_rad", "rad"),
             ("stop_contacts", "-"), ("seat_impact_m_s", "m/s"), ("stop_impact_m_s", "m/s"), ("loss_j", "J/rev"))},
         "speed_rpm": "rpm", "load_pressure": "Pa", "air_content": "-", "revolutions": "-", "max_revolutions": "-",
         "steady_tol": "-", "rtol": "-", "atol": "-"}
#: what a design with a validity warning becomes: "flag" (status ok, warnings in their column) or "exclude"
ON_WARNING = ("flag", "exclude")
MAIN_RESPONSES = ("delivery_m3_per_rev", "volumetric_efficiency", "delivery_peak_opening_m")
REQUIRED = ()
OPERATING = ("model", "valve", "speed_rpm", "load_pressure", "air_content", "revolutions", "max_revolutions",
             "steady_tol", "warm_start", "one_revolution", "method", "rtol", "atol", "circuit", "on_warning",
             "accuracy_check")
#: the most revolutions a design runs to reach cyclic steady state (unless ``max_revolutions``)
MAX_REVOLUTIONS = 10
#: the steady-state test's tolerance (floored at the integrator's rtol) unless ``steady_tol``: lumped's
#: STEADY_TOL (the last revolution's delivery then within 1e-4 of the cycle's)
from lumped.run.revolutions import STEADY_TOL  # noqa: E402


# --------------------------------------------------------------------------- names of the first sweep files
@lru_cache(maxsize=None)
def _legacy_fields() -> dict:
    """Python field name -> model-file key of the valve kinds, pump and oil (from the declarations)."""
    from lumped.fluid.oil import Oil
    from lumped.model.pump import Pump
    from lumped.valves.kind import KINDS

    out = {"pump": {n: s.key for n, s in specs(Pump) if s.key}, "oil": {n: s.key for n, s in specs(Oil) if s.key},
           "valve": {}}
    for k in KINDS.values():
        out["valve"].update({n: s.key for n, s in specs(k.params) if s.key})
    out["oil"]["density_atm"] = "density"
    return out


def translate(name: str) -> str:
    """The model key path of an input name.

    Parameters
    ----------
    name : str
        A key path, or a first-version name (``delivery.compliant_seat_stiffness``, ``effect.piston_leakage``,
        ``inlet.spring_stiffness``).

    Returns
    -------
    str
        ``effects.seat_compliance.delivery.k_seat``, ``effects.piston_leakage``, ``valves.inlet.spring.stiffness``;
        a name that is no first-version name unchanged.

    Examples
    --------
    >>> translate("effect.piston_leakage")
    'effects.piston_leakage'
    """
    comp, _, attr = name.partition(".")
    if comp == "effect":
        return f"effects.{attr}"
    fields = _legacy_fields()
    if comp in ("inlet", "delivery", "valves") and attr and "." not in attr:
        where = "valves" if comp == "valves" else f"valves.{comp}"
        if attr in ("compliant_seat_stiffness",):
            return f"effects.seat_compliance.{comp}.k_seat" if comp != "valves" else "effects.seat_compliance.k_seat"
        if attr in fields["valve"]:
            return f"{where}.{fields['valve'][attr]}"
    if comp in ("pump", "oil") and attr in fields[comp] and fields[comp][attr] != attr:
        return f"{comp}.{fields[comp][attr]}"
    return name


def _base_name(design: dict) -> str:
    if "model" in design:
        return str(design["model"])
    if "valve" in design:
        return f"thesis-{design['valve']}"
    raise InputError("model", "missing: give the pump model (model = NAME|FILE, or valve = disc|reed) as a factor "
                              "or in [fixed]")


def _model_and_valve(fixed: dict, factors: dict) -> None:
    """Both a pump model and a valve kind given (``model`` names the base, so ``valve`` is ignored by
    :func:`_base_name`): refused unless every model has valves of every kind named."""
    from lumped.model.model_file import load_model

    models = [fixed["model"]] if "model" in fixed else list(factors.get("model", ()))
    valves = [fixed["valve"]] if "valve" in fixed else list(factors.get("valve", ()))
    for m in models if valves else ():
        kinds = set(load_model(str(m), field="model").kinds)
        for v in valves:
            if kinds != {v}:
                raise InputError("valve", f"{v!r} contradicts the model {m!r}, which has "
                                          f"{' and '.join(sorted(kinds))} valves: the model names the valves; drop valve")


def _positive(name, v, integer=False):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise InputError(name, f"must be a positive number, got {v!r}")
    if integer and int(v) != v:
        raise InputError(name, f"must be an integer, got {v!r}")


def check(name: str, value) -> None:
    """Vet one operating or run input (name and value) before a sweep runs.

    Model keys are checked by :func:`check_inputs` against the base model.

    Parameters
    ----------
    name : str
    value : object
        ``speed_rpm`` [rpm] and ``load_pressure`` [Pa] within their declared bounds, ``air_content``
        a volume fraction in [0, 0.5), ``revolutions`` 2 to 100000, tolerances in (0, 0.1), ...
    """
    from geometry.declare import check_value
    from lumped.model.pump_model import Operating

    if name == "valve":
        if value not in ("disc", "reed"):
            raise InputError(name, f"expected disc or reed, got {value!r}")
    elif name == "model":
        from lumped.model.model_file import load_model
        if not isinstance(value, str):
            raise InputError(name, f"expected a model name or file, got {value!r}")
        load_model(value, field=name)
    elif name == "speed_rpm":
        check_value(value, Operating.__dataclass_fields__["speed_rpm"].metadata["valvelab"], name)
    elif name == "load_pressure":
        check_value(value, Operating.__dataclass_fields__["load_pressure"].metadata["valvelab"], name)
    elif name == "air_content":
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < 0.5:
            raise InputError(name, f"must be a volume fraction in [0, 0.5), got {value!r}")
    elif name in ("revolutions", "max_revolutions"):
        _positive(name, value, integer=True)
        if not 2 <= value <= 100_000:
            raise InputError(name, f"must be from 2 (cyclic steady state compares two) to 100000, got {value!r}")
    elif name in ("warm_start", "one_revolution", "accuracy_check"):
        if not isinstance(value, bool):
            raise InputError(name, f"must be true or false, got {value!r}")
    elif name in ("steady_tol", "rtol", "atol"):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < 0.1:
            raise InputError(name, f"must be in (0, 0.1), got {value!r}")
    elif name == "method":
        if value not in ("fast", "reference"):
            raise InputError(name, f"expected 'fast' or 'reference', got {value!r}")
    elif name == "circuit":
        if value not in ("simplified", "complete"):
            raise InputError(name, f"expected simplified or complete, got {value!r}")
    elif name == "on_warning":
        if value not in ON_WARNING:
            raise InputError(name, f"expected {' or '.join(ON_WARNING)}, got {value!r}")
    elif "." not in name:
        raise InputError(name, "unknown input; expected an operating input (" + ", ".join(OPERATING)
                         + ") or a model key path such as pump.dead_volume, valves.delivery.spring.stiffness, "
                           "effects.seat_compliance.delivery.k_seat")


def check_inputs(fixed: dict, factors: dict) -> None:
    """Apply every model key of a sweep to its base model(s) before anything runs.

    Parameters
    ----------
    fixed : dict
        The fixed inputs.
    factors : dict
        {factor: its values, or the ends of its range}.

    Raises
    ------
    InputError
        Naming the input: an unknown key or an implausible value (a key must make sense for at
        least one base model of the sweep), or a first-version name and its key path both given.
    """
    from lumped.model.model_file import load_model, with_values

    bases = set()
    for src in ("model", "valve"):
        if src in fixed:
            bases = {_base_name({src: fixed[src]})}
            break
        if src in factors:
            bases = {_base_name({src: v}) for v in factors[src]}
            break
    if not bases:
        raise InputError("model", "missing: give the pump model (model = NAME|FILE, or valve = disc|reed) as a "
                                  "factor or in [fixed]")
    _model_and_valve(fixed, factors)
    seen: dict = {}
    for name in [*fixed, *factors]:      # a first-version name and its key path: one input given twice
        path = translate(name)
        if path in seen and seen[path] != name:
            raise InputError(name, f"is the same input as {seen[path]} (both name {path}); keep one")
        seen[path] = name
    keys = {k: [v] for k, v in fixed.items() if k not in OPERATING}
    keys.update({k: list(v) for k, v in factors.items() if k not in OPERATING})
    base_values = {translate(k): v[0] for k, v in keys.items()}
    for name, vals in keys.items():
        # a key must make sense for at least one base model (a reed key in a disc-and-reed sweep:
        # the disc designs then fail one by one, recorded with their error)
        first_error = None
        for b in sorted(bases):
            model = load_model(b, field="model")
            try:
                for v in vals:
                    with_values(model, dict(base_values, **{translate(name): v}))
                first_error = None
                break
            except InputError as exc:
                first_error = first_error or exc
        if first_error is not None:
            exc = first_error
            if exc.field in base_values or exc.field.startswith(translate(name)):
                raise InputError(name, exc.message) from None
            raise InputError(name, f"{exc.field}: {exc.message}") from None


#: the units of a reed geometry's keys (``valves.<pos>.geometry.<key>``)
GEOMETRY_UNITS = {"length": "m", "thickness": "m", "width_root": "m", "width_tip": "m", "tip_radius": "m",
                  "step_fraction": "-", "material.youngs_modulus": "Pa", "material.density": "kg/m^3",
                  "material.poisson_ratio": "-"}


def key_unit(model, path: str) -> str:
    """The unit of a model-file key path, from its declaration.

    Parameters
    ----------
    model : lumped.model.pump_model.PumpModel
    path : str
        A key path (``valves.spring.stiffness`` for both valves, ``valves.<pos>.geometry.<key>``,
        ``effects.<name>[.<target>].<parameter>``).

    Returns
    -------
    str
        Its unit, ``-`` when it has none.
    """
    from lumped.model.model_file import key_paths

    parts = path.split(".")
    if "geometry" in parts:
        return GEOMETRY_UNITS.get(".".join(parts[parts.index("geometry") + 1:]), "-")
    units = {k["path"]: k["unit"] for k in key_paths(model)}
    if path in units:
        return units[path]
    if parts[0] == "valves" and len(parts) > 1 and parts[1] not in ("inlet", "delivery"):
        return units.get("valves.delivery." + ".".join(parts[1:]), units.get("valves.inlet." + ".".join(parts[1:]), "-"))
    if parts[0] == "effects":
        from lumped.model.effect_library import LIBRARY

        if len(parts) >= 3 and parts[1] in LIBRARY.names():
            for p in LIBRARY[parts[1]].parameters:
                if p.name == parts[-1]:
                    return p.unit
    return "-"


def input_units(names, fixed: dict) -> dict:
    """The units of a sweep's inputs: operating inputs and model key paths (their declarations).

    Parameters
    ----------
    names : iterable of str
        Input names (key paths, first-version names, operating inputs).
    fixed : dict
        The sweep's fixed inputs (the base model: ``model`` or ``valve``).

    Returns
    -------
    dict
        {name: unit} of the names whose unit is known.
    """
    from lumped.model.model_file import load_model

    out = {n: UNITS[n] for n in names if n in UNITS}
    try:
        model = load_model(_base_name(fixed), field="model")
    except InputError:           # the base model is a factor: no one model to read the units from
        return out
    return {**{n: key_unit(model, translate(n)) for n in names if n not in UNITS and "." in n}, **out}


def build_model(design: dict):
    """The model of a design: its base model with its key paths applied (validated).

    Parameters
    ----------
    design : dict
        Its inputs (``model`` or ``valve``, key paths).

    Returns
    -------
    lumped.model.pump_model.PumpModel
    """
    from lumped.model.model_file import load_model, with_values

    model = load_model(_base_name(design), field="model")
    values = {translate(k): v for k, v in design.items() if k not in OPERATING}
    return with_values(model, values)


def stop_rule(design: dict):
    """The stop rule of a design's run settings.

    Parameters
    ----------
    design : dict
        ``revolutions``, ``max_revolutions``, ``steady_tol``, ``one_revolution``.

    Returns
    -------
    lumped.run.revolutions.StopRule
        Until cyclic steady state (at least ``revolutions``, default 2; at most ``max_revolutions``,
        default :data:`MAX_REVOLUTIONS`), or a fixed count when only ``revolutions`` is given.
    """
    from lumped.run.revolutions import StopRule

    tol = float(design.get("steady_tol", STEADY_TOL))
    if "revolutions" in design and "max_revolutions" not in design:
        return StopRule(int(design["revolutions"]), None, tol)
    least = int(design.get("revolutions", 2))
    most = int(design.get("max_revolutions", max(MAX_REVOLUTIONS, least)))
    if most < least:
        raise InputError("max_revolutions", f"must be at least revolutions ({least}), got {most}")
    # a warm start may stop after one revolution when its TDC state is a fixed point of the revolution map
    # (StopRule single): against a sharp reference (rtol 1e-5) it is as accurate as two revolutions and as a
    # 40-revolution run at the sweep's rtol, whose own error it sits in (docs/performance.md, "Sweeps");
    # ``one_revolution = false``: two revolutions at least
    single = bool(design.get("one_revolution", True)) and least <= 2
    return StopRule(least, most, tol, single)


def simulate_design(model, design: dict, warm=None):
    """Simulate a design's model at its operating point to cyclic steady state.

    Parameters
    ----------
    model : lumped.model.pump_model.PumpModel
        The design's model.
    design : dict
        Its inputs: ``speed_rpm`` [rpm], ``load_pressure`` [Pa, absolute], ``air_content``,
        ``circuit``, ``method`` (default ``fast``), ``rtol``, ``atol`` and the run settings of :func:`stop_rule`.
    warm : studies.sweeps.locality.WarmSlot, optional
        Start from the nearest solved design's TDC state, and leave this one's there.

    Returns
    -------
    lumped.run.simulate.PumpResult
    """
    from lumped.run.simulate import simulate

    kw = {k: design[k] for k in ("rtol", "atol") if k in design}
    # the fast path's a-posteriori check (lumped.run.accuracy) costs a revolution at a tenth of the tolerances, more
    # than a warm-started design's own: a sweep asks for it (accuracy_check = true); docs/performance.md
    kw["accuracy_check"] = bool(design.get("accuracy_check", False))
    res = simulate(model, design.get("speed_rpm"), design.get("load_pressure"),
                   air_content=design.get("air_content"), stop=stop_rule(design),
                   circuit=design.get("circuit"), method=design.get("method", "fast"),
                   initial_state=start_of(design, warm, model), **kw)
    if warm is not None:
        warm.solved(res.tdc_state)
    return res


def evaluate(design: dict, warm=None) -> dict:
    """Simulate one design and return the sweep outputs (the sweep-model protocol of :mod:`studies.sweeps.sweep`).

    Parameters
    ----------
    design : dict
        Its inputs (:func:`simulate_design`, :func:`build_model`).
    warm : studies.sweeps.locality.WarmSlot, optional
        Start from the nearest solved design's TDC state.

    Returns
    -------
    dict
        :func:`outputs_of` the result.
    """
    return outputs_of(simulate_design(build_model(design), design, warm), design.get("on_warning", "flag"))


def start_of(design: dict, warm, model=None):
    """The TDC state a design starts from.

    Parameters
    ----------
    design : dict
        Its inputs (``method``, ``warm_start``, the operating point).
    warm : studies.sweeps.locality.WarmSlot or None
        Its batch's pool of solved designs.
    model : lumped.model.pump_model.PumpModel, optional

    Returns
    -------
    lumped.run.warmstart.TdcState or None
        On the reference stepper, the fast path's cycle of the design itself
        (:func:`lumped.run.warmstart.fast_start`: a few milliseconds, and the reference is steady
        after its first revolution); else the state predicted from the batch's solved designs
        (None: a cold start, also with ``warm_start = false``).
    """
    if design.get("warm_start", True) is False:
        return None
    if design.get("method", "fast") != "fast" and model is not None:
        from lumped.run.warmstart import fast_start

        return fast_start(model, design.get("speed_rpm"), design.get("load_pressure"),
                          air_content=design.get("air_content"), circuit=design.get("circuit"))
    return None if warm is None else warm.state()


def outputs_of(res, on_warning: str = "flag") -> dict:
    """The sweep outputs of a pump result.

    Parameters
    ----------
    res : lumped.run.simulate.PumpResult
    on_warning : str
        ``flag`` (keep a result with a validity warning) or ``exclude`` (its status becomes ``outside``).

    Returns
    -------
    dict
        :data:`OUTPUTS` in SI (delivery [m^3/rev], pressures [Pa], angles [rad], openings [m],
        impact speeds [m/s], losses [J/rev]), ``status`` and the warnings as JSON.
    """
    out = {
        "delivery_m3_per_rev": res.delivery_per_rev,
        "volumetric_efficiency": res.volumetric_efficiency,
        "min_cylinder_pressure_pa": res.min_cylinder_pressure,
        "max_cylinder_pressure_pa": res.max_cylinder_pressure,
        "cyclic_steady": res.cyclic_steady, "cycle_change": res.cycle_change,
        "mass_balance_error": res.mass_balance_error, "revolutions_run": res.revolutions,
        "warm_started": res.start == "warm",
        "cpu_seconds": res.cpu_seconds,
        "status": "ok" if res.cyclic_steady else "not_cyclic",
        "warnings": json.dumps([w.to_dict() for w in res.warnings]),
    }
    if on_warning == "exclude" and res.warnings and out["status"] == "ok":
        out["status"] = "outside"
    for pos, v in res.valves.items():
        out.update({
            f"{pos}_peak_opening_m": v.peak_opening, f"{pos}_opening_angle_rad": v.opening_angle,
            f"{pos}_closing_angle_rad": v.closing_angle, f"{pos}_stop_contacts": v.stop_contacts,
            f"{pos}_seat_impact_m_s": v.seat_impact_velocity, f"{pos}_stop_impact_m_s": v.stop_impact_velocity,
            f"{pos}_loss_j": v.energy_loss,
        })
    out["valve_loss_j"] = res.inlet.energy_loss + res.delivery.energy_loss
    return out


def parse_warnings(text) -> list[dict]:
    """The warnings of a results-table cell.

    Parameters
    ----------
    text : str or None
        The JSON of the ``warnings`` column.

    Returns
    -------
    list of dict
        ``code`` and ``message`` each ([] for an empty cell: an error row, a module model).
    """
    if not isinstance(text, str) or not text:
        return []
    return json.loads(text)


def summarize_warnings(cells, what: str = "designs") -> list[dict]:
    """One entry per warning code of a results column.

    Parameters
    ----------
    cells : iterable of (str, str)
        (row label, ``warnings`` cell) pairs.
    what : str
        What a row is, for the message (``designs``, ``evaluations``).

    Returns
    -------
    list of dict
        {"code", "message"}: how many rows carry it and the first one's message.
    """
    cells = list(cells)
    found: dict = {}
    for label, cell in cells:
        for w in parse_warnings(cell):
            n, first = found.get(w["code"], (0, None))
            found[w["code"]] = (n + 1, first or f"{label}: {w['message']}")
    return [{"code": code, "message": f"{n} of {len(cells)} {what}, first {first}"}
            for code, (n, first) in found.items()]
