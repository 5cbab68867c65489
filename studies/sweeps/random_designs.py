"""Random pump designs drawn from the valve-kind registry (the generator lives in
:mod:`lumped.model.random_designs`, where the conformance check of a kind can reach it; re-exported here for
the studies)."""

from lumped.model.random_designs import POSITIONS, VALVES, draw, mixed_model, random_design, valve_designs  # noqa: F401
