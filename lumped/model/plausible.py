"""Values of a pump model that are possible but likely a slip: ``implausible_input`` warnings before running.

A value outside a parameter's declared bounds is refused (:class:`geometry.errors.InputError`); one inside them
but outside what real designs use (an oil of 150 kg/m^3, a 50 mm lift, a reed stiffness typed in MPa/m) is
accepted and reported, by ``valvelab model check`` and ``valvelab pump`` (their JSON ``warnings`` and stderr;
CONTRACT.md "Validity warnings"). Not part of a run's own warnings: a sweep's designs are not flagged for it.
"""

from __future__ import annotations

from geometry.declare import atypical
from lumped.validity import ResultWarning, beam_warnings
from lumped.valves.kind import kind_of


def input_warnings(model) -> list[ResultWarning]:
    """``implausible_input`` warnings for the values of a model that are possible but likely a slip: each
    declared number outside the range real designs fall in (:func:`geometry.declare.atypical`: its ``typical``
    range, else a factor 100 either side of the shipped model's value: the thesis pump and oil, the kind's
    default valve), a reed geometry's too, and a reed wider than long under beam theory (eq 3.8).

    Parameters
    ----------
    model : lumped.model.pump_model.PumpModel

    Returns
    -------
    list of ResultWarning
        One per value, the key path and the value in the message; empty for the shipped models.
    """
    from lumped.model.model_file import kind_default_model, load_model

    ref = load_model("thesis-disc")
    found = []
    for sec in ("pump", "oil", "circuit", "operating"):
        found += atypical(getattr(model, sec), sec, getattr(ref, sec))
    for pos in ("inlet", "delivery"):
        v = model.valve(pos)
        base = load_model(kind_default_model(kind_of(v).name)).valve(pos)
        reed = getattr(v, "reed", None)
        skip = set(kind_of(v).params.FROM_GEOMETRY) if reed is not None else set()
        found += [(k, m) for k, m in atypical(v, f"valves.{pos}", base) if k.split(".", 2)[2] not in skip]
        if reed is None:
            continue
        found += atypical(reed, f"valves.{pos}.geometry")
        found += beam_warnings(reed, getattr(v, "fidelity", None), f"valves.{pos}.geometry")
    return [ResultWarning("implausible_input", f"{k}: {m}") for k, m in found]
