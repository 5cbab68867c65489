"""Random pump designs drawn from the valve-kind registry: the population the fast path is checked on.

The one generator: the conformance check of a kind (:mod:`lumped.conformance`), the tests (fast vs
reference, the Jacobian on random designs), ``studies.sweeps.random_designs`` (which re-exports it) and
benchmarks/pump_tolerance_study.py all draw from here, so all judge the fast path on the same population.
A design names its valves: a kind ("disc", "reed", "ball", ... every registered one: the
shipped model of that kind) or "<inlet kind>/<delivery kind>" (a mixed pump: the shipped pump
with those valves); "mixed" is "disc/reed". Each kind declares the ranges its designs are
drawn from (``lumped.valves.kind.ValveKind.design_ranges``).
"""

from __future__ import annotations

import math

from lumped.model.model_file import kind_default_model, load_model, parse_model, with_values
from lumped.model.pump_model import POSITIONS, PumpModel
from lumped.valves.kind import KINDS


def valve_designs() -> tuple[str, ...]:
    """Every design name: each registered kind, and each ordered pair of two kinds (mixed pumps)."""
    kinds = tuple(KINDS)
    return kinds + tuple(f"{a}/{b}" for a in kinds for b in kinds if a != b)


#: the designs the tests draw (every kind, and the classic mixed pump)
VALVES = tuple(KINDS) + ("mixed",)


def draw(rng, lo: float, hi: float) -> float:
    """One value of a design range: uniform in [lo, hi], log-uniform when lo > 0 and the range spans more
    than a decade (``rng``: a numpy Generator)."""
    if lo > 0 and hi / lo > 10:
        return 10.0 ** rng.uniform(math.log10(lo), math.log10(hi))
    return rng.uniform(lo, hi)


def _applies(key: str, pos: str | None) -> tuple[bool, str]:
    """Whether a design-range key applies to a kind placed at ``pos`` (None: at both), and its model path."""
    parts = key.split(".")
    named = [p for p in parts if p in POSITIONS]
    if named and pos is not None and named[0] != pos:
        return False, ""
    if named and pos is None:
        pos = named[0]
    if parts[0] in ("effects", "valves", "pump", "oil", "circuit"):
        return True, key
    rest = ".".join(p for p in parts if p not in POSITIONS)
    return True, f"valves.{pos}.{rest}" if pos is not None else f"valves.{rest}"


def random_design(rng, valve: str) -> tuple[float, float, float, PumpModel]:
    """A random plausible pump design and operating point.

    Parameters
    ----------
    rng : numpy.random.Generator
        The draws' source.
    valve : str
        A design name of :func:`valve_designs` (a kind, ``"<inlet kind>/<delivery kind>"``, or ``"mixed"``).

    Returns
    -------
    tuple
        (speed [rpm] uniform in 450-950, load pressure [Pa] uniform in 1.5-4.5 MPa, air content [-] uniform
        in 0-0.03, the model): then each valve kind's design ranges drawn by :func:`draw`
        (``ValveKind.design_ranges``; a key naming a position applies only to a valve of that kind there).
    """
    speed = rng.uniform(450, 950)
    load = rng.uniform(1.5e6, 4.5e6)
    air = rng.uniform(0.0, 0.03)
    valve = "disc/reed" if valve == "mixed" else valve
    if valve in KINDS:
        model = load_model(kind_default_model(valve))
        placed = [(KINDS[valve], None)]
    else:
        a, b = valve.split("/")
        model = mixed_model(a, b)
        placed = [(KINDS[a], "inlet"), (KINDS[b], "delivery")]
    values = {}
    for kind, pos in placed:
        for key, (lo, hi) in kind.design_ranges.items():
            ok, path = _applies(key, pos)
            if ok:
                values[path] = draw(rng, lo, hi)
    return speed, load, air, with_values(model, values)


def mixed_model(inlet: str = "disc", delivery: str = "reed") -> PumpModel:
    """The thesis pump (thesis-disc's pump and oil) with an ``inlet`` kind inlet valve and a ``delivery``
    kind delivery valve (each with its kind's shipped defaults)."""
    return parse_model({"name": f"mixed-{inlet}-{delivery}", "valves": {"inlet": {"kind": inlet},
                                                                         "delivery": {"kind": delivery}}})
