"""Synthetic measurements: datasets made by the model with chosen effects hidden in them.

The model (any simulator of ``studies/discrepancy/workflow.py``) is run with a "truth" set of
effects for several operating conditions; its cyclic steady state is then sampled
the way the thesis's rig did (10 kHz, time zero at TDC, whole revolutions) and
spoiled the way real data is: white position noise, a position-sensor scale error
per valve (the laser triangulation scale factor is uncertain by +-1.12 %, thesis
section 5.3.2), a time offset between the sensor and the crank angle, pressure noise
(cut at the oil's vapour pressure: an absolute transducer reads nothing lower, and no liquid is
below it) and a delivery-measurement error. The truth (effects, nuisances, seed) goes to
``truth.toml`` at the dataset root, which the dataset reader ignores: the effect is
hidden from the workflow.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tomli_w

from geometry.errors import InputError, ModelFailure
from lumped.model.effects import Applied

from studies.discrepancy.gap import periodic_interp
from studies.discrepancy.measured import Run, Trace, write_dataset
from studies.discrepancy.records import RunCondition
from studies.discrepancy.simulations import Simulations
from studies.tables.thesis import experiments

#: relative uncertainty of the position sensor's scale factor (thesis section 5.3.2.2)
LTS_SCALE_UNCERTAINTY = 0.0112


@dataclass(frozen=True)
class Noise:
    """How measured data departs from the model (all SI)."""

    position_m: float = 1.0e-5          # white noise on each position sample
    pressure_pa: float = 1.0e4          # white noise on each pressure sample
    delivery_frac: float = 0.003        # relative error of the measured delivery
    scale_error: tuple | None = None    # (inlet, delivery) sensor scale errors; None: drawn, +-1.12 %
    time_offset_s: float | None = None  # sensor lag behind the crank angle; None: drawn within +-0.2 ms
    sample_rate_hz: float = 1.0e4       # the thesis's DAQ rate (section 5.4.1)
    revolutions: int = 1                # revolutions written per run
    vibration_m: float = 0.0            # rig vibration on the position readings: amplitude [m] ...
    vibration_hz: float = 0.0           # ... at this frequency [Hz] (not a multiple of the shaft's), random phase
    drift_m: float = 0.0                # linear drift of the position readings over the record [m]
    pressure_gain_error: float = 0.0    # relative gain error of the cylinder-pressure transducer
    stated_uncertainties: bool = True   # run.toml states the delivery's and the positions' standard uncertainty


@dataclass(frozen=True)
class Condition:
    """One synthetic run: speed, load pressure, which valve's position is recorded."""

    speed_rpm: float
    load_pressure_pa: float
    measured_valve: str = "delivery"    # inlet, delivery or both
    air_content: float | None = None    # stated in run.toml (None: not stated)


def run_name(i: int, c: Condition) -> str:
    return f"run{i + 1:02d}_{c.speed_rpm:.0f}rpm_{c.load_pressure_pa / 1e6:.2f}MPa_{c.measured_valve}"


#: samples one run may hold (a trace.csv of ~80 MB)
MAX_SAMPLES_PER_RUN = 1_000_000


