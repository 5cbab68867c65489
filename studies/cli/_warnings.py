"""Validity warnings (lumped.validity) for the commands whose simulations go through a simulator of their own
(``synth``, ``discrepancy``): one run of the pump model at each condition, its warnings named by the run."""

from __future__ import annotations

#: the run settings of the check: the pump at cyclic steady state (lumped.run.simulate.simulate)
SETTINGS = {"revolutions": 3, "max_revolutions": 20}


def at_conditions(simulator, conditions, effects=(), names=None) -> list[dict]:
    """The validity warnings (:mod:`lumped.validity`) of a simulator's pump model at each condition.

    Parameters
    ----------
    simulator : object
        With ``model_for(condition, effects)`` (:class:`studies.discrepancy.pump_sim.PumpSimulator`);
        a simulator without it (a module's own) has none.
    conditions : sequence
        Each with ``speed_rpm`` [rpm] and ``load_pressure_pa`` [Pa].
    effects : sequence
        The effects applied.
    names : list of str, optional
        The conditions' names (default theirs, or ``condition N``).

    Returns
    -------
    list of dict
        ``{"code", "message"}``, each message led by its condition's name; a condition whose check
        run fails is skipped (the command's own simulation of it already reported).
    """
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
