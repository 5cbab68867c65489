"""Random pump designs around the thesis's: the draws the fast path is checked on.

Used by tests/test_pump_fast.py (fast vs reference on random designs) and
benchmarks/pump_tolerance_study.py, so both judge the fast path on the same population.
Valve "disc", "reed" or "mixed" (a disc inlet with a reed delivery valve).
"""

from __future__ import annotations

from lumped.model import PumpModel
from lumped.model_file import load_model, with_values

VALVES = ("disc", "reed", "mixed")


def random_design(rng, valve: str) -> tuple[float, float, float, PumpModel]:
    """(speed [rpm], load pressure [Pa], air content [-], model): operating point, air, the disc
    delivery seat stiffness (O-ring compliance, critical damping of eq 2.23), spring and displacement
    factors f1/f2, or the reed's kappa and f1/f2, drawn uniformly (the seat log-uniformly)."""
    speed = rng.uniform(450, 950)
    load = rng.uniform(1.5e6, 4.5e6)
    air = rng.uniform(0.0, 0.03)
    if valve == "disc":
        model = load_model("thesis-disc")
        values = {"effects.seat_compliance.delivery.k_seat": 10 ** rng.uniform(5.5, 7.0),
                  "valves.delivery.flow.f1": rng.uniform(0.6, 1.0), "valves.delivery.flow.f2": rng.uniform(0.6, 1.0),
                  "valves.inlet.spring.stiffness": rng.uniform(150, 300)}
    elif valve == "reed":
        model = load_model("thesis-reed")
        f1, f2 = rng.uniform(0.1, 0.4), rng.uniform(0.2, 0.5)
        values = {"valves.structure.stiffness": rng.uniform(5e6, 1e7), "valves.flow.f1": f1, "valves.flow.f2": f2}
    else:
        model = mixed_model()
        values = {"valves.inlet.spring.stiffness": rng.uniform(150, 300),
                  "valves.delivery.structure.stiffness": rng.uniform(5e6, 1e7),
                  "valves.delivery.flow.f1": rng.uniform(0.1, 0.4), "valves.delivery.flow.f2": rng.uniform(0.2, 0.5)}
    return speed, load, air, with_values(model, values)


def mixed_model() -> PumpModel:
    """The thesis pump with a disc inlet valve and the prototype reed as the delivery valve."""
    from lumped.model_file import parse_model

    return parse_model({"name": "mixed-disc-reed", "valves": {"inlet": {"kind": "disc"},
                                                            "delivery": {"kind": "reed"}}})
