"""Validity warnings (lumped.validity) for the commands whose simulations go through a simulator of their own
(``synth``, ``discrepancy``): one run of the pump model at each condition, its warnings named by the run."""

from __future__ import annotations

#: the run settings of the check: the pump at cyclic steady state (lumped.run.simulate.simulate)
SETTINGS = {"revolutions": 3, "max_revolutions": 20}


def at_conditions(simulator, conditions, effects=(), names=None) -> list[dict]:
    """``[{"code", "message"}]`` of ``simulator``'s pump model (``model_for(condition, effects)``, as
    studies.discrepancy.pump_sim.PumpSimulator has) at each condition (``speed_rpm``, ``load_pressure_pa``),
    each message led by the condition's name; [] for a simulator without a pump model (a module's own).
    A condition whose check run fails is skipped: the command's own simulation of it already succeeded or
    failed with its message."""
    from geometry.errors import ModelFailure
    from lumped.run.simulate import simulate

    model_for = getattr(simulator, "model_for", None)
    if model_for is None:
        return []
    out = []
    for i, c in enumerate(conditions):
        name = names[i] if names is not None else getattr(c, "name", f"condition {i + 1}")
        try:
            r = simulate(model_for(c, tuple(effects)), c.speed_rpm, c.load_pressure_pa, **SETTINGS)
        except ModelFailure:
            continue
        out += [{"code": w.code, "message": f"{name}: {w.message}"} for w in r.warnings]
    return out
