"""Which pump model the discrepancy and synth commands use (``--model MODULE``).

A model module provides ``simulate(condition, applied_effects) -> CycleTrace`` (see
``studies/discrepancy.py``) and ``LIBRARY`` (a :class:`lumped.effects.Library`).
The default is valvelab's own pump of the thesis (``studies.pump_sim``); a user can
point the workflow at their own model the same way.
"""

from __future__ import annotations

import importlib

from geometry.errors import InputError

DEFAULT_MODEL = "studies.pump_sim"


def load_model(name: str | None):
    """(simulate, LIBRARY) of a model module."""
    name = name or DEFAULT_MODEL
    try:
        mod = importlib.import_module(name)
    except ImportError as exc:
        raise InputError("--model", f"cannot import {name!r} ({exc})") from None
    sim, lib = getattr(mod, "simulate", None), getattr(mod, "LIBRARY", None)
    if not callable(sim) or lib is None:
        raise InputError("--model", f"module {name!r} must define simulate(condition, effects) and LIBRARY")
    return sim, lib
