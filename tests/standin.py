"""A crude, instant stand-in pump for testing the discrepancy machinery (not physics).

Valve traces are smoothed trapezoids whose opening and closing crank angles move
with speed and load pressure the way a pump's do; each toy effect leaves a distinct
signature (a compliant seat pushes the closed valve below zero in proportion to
the pressure across it; a closing lag delays closing in proportion to speed; leakage
and air lower the delivery, air also delays the openings). The workflow must
recover what was hidden without knowing any of this.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from lumped.model.effects import PER_VALVE, PUMP, BOTH_VALVES, Effect, Library, Parameter
from studies.discrepancy.gap import CycleTrace

SEAT_AREA = 1.77e-4   # m^2, disc face area (thesis Table 2.3)


@dataclass(frozen=True)
class ToyParams:
    k_seat_inlet: float = math.inf
    k_seat_delivery: float = math.inf
    lag_deg: float = 0.0          # closing lag per 1000 rpm, both valves
    lag_inlet: float = 0.0        # ... of one valve (the placed closing lag)
    lag_delivery: float = 0.0
    leak_per_mpa: float = 0.0     # delivery lost per MPa of load
    air: float = 0.0
    cd_scale: float = 1.0         # a model error (not a candidate)


def _set_seat(p, v, t):
    k = v["k_seat"]
    return replace(p, **({"k_seat_inlet": k} if t == "inlet" else {"k_seat_delivery": k}))


LIBRARY = LIB = Library()
LIB.register(Effect(
    "seat_compliance", "compliant seat", (Parameter("k_seat", "N/m", 3.0e9, (1e5, 1e10), (1e5, 3.1e9), "FEA"),),
    _set_seat, targets=PER_VALVE, derived=lambda v, vt: {"c_seat": 2 * math.sqrt(v["k_seat"] * 3.9e-3)},
    derived_units={"c_seat": "N s/m"}))
LIB.register(Effect(
    "closing_lag", "inertia-like closing lag", (Parameter("lag_deg", "deg", 1.0, (0.05, 100.0), (0.05, 30.0), "toy"),),
    lambda p, v, t: replace(p, lag_deg=v["lag_deg"]), targets=BOTH_VALVES))
LIB.register(Effect(
    "opening_lag", "a lag of the opening, on one valve or both (placed: fitted on both, then tried on each)",
    (Parameter("lag_deg", "deg", 1.0, (0.05, 100.0), (0.05, 30.0), "toy"),),
    lambda p, v, t: replace(p, **({"lag_inlet": v["lag_deg"], "lag_delivery": v["lag_deg"]} if t == "both"
                                  else {f"lag_{t}": v["lag_deg"]})),
    targets=BOTH_VALVES + PER_VALVE, placement=True))
LIB.register(Effect(
    "piston_leakage", "leakage", (Parameter("leak_per_mpa", "1/MPa", 1e-3, (1e-5, 0.1), (1e-5, 0.05), "toy"),),
    lambda p, v, t: replace(p, leak_per_mpa=v["leak_per_mpa"]), targets=PUMP))
LIB.register(Effect(
    "entrained_air", "air", (Parameter("R", "-", 0.01, (1e-4, 0.2), (1e-4, 0.1), "toy"),),
    lambda p, v, t: replace(p, air=v["R"]), targets=PUMP,
    applicable=lambda runs: "air content stated" if any(r.air_content is not None for r in runs) else None))
LIB.register(Effect(
    "discharge_scale", "Cd error", (Parameter("scale", "-", 1.0, (0.5, 2.0), (0.5, 2.0), "toy"),),
    lambda p, v, t: replace(p, cd_scale=v["scale"]), targets=PUMP, candidate=False))

GRID = np.arange(0.0, 360.0, 0.25)


def _lift(theta, open_deg, close_deg, lift, ramp=12.0):
    """Smoothed trapezoid between open and close (wrapping), 0 outside."""
    span = np.mod(close_deg - open_deg, 360.0)
    s = np.mod(theta - open_deg, 360.0)
    f = np.clip(np.minimum(s / ramp, (span - s) / ramp), 0.0, 1.0)
    return lift * f * f * (3 - 2 * f), f


def simulate(cond, model) -> CycleTrace:
    """The toy pump's revolution for a run condition and applied toy effects."""
    p = LIB.apply(ToyParams(air=cond.air_content or 0.0), model)
    P = cond.load_pressure_pa / 1e6
    w = cond.speed_rpm / 1000.0
    air_delay = 400.0 * p.air * P
    cd = p.cd_scale
    xi, fi = _lift(GRID, 8 + 3 * P + air_delay + p.lag_inlet * w, 183 + 8 * w + p.lag_deg * w,
                   1.0e-3 * (0.7 + 0.3 * w) / cd)
    xd, fd = _lift(GRID, 205 + 6 * P + air_delay + p.lag_delivery * w, 362 + 6 * w + p.lag_deg * w,
                   0.8e-3 * (0.6 + 0.4 * w) / cd**0.5)
    # closed valves pressed into a compliant seat by the pressure across them
    xi = xi - (1 - np.minimum(fi * 4, 1)) * np.where(GRID > 180, 1.0, 0.3) * P * 1e6 * SEAT_AREA / p.k_seat_inlet
    xd = xd - (1 - np.minimum(fd * 4, 1)) * np.where(GRID < 190, 1.0, 0.3) * P * 1e6 * SEAT_AREA / p.k_seat_delivery
    delivery = 2.218e-6 * (0.9 - 0.01 * P - 0.6 * p.air * P - 0.002 * p.lag_deg * w) * (1 - p.leak_per_mpa * P)
    delivery *= 1 + 0.004 * (cd - 1)
    return CycleTrace(GRID.copy(), {"inlet": xi, "delivery": xd}, float(delivery), None)
