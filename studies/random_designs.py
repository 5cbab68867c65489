"""Random pump designs around the thesis's: the draws the fast path is checked on.

Used by tests/test_pump_fast.py (fast vs reference on random designs) and
benchmarks/pump_tolerance_study.py, so both judge the fast path on the same population.
"""

from __future__ import annotations

import math
from dataclasses import replace

from lumped.params import PumpModel, thesis_model


def random_design(rng, valve: str) -> tuple[float, float, float, PumpModel]:
    """(speed [rpm], load pressure [Pa], air content [-], model): operating point, air, the disc
    delivery seat stiffness (critical damping, eq 2.23), spring and displacement factors
    f1/f2, or the reed's kappa and f1/f2, drawn uniformly (the seat log-uniformly)."""
    model = thesis_model(valve)
    speed = rng.uniform(450, 950)
    load = rng.uniform(1.5e6, 4.5e6)
    air = rng.uniform(0.0, 0.03)
    inlet, delivery = model.inlet, model.delivery
    if valve == "disc":
        k = 10 ** rng.uniform(5.5, 7.0)
        delivery = replace(delivery, compliant_seat_stiffness=k, compliant_seat_damping=2 * math.sqrt(k * 3.9e-3),
                           f1=rng.uniform(0.6, 1.0), f2=rng.uniform(0.6, 1.0))
        inlet = replace(inlet, spring_stiffness=rng.uniform(150, 300))
    else:
        kappa = rng.uniform(5e6, 1e7)
        inlet = replace(inlet, stiffness=kappa, f1=rng.uniform(0.1, 0.4), f2=rng.uniform(0.2, 0.5))
        delivery = replace(delivery, stiffness=kappa, f1=inlet.f1, f2=inlet.f2)
    return speed, load, air, replace(model, inlet=inlet, delivery=delivery)
