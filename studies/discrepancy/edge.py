"""A fit at the edge of its plausible range: does the effect fade out there, or do the data want more of it?

A candidate whose fitted value sits on a search bound or at the edge of its plausible range
(:meth:`lumped.model.effects.Parameter.plausibility`) is judged by which end it sits at, as the parameter
declares once (``Parameter.strong``, :meth:`lumped.model.effects.Parameter.edge_side`):

- at the end where the effect is **strongest** (a jet angle at 5 deg, cos ~ 1; a damping, a mass, a film, a
  leak at its upper plausible bound; a seat at its softest) the data want more of the effect than physics
  allows: the signature of a candidate soaking up another effect's form mismatch (a flow force on the inlet
  valve standing in for the opening a film of another cavitation rule moves). It is refused as implausible;
- at the end where the effect **fades out** (a jet angle near 90 deg, whose steady force goes with
  cos(theta_jet) -> 0; a film, a mass or a damping at a tenth of its prior) a flat valley ends at the edge and
  the data cannot pin the value: it is moved inside the range by ``Settings.edge_pull`` of the range's width,
  the candidate's other parameters and the nuisances refitted with it held, and the candidate is judged there
  unless that costs more than a right effect of another form may trade (``Settings.max_worse_units`` or
  ``Settings.worse_fraction`` of the candidate's fit gain, the tolerance of the decision rule's evidence by
  kind): then the data pin the fading end, and it stays implausible too.

A parameter that declares no end is implausible at either edge. A value pulled inside is held where it is by
every later refit of the search once the candidate is added (``Problem.held``, set by ``search.add``, read by
``fitting.fit``, ``fitting.refine`` and ``fitting.polish``), so no reported value leaves the range.
"""

from __future__ import annotations

from lumped.model.effects import Parameter
from studies.discrepancy import fitting
from studies.discrepancy.fitting import acceptable_units
from studies.discrepancy.records import with_value

def pulled_value(p: Parameter, value: float, pull: float) -> float:
    """``value`` moved inside its acceptable zone by ``pull`` of the plausible range's width (unit coordinates),
    from the side it is nearest."""
    lo, hi = acceptable_units(p)
    width = p.to_unit(p.plausible[1]) - p.to_unit(p.plausible[0])
    u = p.to_unit(value)
    inside = min(hi, lo + pull * width) if abs(u - lo) <= abs(u - hi) else max(lo, hi - pull * width)
    return p.from_unit(inside)


def pull_inside(pb, model: tuple, i: int, base_fit: float, cost: float):
    """(model, fit cost, sensor nuisances, note, the parameters pulled) with the implausible parameters of the
    effect ``model[i]`` pulled inside their plausible range and the rest of it and the nuisances refitted, when
    every one sits at its fading end and that costs at most the tolerance (module docstring) more than ``cost``
    (the fit cost of ``model``; ``base_fit``: that of the model without the effect); None when one sits at its
    strong end, or the data pin the fit to the edge (or nothing can be pulled)."""
    st = pb.settings
    eff = pb.library[model[i].name]
    vals = model[i].value_dict
    params = eff.parameters_for(pb.context, model[i].target)
    edge = [p for p in params if p.plausibility(vals[p.name]) is not None]
    if st.edge_pull <= 0.0 or not edge or any(p.edge_side(vals[p.name]) != "fading" for p in edge):
        return None          # the data want more of the effect than physics allows (or no end is declared)
    moved = model
    for p in edge:
        moved = with_value(moved, i, p.name, pulled_value(p, vals[p.name], st.edge_pull))
    held = frozenset((i, p.name) for p in edge)
    names = {eff.name, *pb.nuisance_effects}
    moved = fitting.polish(pb, moved, names, fixed=held, least=1)
    new_cost, nuis = pb.fit_objective(moved)
    tolerance = max(st.max_worse_units, st.worse_fraction * max(base_fit - cost, 0.0))
    if not new_cost - cost <= tolerance:
        return None
    new = moved[i].value_dict
    note = "; ".join(f"{p.name} {vals[p.name]:.4g} -> {new[p.name]:.4g} {p.unit}" for p in edge)
    note = (f"pulled inside its plausible range ({note}): the fit costs {new_cost - cost:.2g} units more "
            f"(tolerance {tolerance:.2g}), so the data do not pin it to the edge")
    return moved, new_cost, nuis, note, tuple(p.name for p in edge)