def check_synthesis(simulator, valve_type, conditions, truth, noise, seed, workers) -> None:
    """InputError naming the first bad argument of :func:`synthesize` (types, ranges, the trace size)."""
    from geometry import validate
    from geometry.declare import check_value, spec_of
    from lumped.model.pump_model import SPEED, Operating
    from studies.discrepancy.measured import MEASURED_VALVES

    if not callable(simulator):
        raise InputError("simulator", f"expected a callable (run condition, effects) -> CycleTrace, got {simulator!r}")
    if not isinstance(valve_type, str) or not valve_type:
        raise InputError("valve_type", f"expected a valve type such as 'disc' or 'reed', got {valve_type!r}")
    from studies.discrepancy.measured import valve_types

    validate.choice(valve_type, "valve_type", valve_types())      # 'Disc': did you mean disc?
    if not isinstance(conditions, (list, tuple)) or not conditions:
        raise InputError("conditions", f"expected a non-empty list of Condition, got {conditions!r}")
    for i, c in enumerate(conditions):
        where = f"conditions[{i}]"
        if not isinstance(c, Condition):
            raise InputError(where, f"expected a studies.discrepancy.synth.Condition, got {c!r}")
        check_value(c.speed_rpm, SPEED, f"{where}.speed_rpm")
        check_value(c.load_pressure_pa, spec_of(Operating, "load_pressure"), f"{where}.load_pressure_pa")
        validate.choice(c.measured_valve, f"{where}.measured_valve", MEASURED_VALVES)
        if c.air_content is not None:
            validate.number(c.air_content, f"{where}.air_content", bounds=(0.0, 0.49))
    if not isinstance(truth, (list, tuple)) or not all(isinstance(a, Applied) for a in truth):
        raise InputError("truth", f"expected a tuple of lumped.model.effects.Applied, got {truth!r}")
    if not isinstance(noise, Noise):
        raise InputError("noise", f"expected a studies.discrepancy.synth.Noise, got {noise!r}")
    for f in ("position_m", "pressure_pa", "delivery_frac", "vibration_m", "vibration_hz", "drift_m"):
        validate.number(getattr(noise, f), f"noise.{f}", bounds=(0.0, 1e9))
    validate.number(noise.pressure_gain_error, "noise.pressure_gain_error", bounds=(-0.2, 0.2))
    validate.number(noise.sample_rate_hz, "noise.sample_rate_hz", unit="Hz", bounds=(1e3, 1e7))
    validate.number(noise.revolutions, "noise.revolutions", integer=True, bounds=(1, 1000))
    if noise.time_offset_s is not None:
        validate.number(noise.time_offset_s, "noise.time_offset_s", unit="s", bounds=(-5e-3, 5e-3))
    if noise.scale_error is not None:
        if not isinstance(noise.scale_error, (tuple, list)) or len(noise.scale_error) != 2:
            raise InputError("noise.scale_error", f"expected (inlet, delivery), got {noise.scale_error!r}")
        for i, x in enumerate(noise.scale_error):
            validate.number(x, f"noise.scale_error[{i}]", bounds=(-0.2, 0.2))
    validate.number(seed, "seed", integer=True, bounds=(0, 2**32 - 1))
    validate.number(workers, "workers", integer=True, bounds=(1, 256))
    for c in conditions:
        validate.size(noise.revolutions * 60.0 / c.speed_rpm * noise.sample_rate_hz, "noise.revolutions",
                      limit=MAX_SAMPLES_PER_RUN, unit="samples per run", bytes_each=80.0,
                      how=f"at {c.speed_rpm:g} rpm lower the revolutions or the sample rate")


