"""Candidate effects: named, switchable extensions of the baseline pump/valve model.

The discrepancy workflow (``studies/discrepancy/workflow.py``) asks which physics the
baseline is missing. Each candidate is one :class:`Effect`: its parameters with
search bounds, a physical prior (the value physics predicts and where it comes
from: a thesis equation, an FEA result, a correlation) and a plausibility range,
plus a function ``apply(params, values, target) -> params`` that switches the effect
on in the model's frozen parameter dataclasses (``dataclasses.replace``).

Adding an effect is one new ``Library.register`` call with one new :class:`Effect`;
the workflow, the synthetic-data generator and the report pick it up by name.
The entries for the pump model of the thesis are in :mod:`lumped.model.effect_library`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Callable

#: where an effect acts: one candidate per valve, or one for the whole pump
PER_VALVE = ("inlet", "delivery")
BOTH_VALVES = ("both",)
PUMP = ("pump",)


@dataclass(frozen=True)
class Parameter:
    """One parameter of an effect (SI units).

    ``prior`` is the value physics predicts (``source`` says from where);
    ``bounds`` the range searched (in log space if ``log``); ``plausible`` the
    range a fitted value must fall in to be believed. A fit that ends on a bound
    or outside ``plausible`` is reported but never added to the model.

    ``strong`` is the end of the range where the effect is strongest ("high" or "low"; the other end is where
    it fades out): a fit at the plausible edge on the strong side says the data want more of the effect than
    physics allows, one at the fading side only that the data cannot pin a weak effect's value
    (``studies/discrepancy/edge.py``). None: not declared, a fit at either edge is implausible.
    """

    name: str
    unit: str
    prior: float
    bounds: tuple[float, float]
    plausible: tuple[float, float]
    source: str
    log: bool = True
    field: str | None = None              # the declared component field this parameter sets
    prior_from: Callable | None = None    # prior computed for a model: f(model, target) -> value
    relative: bool = False                # bounds and plausible range are multiples of the prior
    strong: str | None = None             # "high"/"low": the end where the effect is strongest (None: undeclared)

    def __post_init__(self):
        if self.strong not in (None, "high", "low"):
            raise ValueError(f"{self.name}: strong must be 'high', 'low' or None, not {self.strong!r}")
        if self.relative:
            return                        # checked once resolved for a model (for_model)
        lo, hi = self.bounds
        if not lo < hi:
            raise ValueError(f"{self.name}: bounds must be increasing")
        if self.log and lo <= 0:
            raise ValueError(f"{self.name}: log-space bounds must be positive")
        if not lo <= self.prior <= hi:
            raise ValueError(f"{self.name}: prior {self.prior} outside bounds {self.bounds}")

    def for_model(self, model, target: str) -> "Parameter":
        """This parameter with its prior (and relative ranges) evaluated for ``model`` and ``target``."""
        prior = self.prior if self.prior_from is None else float(self.prior_from(model, target))
        if not self.relative:
            return replace(self, prior=prior, prior_from=None)
        lo, hi = self.bounds
        plo, phi = self.plausible
        return Parameter(self.name, self.unit, prior, (prior * lo, prior * hi), (prior * plo, prior * phi),
                         self.source, self.log, self.field, strong=self.strong)

    def to_unit(self, value: float) -> float:
        """Position of ``value`` within the bounds, 0..1 (log or linear)."""
        lo, hi = self.bounds
        if self.log:
            return (math.log(value) - math.log(lo)) / (math.log(hi) - math.log(lo))
        return (value - lo) / (hi - lo)

    def from_unit(self, u: float) -> float:
        """Inverse of :meth:`to_unit`."""
        lo, hi = self.bounds
        u = min(max(u, 0.0), 1.0)
        if self.log:
            return math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo)))
        return lo + u * (hi - lo)

    def plausibility(self, value: float, bound_tol: float = 0.01) -> str | None:
        """None if ``value`` is plausible, else the reason: on a search bound, outside the plausible range, or
        at its edge (within ``bound_tol`` of its width, in the search's log or linear scale: a fit pinned to
        the edge of the plausible range wants to go beyond it, whatever the wider search range allows)."""
        u = self.to_unit(value)
        if u <= bound_tol or u >= 1.0 - bound_tol:
            return f"{self.name} = {value:.4g} {self.unit} ran into the search bound {self.bounds}"
        lo, hi = self.plausible
        if not lo <= value <= hi:
            return (f"{self.name} = {value:.4g} {self.unit} is outside the physically plausible range "
                    f"{lo:.3g}-{hi:.3g} ({self.source})")
        ulo, uhi = self.to_unit(lo), self.to_unit(hi)
        edge = bound_tol * (uhi - ulo)
        if (ulo > bound_tol and u - ulo <= edge) or (uhi < 1.0 - bound_tol and uhi - u <= edge):
            return (f"{self.name} = {value:.4g} {self.unit} sits at the edge of the physically plausible range "
                    f"{lo:.3g}-{hi:.3g}: the fit wants to go beyond it ({self.source})")
        return None

    def edge_side(self, value: float, bound_tol: float = 0.01) -> str | None:
        """Which end of the range an implausible ``value`` sits at: "strong" (the end ``strong`` names,
        where the effect is largest), "fading" (the other), or None where it is plausible or no end is
        declared. The nearer end in the search's unit scale counts."""
        if self.strong is None or self.plausibility(value, bound_tol) is None:
            return None
        u = self.to_unit(value)
        ulo, uhi = self.to_unit(self.plausible[0]), self.to_unit(self.plausible[1])
        high = abs(u - uhi) < abs(u - ulo)
        return "strong" if high == (self.strong == "high") else "fading"


