"""One operating point of a model, as the uncertainty studies run it (the tolerance ladder, the Monte Carlo)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Point:
    """One operating point to run: a model with its declarations, speed [rpm], load [Pa], the revolutions a run
    reports (after at most ``max_revolutions`` towards steady state) and the circuit (None: the model's)."""

    name: str
    model: object
    speed_rpm: float
    load_pressure: float
    revolutions: int = 2
    max_revolutions: int | None = 12
    circuit: str | None = None
    group: str | None = None        # points of one group share their draws (the same inputs at draw k)