def synthesize(simulator, valve_type: str, conditions: list[Condition], truth: tuple[Applied, ...] = (),
               noise: Noise = Noise(), seed: int = 0, workers: int = 1) -> tuple[list[Run], dict]:
    """Runs (with traces and deliveries) the model gives with ``truth`` switched on, and the truth itself.
    Every argument is checked first (:func:`check_synthesis`)."""
    check_synthesis(simulator, valve_type, conditions, truth, noise, seed, workers)
    rng = np.random.default_rng(seed)
    if noise.scale_error is None:
        scale_err = {v: float(rng.uniform(-1, 1) * LTS_SCALE_UNCERTAINTY) for v in ("inlet", "delivery")}
    else:
        scale_err = dict(zip(("inlet", "delivery"), map(float, noise.scale_error)))
    offset = float(rng.uniform(-2e-4, 2e-4)) if noise.time_offset_s is None else float(noise.time_offset_s)
    conds = [RunCondition(run_name(i, c), valve_type, float(c.speed_rpm), float(c.load_pressure_pa),
                          c.air_content) for i, c in enumerate(conditions)]
    floor = pressure_floor(simulator)
    # the truth at the reference's accuracy where the simulator offers it (PumpSimulator.accurate)
    truth_sim = simulator.accurate() if callable(getattr(simulator, "accurate", None)) else simulator
    with Simulations(truth_sim, workers) as sims:
        results = sims.many([(rc, tuple(truth)) for rc in conds])
    runs = []
    for c, rc, sim in zip(conditions, conds, results):
        if not hasattr(sim, "positions"):
            raise ModelFailure(f"the model failed for {rc.name}: {sim.reason}")
        runs.append(_measured(c, rc.name, valve_type, sim, noise, rng, (scale_err, offset, floor)))
    truth_doc = {
        "seed": int(seed),
        "valve_type": valve_type,
        "effects": [{"name": a.name, "target": a.target, **a.value_dict} for a in truth],
        "nuisance": {"scale_error_inlet": scale_err["inlet"], "scale_error_delivery": scale_err["delivery"],
                     "time_offset_s": offset},
        "noise": {"position_m": noise.position_m, "pressure_pa": noise.pressure_pa,
                  "delivery_frac": noise.delivery_frac, "sample_rate_hz": noise.sample_rate_hz,
                  "revolutions": noise.revolutions, "vibration_m": noise.vibration_m,
                  "vibration_hz": noise.vibration_hz, "drift_m": noise.drift_m,
                  "pressure_gain_error": noise.pressure_gain_error},
    }
    form = getattr(simulator, "truth_form", None)
    if callable(form):
        truth_doc["model_form"] = form()        # a model-form mismatch (studies.discrepancy.mismatch)
    return runs, truth_doc


def _measured(c: Condition, name: str, valve_type: str, sim, noise: Noise, rng, sensor: tuple) -> Run:
    """One run as the rig would have measured the simulated revolution ``sim``: sampled at the DAQ rate from
    TDC, the position sensor's scale error and time offset, white noise, vibration and drift, the pressure
    transducer's gain error and noise (``sensor``: (scale error per valve, time offset [s], the lowest
    pressure a transducer reads [Pa])); draws from ``rng`` in a fixed order."""
    scale_err, offset, floor = sensor
    period = 60.0 / c.speed_rpm
    n = int(round(noise.revolutions * period * noise.sample_rate_hz))
    t = np.arange(n) * (noise.revolutions * period / n)   # uniform, whole revolutions
    theta = np.mod(t * c.speed_rpm * 6.0, 360.0)
    shift = offset * c.speed_rpm * 6.0
    positions = {}
    valves = ("inlet", "delivery") if c.measured_valve == "both" else (c.measured_valve,)
    for v in valves:
        x = periodic_interp(theta - shift, sim.crank_deg, sim.positions[v])
        positions[v] = (1.0 + scale_err[v]) * x + rng.normal(0.0, noise.position_m, n)
        if noise.vibration_m > 0.0:
            positions[v] += noise.vibration_m * np.sin(2 * np.pi * noise.vibration_hz * t + rng.uniform(0, 2 * np.pi))
        if noise.drift_m > 0.0:
            positions[v] += noise.drift_m * rng.choice((-1.0, 1.0)) * (t / t[-1] - 0.5)
    pcyl = None
    if sim.cylinder_pressure_pa is not None:
        pcyl = ((1.0 + noise.pressure_gain_error) * periodic_interp(theta, sim.crank_deg, sim.cylinder_pressure_pa)
                + rng.normal(0.0, noise.pressure_pa, n))
        # an absolute transducer reads no lower than the bottom of its range: the noise is cut
        # at the oil's vapour pressure, below which the liquid's pressure cannot fall
        pcyl = np.maximum(pcyl, floor)
    pload = c.load_pressure_pa + rng.normal(0.0, noise.pressure_pa, n)
    delivery = sim.delivery_m3_per_rev * (1.0 + rng.normal(0.0, noise.delivery_frac))
    stated = {}
    if noise.stated_uncertainties:
        # what the experimenter knows of the instruments: the meter's scatter and the sensor's scale
        stated = {"delivery_uncertainty_cc": float(noise.delivery_frac * delivery * 1e6),
                  "position_uncertainty_rel": LTS_SCALE_UNCERTAINTY}
    return Run(name=name, valve_type=valve_type, speed_rpm=float(c.speed_rpm),
               load_pressure_pa=float(c.load_pressure_pa), measured_valve=c.measured_valve,
               delivery_cc_per_rev=float(delivery * 1e6), air_content=c.air_content,
               trace=Trace.measured(t, positions, pcyl, pload, c.speed_rpm), **stated)