@dataclass(frozen=True)
class Effect:
    """A named extension of the baseline model.

    ``apply(params, values, target)`` returns the model parameters with the effect
    switched on, ``values`` mapping parameter names to values and ``target`` one of
    ``targets`` ("inlet"/"delivery" for an effect of one valve, "both", "pump"). ``valve_types``:
    the valve kinds the effect has a meaning for (None: every kind; an effect on the whole pump is
    never checked against kinds).
    ``parameters`` may be empty (a pure switch). ``variants`` overrides them for a
    valve type whose model states the effect differently (the reed's seat stiffness is
    a pressure per metre, the disc's a force per metre). ``derived(values, context[, target])``
    gives reported quantities that follow from the fitted ones (e.g. the critical seat
    damping from the seat stiffness), in the units of ``derived_units`` ({name: unit}, or {name: {kind: unit,
    None: the other kinds' unit}} where a variant states the effect per unit area). ``candidate=False`` marks a model error the
    synthetic-data generator can inject but the workflow never searches (e.g. a
    discharge coefficient a few percent off). ``applicable(runs)`` returns None, or why
    the effect is not a candidate for a dataset (e.g. entrained air when run.toml
    states the air content). ``tight_tolerance``: a model with the effect is simulated at tight
    integrator tolerances by the discrepancy workflow (its response is steep in the effect's
    parameters, so a fit at the fast path's default tolerances reads integration noise as evidence).
    ``placement``: the workflow searches the effect at ``targets[0]`` and then tries its other targets
    (one valve instead of both) at the fitted values, keeping the one the data prefer.
    """

    name: str
    summary: str
    parameters: tuple[Parameter, ...]
    apply: Callable[[Any, dict, str], Any]
    valve_types: tuple[str, ...] | None = None
    targets: tuple[str, ...] = BOTH_VALVES
    derived: Callable[[dict, str], dict] | None = None
    derived_units: dict = field(default_factory=dict)
    candidate: bool = True
    applicable: Callable[[list], str | None] | None = None
    variants: dict = field(default_factory=dict)
    tight_tolerance: bool = False
    placement: bool = False

    def parameters_for(self, context=None, target: str | None = None) -> tuple[Parameter, ...]:
        """The parameters of the effect for a context: a valve type (kind name) or a model.

        A model (anything with ``kind_at(target)``) picks the variant of the target valve's
        kind; model-dependent priors and relative ranges are evaluated for it
        (:meth:`Parameter.for_model`; with a kind name the prior function gets None).
        """
        target = target or self.targets[0]
        if context is None or isinstance(context, str):
            model, kind = None, context
        else:
            model, kind = context, self._kind(context, target)
        return tuple(p.for_model(model, target) if (p.prior_from is not None or p.relative) else p
                     for p in self.variants.get(kind, self.parameters))

    def _kind(self, model, target: str) -> str:
        """The valve kind an effect at ``target`` of a model acts on: the target's, or for "both"/"pump"
        the first valve's kind the effect has (a mixed pump: the valves of that kind)."""
        if target in PER_VALVE:
            return model.kind_at(target)
        kinds = [model.kind_at(pos) for pos in PER_VALVE]
        return next((k for k in kinds if self.valve_types is None or k in self.valve_types), kinds[0])

    def applies_to(self, context, target: str) -> bool:
        """Whether the effect has a meaning for the target valve(s) of a context (kind name or model)."""
        if context is None or self.valve_types is None or target == "pump" or self.targets == PUMP:
            return True
        if isinstance(context, str):
            return context in self.valve_types
        return self._kind(context, target) in self.valve_types

    def prior_values(self, context=None, target: str | None = None) -> dict:
        return {p.name: p.prior for p in self.parameters_for(context, target)}

    def parameter(self, name: str, context=None, target: str | None = None) -> Parameter:
        for p in self.parameters_for(context, target):
            if p.name == name:
                return p
        raise KeyError(name)

    def plausibility(self, values: dict, context=None, target: str | None = None) -> str | None:
        """None if every fitted value is plausible, else the first reason."""
        for p in self.parameters_for(context, target):
            why = p.plausibility(values[p.name])
            if why:
                return why
        return None

    def units(self, context=None, target: str | None = None) -> dict:
        """The unit of every value :meth:`report` gives for a context (kind name or model): the parameters'
        declared units, then the derived quantities' (``derived_units``), e.g. ``{"k_seat": "N/m", "c_seat":
        "N s/m"}``."""
        out = {p.name: p.unit for p in self.parameters_for(context, target)}
        if self.derived_units:
            target = target or self.targets[0]
            kind = context if (context is None or isinstance(context, str)) else self._kind(context, target)
            for name, unit in self.derived_units.items():
                out[name] = unit.get(kind, unit[None]) if isinstance(unit, dict) else unit
        return out

    def report(self, values: dict, context=None, target: str | None = None) -> dict:
        """Fitted and derived values as reported in JSON."""
        out = {p.name: float(values[p.name]) for p in self.parameters_for(context, target)}
        if self.derived is not None:
            import inspect

            args = (values, context, target or self.targets[0])
            n = len(inspect.signature(self.derived).parameters)
            out.update({k: float(v) for k, v in self.derived(*args[:n]).items()})
        return out


