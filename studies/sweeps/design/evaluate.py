"""One pump design at one operating point, as a sweep model (protocol in :mod:`studies.sweeps.sweep`).

The inputs are those of :mod:`studies.sweeps.pump` (``model``, ``speed_rpm``, ``load_pressure`` [Pa],
``revolutions``, ``method``, ``rtol``, ``atol`` and model-file key paths) plus:

- ``max_revolutions``: continue past ``revolutions`` until cyclic steady state, at most this many
  (:func:`studies.sweeps.pump.stop_rule`); each row starts from the TDC state of the nearest row
  solved before it in its batch (a warm start, :mod:`studies.sweeps.locality`);
- ``stress_calibration_inlet`` / ``stress_calibration_delivery``: the calibration factor of that
  reed valve's bending stress estimate (:mod:`studies.sweeps.design.stress`; 0 or absent: no stress).

The outputs are the sweep's (:data:`studies.sweeps.pump.OUTPUTS`) plus per valve ``kappa_pa_m``,
``omega_rad_s`` (reed valves), the estimated bending stress at maximum lift ``reed_stress_pa``,
at the peak opening ``reed_stress_peak_pa``, the uncalibrated Euler-Bernoulli values
``reed_stress_eb_pa`` (the largest along the reed, before the calibration factor).

The designs of a study run each operating point as its own row; the rows of one design reuse
the model built for the first (``_model_for``, a small cache: a batch visits its rows in a
nearest-neighbour chain, not in order).
"""

from __future__ import annotations


from studies.sweeps import pump as sweep_pump
from studies.sweeps.pump import OPERATING, translate

EXTRA = ("max_revolutions", "stress_calibration_inlet", "stress_calibration_delivery")
_REED_KEYS = ("kappa_pa_m", "omega_rad_s", "reed_stress_pa", "reed_stress_peak_pa", "reed_stress_eb_pa")
OUTPUTS = {**sweep_pump.OUTPUTS, **{f"{pos}_{k}": "float64" for pos in ("inlet", "delivery") for k in _REED_KEYS}}
MAIN_RESPONSES = sweep_pump.MAIN_RESPONSES
REQUIRED = ("model",)

_cache: dict = {}
#: models (and their stress outputs) kept per worker process
CACHE_SIZE = 64


def check(name: str, value) -> None:
    """Vet one input before a run (the key paths are checked by :mod:`studies.sweeps.design.spec` against the model)."""
    from geometry.errors import InputError

    if name == "max_revolutions":
        if isinstance(value, bool) or not isinstance(value, int) or not 2 <= value <= 100_000:
            raise InputError(name, f"must be an integer from 2 to 100000, got {value!r}")
    elif name.startswith("stress_calibration_"):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
            raise InputError(name, f"must be a non-negative number, got {value!r}")
    else:
        sweep_pump.check(name, value)


def model_values(design: dict) -> dict:
    """The model-file key paths of a design (every input that is not an operating or run input)."""
    return {translate(k): v for k, v in design.items() if k not in OPERATING and k not in EXTRA}


def _model_key(design: dict) -> tuple:
    return (design["model"], tuple((k, repr(v)) for k, v in model_values(design).items()))


def _model_for(design: dict):
    from lumped.model.model_file import load_model, with_values

    key = _model_key(design)
    if key not in _cache:
        values = model_values(design)
        if any(k.endswith("fidelity") and v in ("beam", "plate", "solid") for k, v in values.items()) or \
                any(getattr(v, "fidelity", None) in ("beam", "plate", "solid")
                    for v in (load_model(design["model"], field="model").valve(p) for p in ("inlet", "delivery"))):
            from studies.sweeps.design.fea_tasks import ensure_gmsh

            ensure_gmsh()
        model = with_values(load_model(design["model"], field="model"), values)   # raises: nothing cached
        if len(_cache) >= CACHE_SIZE:
            del _cache[next(iter(_cache))]
        _cache[key] = {"model": model, "stress": {}}
    return _cache[key]["model"]


def build_design_model(model_path: str, keys: dict):
    """The PumpModel of ``model_path`` with the key paths ``keys`` (from this worker's cache when it built it)."""
    return _model_for({"model": model_path, **keys})


def evaluate(design: dict, warm=None) -> dict:
    """Simulate the design at its operating point and return the outputs (fast path unless ``method``);
    ``warm`` (:class:`studies.sweeps.locality.WarmSlot`): start from the nearest solved row's TDC state."""
    from lumped.run.simulate import simulate

    model = _model_for(design)
    kw = {k: design[k] for k in ("rtol", "atol") if k in design}
    res = simulate(model, design.get("speed_rpm"), design.get("load_pressure"),
                   air_content=design.get("air_content"), stop=sweep_pump.stop_rule(design),
                   circuit=design.get("circuit"), method=design.get("method", "fast"),
                   initial_state=sweep_pump.start_of(design, warm, model), **kw)
    if warm is not None:
        warm.solved(res.tdc_state)
    # a valve that never reseats (held off its seat by the squeeze film's C2 u / x^3) has no timing:
    # lumped.run.simulate reports its angles as None, which the outputs keep as missing
    out = sweep_pump.outputs_of(res, design.get("on_warning", "flag"))
    from studies.sweeps.design.stress import lift_deflection, reed_outputs

    cal = {pos: float(design.get(f"stress_calibration_{pos}", 0.0) or 0.0) for pos in ("inlet", "delivery")}
    stress = _cache[_model_key(design)]["stress"]
    skey = tuple(cal.items())
    if skey not in stress:                 # design-level: once per design, not per operating point
        stress[skey] = reed_outputs(model, cal)
    row = dict(stress[skey])
    for pos in ("inlet", "delivery"):
        at_stop, peak = row[f"{pos}_reed_stress_pa"], getattr(res, pos).peak_opening
        if at_stop is not None and peak is not None:
            v = model.valve(pos)
            row[f"{pos}_reed_stress_peak_pa"] = at_stop * lift_deflection(v, peak) / lift_deflection(v)
    out.update(row)
    return out
