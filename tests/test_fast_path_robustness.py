"""The fast path completes every candidate model the discrepancy workflow may ask for.

A fit walks each candidate effect over its whole search range (docs/discrepancy.md): seat
stiffnesses up to 1e11 N/m (30x steel), squeeze films at 1/100-100x eq 2.15, flow forces at
jet angles of 6-86 deg with oil columns 1/20-20x, added masses over 4 decades. Every such
model must integrate on the fast path (a failure sends the workflow to the reference path,
100x slower); 6 s, in the default run. Guards the integrator's numerics: a variant of the cylinder-pressure inversion
that carried its terms from call to call failed 11 of these 192 runs (step-size underflow),
the code before and after it none.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from geometry.errors import ModelFailure
from lumped.run.simulate import InvariantError, simulate
from lumped.model.effects import Applied
from lumped.model.model_file import load_model
from studies.discrepancy.pump_sim import PumpSimulator
from studies.discrepancy.synth import Condition

#: a pump that is not the thesis's (shared with tests/test_discrepancy_model_file.py)
BENCH = Path(__file__).parent / "data" / "bench-pump.toml"


def _candidates(kind: str) -> list[tuple]:
    geo = np.geomspace
    if kind == "disc":
        return ([("seat_compliance", t, {"k_seat": k}) for t in ("delivery", "inlet") for k in geo(1e5, 1e11, 7)]
                + [("squeeze_film", "both", {"C2": c}) for c in geo(7.4e-13, 7.4e-9, 5)]
                + [("added_mass", "both", {"m_f": m}) for m in geo(1e-5, 1e-1, 5)]
                + [("flow_force", "both", {"theta_jet": th, "L_t": lt}) for th in (0.1, 0.9, 1.5)
                   for lt in (2.6e-4, 5.2e-3, 0.1)]
                + [("piston_leakage", "pump", {"clearance": c}) for c in (1e-6, 2e-5, 2e-4)])
    return ([("seat_compliance", t, {"k_seat": k}) for t in ("delivery", "inlet") for k in geo(1e8, 1e13, 6)]
            + [("added_mass", "both", {"Gamma_f": g}) for g in (0.01, 1.0, 100.0)]
            + [("fluid_damping", "both", {"c_f": c}) for c in (10.0, 1e3, 1e5)]
            + [("piston_leakage", "pump", {"clearance": c}) for c in (1e-6, 2e-5, 2e-4)])


@pytest.mark.parametrize("model", ["bench", "thesis-disc", "thesis-reed"])
def test_every_candidate_model_integrates_on_the_fast_path(model):
    if model == "bench":
        model = str(BENCH)
    sim = PumpSimulator(load_model(model))
    kind = "reed" if model == "thesis-reed" else "disc"
    conditions = [Condition(600, 2.5e6, "inlet", 0.01), Condition(900, 3.5e6, "delivery", 0.0)]
    failed = []
    for name, target, values in [("", "", {})] + _candidates(kind):
        effects = () if not name else (Applied.of(name, target, values),)
        for c in conditions:
            try:
                simulate(sim.model_for(c, effects), c.speed_rpm, c.load_pressure_pa, revolutions=2, trace=True,
                         trace_points=1440, method="fast", max_steps=200_000)
            except InvariantError:
                pass                  # the physics of an implausible candidate, not the integrator
            except ModelFailure as e:
                failed.append(f"{name}@{target} {values} at {c.speed_rpm} rpm: {e}")
    assert not failed, "\n".join(failed)