def pressure_floor(simulator) -> float:
    """Lowest absolute pressure a synthetic transducer reads [Pa]: the model oil's vapour pressure (0 for a
    simulator without a pump model)."""
    oil = getattr(getattr(simulator, "context", None), "oil", None)
    return float(getattr(oil, "vapour_pressure", 0.0))


def earlier_output(folder) -> list[Path]:
    """What an earlier ``synth`` wrote in ``folder`` (a valvelab folder): its run folders, ``truth.toml`` and
    ``model.toml``; [] for a new folder or a user's."""
    from studies.outputs import MARKER

    folder = Path(folder)
    if not (folder / MARKER).is_file():
        return []
    runs = [p for p in sorted(folder.iterdir()) if p.is_dir() and (p / "run.toml").is_file() and (p / MARKER).is_file()]
    return runs + [folder / n for n in ("truth.toml", "model.toml") if (folder / n).is_file()]


def check_rerun(folder, field: str, force: bool, inputs: dict | None = None) -> None:
    """InputError when ``folder`` holds an earlier synthetic dataset (new runs would mix with its runs and its
    truth) unless ``force``, which replaces it; or when an input file ({flag: path}) lies in what is replaced."""
    old = earlier_output(folder)
    for flag, path in (inputs or {}).items():
        if path is not None and Path(path).is_file() and any(
                Path(path).resolve() == o.resolve() or o.resolve() in Path(path).resolve().parents for o in old):
            raise InputError(flag, f"{path} is part of the dataset in {folder} that this run would replace; copy it "
                                   "elsewhere first")
    if old and not force:
        n = sum(p.is_dir() for p in old)
        raise InputError(field, f"{folder} already holds a synthetic dataset ({n} runs) valvelab wrote; choose "
                                "another folder, or pass --force to replace it (new runs never mix with old ones)")


def write_synthetic(folder, runs: list[Run], truth: dict, force: bool = False):
    """Write a synthetic dataset: run folders plus the hidden ``truth.toml``. An earlier synthetic dataset in
    ``folder`` is refused, or replaced with ``force`` (:func:`check_rerun`)."""
    check_rerun(folder, str(folder), force)
    for p in earlier_output(folder):
        shutil.rmtree(p) if p.is_dir() else p.unlink()
    folder = write_dataset(folder, runs, force=force)
    (folder / "truth.toml").write_text(
        "# What synth hid in this dataset; the discrepancy workflow does not read this file.\n"
        + tomli_w.dumps(truth))
    return folder


def thesis_conditions(model, air: float | None) -> list[Condition]:
    """The six measured runs of the thesis (Tables 5.3-5.6) of the rig a model is: speed, load, measured valve.

    ``model``: a pump model (its pump is compared with the thesis rigs' pumps: the disc rig of Table 5.4,
    whose pump thesis-ball shares, or the reed rig of Table 5.6) or a thesis valve type ("disc", "reed").
    Empty when the model is no thesis rig.
    """
    from lumped.model.model_file import load_model

    if isinstance(model, str):
        rig = model
    else:
        rig = next((t for t in ("disc", "reed") if load_model(f"thesis-{t}").pump == model.pump), None)
    return [Condition(c["speed_rpm"], c["load_pressure"], c["measured_valve"], air)
            for c in experiments() if c["valve"] == rig]
