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

from dataclasses import dataclass

import numpy as np
import tomli_w

from lumped.effects import Applied

from studies.discrepancy.workflow import ModelFailure, RunCondition, Simulations
from studies.discrepancy.gap import periodic_interp
from studies.discrepancy.measured import Run, Trace, write_dataset
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


@dataclass(frozen=True)
class Condition:
    """One synthetic run: speed, load pressure, which valve's position is recorded."""

    speed_rpm: float
    load_pressure_pa: float
    measured_valve: str = "delivery"    # inlet, delivery or both
    air_content: float | None = None    # stated in run.toml (None: not stated)


def run_name(i: int, c: Condition) -> str:
    return f"run{i + 1:02d}_{c.speed_rpm:.0f}rpm_{c.load_pressure_pa / 1e6:.2f}MPa_{c.measured_valve}"


def synthesize(simulator, valve_type: str, conditions: list[Condition], truth: tuple[Applied, ...] = (),
               noise: Noise = Noise(), seed: int = 0, workers: int = 1) -> tuple[list[Run], dict]:
    """Runs (with traces and deliveries) the model gives with ``truth`` switched on, and the truth itself."""
    rng = np.random.default_rng(seed)
    if noise.scale_error is None:
        scale_err = {v: float(rng.uniform(-1, 1) * LTS_SCALE_UNCERTAINTY) for v in ("inlet", "delivery")}
    else:
        scale_err = dict(zip(("inlet", "delivery"), map(float, noise.scale_error)))
    offset = float(rng.uniform(-2e-4, 2e-4)) if noise.time_offset_s is None else float(noise.time_offset_s)
    conds = [RunCondition(run_name(i, c), valve_type, float(c.speed_rpm), float(c.load_pressure_pa),
                          c.air_content) for i, c in enumerate(conditions)]
    floor = pressure_floor(simulator)
    with Simulations(simulator, workers) as sims:
        results = sims.many([(rc, tuple(truth)) for rc in conds])
    runs = []
    for c, rc, sim in zip(conditions, conds, results):
        if not hasattr(sim, "positions"):
            raise ModelFailure(f"the model failed for {rc.name}: {sim.reason}")
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
        pcyl = None
        if sim.cylinder_pressure_pa is not None:
            pcyl = (periodic_interp(theta, sim.crank_deg, sim.cylinder_pressure_pa)
                    + rng.normal(0.0, noise.pressure_pa, n))
            # an absolute transducer reads no lower than the bottom of its range: the noise is cut
            # at the oil's vapour pressure, below which the liquid's pressure cannot fall
            pcyl = np.maximum(pcyl, floor)
        pload = c.load_pressure_pa + rng.normal(0.0, noise.pressure_pa, n)
        delivery = sim.delivery_m3_per_rev * (1.0 + rng.normal(0.0, noise.delivery_frac))
        runs.append(Run(
            name=rc.name, valve_type=valve_type, speed_rpm=float(c.speed_rpm),
            load_pressure_pa=float(c.load_pressure_pa), measured_valve=c.measured_valve,
            delivery_cc_per_rev=float(delivery * 1e6), air_content=c.air_content,
            trace=Trace.measured(t, positions, pcyl, pload, c.speed_rpm),
        ))
    truth_doc = {
        "seed": int(seed),
        "valve_type": valve_type,
        "effects": [{"name": a.name, "target": a.target, **a.value_dict} for a in truth],
        "nuisance": {"scale_error_inlet": scale_err["inlet"], "scale_error_delivery": scale_err["delivery"],
                     "time_offset_s": offset},
        "noise": {"position_m": noise.position_m, "pressure_pa": noise.pressure_pa,
                  "delivery_frac": noise.delivery_frac, "sample_rate_hz": noise.sample_rate_hz,
                  "revolutions": noise.revolutions},
    }
    return runs, truth_doc


def pressure_floor(simulator) -> float:
    """Lowest absolute pressure a synthetic transducer reads [Pa]: the model oil's vapour pressure (0 for a
    simulator without a pump model)."""
    oil = getattr(getattr(simulator, "context", None), "oil", None)
    return float(getattr(oil, "vapour_pressure", 0.0))


def write_synthetic(folder, runs: list[Run], truth: dict, force: bool = False):
    """Write a synthetic dataset: run folders plus the hidden ``truth.toml``."""
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
    from lumped.model_file import load_model

    if isinstance(model, str):
        rig = model
    else:
        rig = next((t for t in ("disc", "reed") if load_model(f"thesis-{t}").pump == model.pump), None)
    return [Condition(c["speed_rpm"], c["load_pressure"], c["measured_valve"], air)
            for c in experiments() if c["valve"] == rig]