@dataclass(frozen=True)
class Applied:
    """An effect switched on at one target with its parameter values (hashable: a cache key)."""

    name: str
    target: str
    values: tuple[tuple[str, float], ...]

    @staticmethod
    def of(name: str, target: str, values: dict) -> "Applied":
        return Applied(name, target, tuple(sorted((k, float(v)) for k, v in values.items())))

    @property
    def value_dict(self) -> dict:
        return dict(self.values)

    def with_values(self, values: dict) -> "Applied":
        """The same effect and target with the parameters in ``values`` replaced."""
        return Applied.of(self.name, self.target, {**self.value_dict, **values})

    @property
    def key(self) -> str:
        return self.name if self.target in ("both", "pump") else f"{self.name}@{self.target}"


@dataclass
class Library:
    """A registry of effects by name (the workflow takes one; tests may build their own)."""

    effects: dict = field(default_factory=dict)

    def register(self, effect: Effect) -> Effect:
        """Add an effect; ValueError if its name repeats, a target is unknown, or a valve kind it claims
        (``valve_types``; None: every registered kind) does not declare a field one of its parameters sets
        (:func:`missing_fields` names both)."""
        if effect.name in self.effects:
            raise ValueError(f"effect {effect.name!r} is registered twice")
        for t in effect.targets:
            if t not in PER_VALVE + BOTH_VALVES + PUMP:
                raise ValueError(f"effect {effect.name!r}: unknown target {t!r}")
        problems = missing_fields(effect)
        if problems:
            raise ValueError(problems[0])
        self.effects[effect.name] = effect
        return effect

    def __getitem__(self, name: str) -> Effect:
        return self.effects[name]

    def __contains__(self, name: str) -> bool:
        return name in self.effects

    def names(self, candidates_only: bool = False) -> list[str]:
        return [n for n, e in self.effects.items() if e.candidate or not candidates_only]

    def candidates(self, context, runs: list | None = None) -> tuple[list, dict]:
        """(effect, target) pairs the workflow searches for a dataset, and the excluded ones with reasons.

        ``context``: the valve type (kind name) or the base model (anything with ``kind_at``).
        """
        out, excluded = [], {}
        for e in self.effects.values():
            if not e.candidate:
                continue
            targets = [t for t in e.targets if e.applies_to(context, t)]
            if not targets:
                what = context if isinstance(context, str) else "model's"
                excluded[e.name] = f"does not apply to the {what} valves"
                continue
            why = e.applicable(runs or []) if e.applicable else None
            if why:
                excluded[e.name] = why
                continue
            out += [(e, t) for t in (targets[:1] if e.placement else targets)]
        return out, excluded

    def apply(self, params, model: tuple[Applied, ...]):
        """``params`` with every applied effect switched on, in order."""
        for a in model:
            params = self.effects[a.name].apply(params, a.value_dict, a.target)
        return params


def missing_fields(effect: Effect, kinds=None) -> list[str]:
    """What an effect claims of valve kinds that they do not declare, one line each naming the effect, the
    kind and the field (empty: none).

    ``kinds``: the registered :class:`lumped.valves.kind.ValveKind` entries to check (default: those the
    effect claims by ``valve_types``, every registered one for None). An effect on the whole pump sets
    ``pump.``/``oil.`` fields and is not checked against kinds.
    """
    from lumped.valves.kind import KINDS

    if effect.targets == PUMP:
        return []
    if kinds is None:
        kinds = [k for k in KINDS.values() if effect.valve_types is None or k.name in effect.valve_types]
    out = []
    for kind in kinds:
        declared = kind.params.__dataclass_fields__
        for p in effect.variants.get(kind.name, effect.parameters):
            if p.field and "." not in p.field and p.field not in declared:
                out.append(f"effect {effect.name!r} claims valve kind {kind.name!r} ("
                           f"{'every kind' if effect.valve_types is None else 'valve_types'}), but "
                           f"{kind.params.__name__} declares no field {p.field!r} that its parameter {p.name!r} "
                           f"sets: declare it on {kind.params.__name__} (param(None, ..., effect={effect.name!r}, "
                           f"packed=True)), give the kind a variant, or leave the kind out of valve_types")
    return out
