"""Which simulator the discrepancy and synth commands use: a pump model, or a model module.

``--model NAME|FILE`` (or ``model = "FILE"`` in run.toml, a path relative to the run
folder) picks a pump model (``lumped.model.model_file``): valvelab's pump with the user's
pump, oil and valves (:class:`studies.discrepancy.pump_sim.PumpSimulator`). Default: the shipped
thesis model of the dataset's valve type. ``--simulator MODULE`` swaps in another model
altogether: a module with ``simulate(condition, applied_effects) -> CycleTrace`` and
``LIBRARY`` (a :class:`lumped.model.effects.Library`); ``--model MODULE`` is still understood
for a module name that is neither a shipped model nor a file, with a note on stderr.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from geometry.errors import InputError
from lumped.model.model_file import SHIPPED, kind_default_model, model_ref
from lumped.valves.kind import KINDS


@dataclass
class Simulator:
    """simulate(condition, effects) -> CycleTrace, the effect library it understands, and the
    context effect priors are computed for (a PumpModel, or None: the runs' valve type)."""

    simulate: Callable
    library: object
    context: object = None
    name: str = ""


def _module(name: str, field: str) -> Simulator:
    from lumped.plugins import import_object

    mod = import_object(name, field)
    sim, lib = getattr(mod, "simulate", None), getattr(mod, "LIBRARY", None)
    if not callable(sim) or lib is None:
        raise InputError(field, f"module {name!r} must define simulate(condition, effects) and LIBRARY")
    return Simulator(sim, lib, None, name)


def _is_model(name: str) -> bool:
    return name in SHIPPED or name in KINDS or Path(name).is_file()


def choose(model: str | None = None, simulator: str | None = None, runs: list | None = None,
           valve_type: str | None = None) -> Simulator:
    """The simulator for a command (see the module docstring)."""
    from lumped.model.model_file import load_model

    from studies.discrepancy.pump_sim import LIBRARY, PumpSimulator

    if simulator is not None:
        if model is not None:
            raise InputError("--simulator", "give --model or --simulator, not both")
        return _module(simulator, "--simulator")
    if model is not None and not _is_model(model) and "/" not in model and not model.endswith(".toml"):
        sys.stderr.write(f"valvelab: note: --model {model} names a module; use --simulator {model} "
                         "(--model now takes a model name or file)\n")
        return _module(model, "--model")
    if model is None and runs:
        named = {r.model for r in runs}
        if None not in named and len(named) == 1:
            path = named.pop()
            run0 = runs[0]
            # a shipped model's name (synth --model thesis-ball writes it) as it is; a file relative to the run
            pm = load_model(model_ref(path, run0.path if run0.path is not None else Path(".")),
                            field=f"{run0.name}/run.toml: model")
            return _checked(Simulator(PumpSimulator(pm), LIBRARY, pm, pm.name), runs, "run.toml: model")
        if len(named) > 1:
            raise InputError("run.toml: model", "the runs name different models (or some none); one dataset, "
                                                "one model (or pass --model)")
    if model is None:
        vt = valve_type or (runs[0].valve_type if runs else "disc")
        model = kind_default_model(vt) if vt in KINDS else None
        if model is None:
            raise InputError("--model", f"runs of {vt!r} valves need a model file (--model)")
    pm = load_model(model, field="--model")
    return _checked(Simulator(PumpSimulator(pm), LIBRARY, pm, pm.name), runs, "--model")


#: the valves of the --demo dataset (the thesis's disc rig with its O-ring, studies/cli/discrepancy.py)
DEMO_VALVES = "disc"


def check_demo_model(model: str | None, simulator: str | None) -> None:
    """InputError naming ``--model`` when the model given with ``--demo`` has other valves than the demo dataset's
    disc valves (decided before the dataset is written, not after)."""
    if model is None or simulator is not None:
        return
    if not _is_model(model) and "/" not in model and not model.endswith(".toml"):
        return                                  # a module (the old --model MODULE), checked when it runs
    from lumped.model.model_file import load_model

    pm = load_model(model, field="--model")
    if pm.label != DEMO_VALVES:
        raise InputError("--model", f"the model {pm.name!r} has {pm.label} valves; the --demo dataset is measured "
                                    f"on the thesis's {DEMO_VALVES} valves: give a {DEMO_VALVES} model or leave --model out")


def _checked(sim: Simulator, runs, field: str) -> Simulator:
    """A pump model must have the valves the runs were measured on, and deliver what they measured."""
    from studies.discrepancy.measured import check_delivery

    for r in runs or ():
        if r.valve_type != sim.context.label:
            raise InputError(field, f"the model {sim.name!r} has {sim.context.label} valves; run {r.name} "
                                    f"was measured on {r.valve_type} valves")
        if r.delivery_cc_per_rev is not None:
            check_delivery(r.delivery_cc_per_rev, sim.context.pump.displacement,
                           f"{r.name}/run.toml: delivery_cc_per_rev")
    return sim


def load_model(name: str | None):
    """(simulate, LIBRARY) of a model module or pump model (the older interface of this module)."""
    s = choose(model=name)
    return s.simulate, s.library
