"""The pump model: pump, oil, two check valves of any kind, circuit, and the effects switched on.

A :class:`PumpModel` is what one model file describes (``lumped.model.model_file``): frozen
components whose parameters are declared once (``geometry.declare.param``), plus the
candidate effects switched on (``effects``, applied by :func:`lumped.model.effect_library.resolve`
before a simulation). Components hold the *baseline* values; the effects are kept apart
so that the discrepancy workflow's baseline is the same model with the effects dropped.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from geometry.declare import Spec, param, spec_of
from lumped.model.effects import Applied
from lumped.fluid.oil import Oil
from lumped.model.pump import Circuit, Pump
from lumped.valves.kind import kind_of

POSITIONS = ("inlet", "delivery")


@dataclass(frozen=True)
class Operating:
    """A default operating point stored with a model (commands' flags override it)."""

    speed_rpm: float = param("speed_rpm", "rpm", "crank speed", bounds=(10.0, 20000.0), positive=True, optional=True)
    load_pressure: float = param("load_pressure", "Pa", "(mean) load pressure, absolute", bounds=(1e4, 1e8),
                                 positive=True, optional=True)


#: the operating point as command lines and spec files take it: speed [rpm], load pressure [MPa]
#: (the ranges of the declarations above)
SPEED = spec_of(Operating, "speed_rpm")
LOAD_MPA = Spec(None, "MPa", "(mean) load pressure, absolute",
                bounds=tuple(b * 1e-6 for b in spec_of(Operating, "load_pressure").bounds), positive=True)


@dataclass(frozen=True)
class PumpModel:
    """Everything a pump simulation needs (SI units); see the module docstring."""

    pump: Pump
    oil: Oil
    inlet: object
    delivery: object
    circuit: Circuit
    operating: Operating = Operating()
    effects: tuple[Applied, ...] = ()
    name: str = "custom"          # shipped name, or the model file's stem
    source: str = ""              # where it was read from
    uncertainties: tuple = ()     # declared input uncertainties (lumped.model.uncertainty.Uncertainty)

    def valve(self, position: str):
        """The valve at ``position`` (inlet or delivery)."""
        if position not in POSITIONS:
            raise KeyError(position)
        return getattr(self, position)

    def kind_at(self, target: str) -> str:
        """Kind name of the valve at ``target`` (for "both" and "pump": the inlet's, or "mixed")."""
        if target in POSITIONS:
            return kind_of(self.valve(target)).name
        kinds = {kind_of(self.inlet).name, kind_of(self.delivery).name}
        return kinds.pop() if len(kinds) == 1 else kind_of(self.inlet).name

    @property
    def kinds(self) -> tuple[str, str]:
        """(inlet kind, delivery kind)."""
        return kind_of(self.inlet).name, kind_of(self.delivery).name

    @property
    def label(self) -> str:
        """"disc", "reed", or "disc/reed" for mixed kinds (inlet/delivery)."""
        a, b = self.kinds
        return a if a == b else f"{a}/{b}"

    def with_effects(self, applied: tuple[Applied, ...]) -> "PumpModel":
        """This model with more effects switched on (after its own)."""
        return replace(self, effects=tuple(self.effects) + tuple(applied))

    def with_effect_values(self, name: str, target: str, values: dict) -> "PumpModel":
        """This model with effect ``name`` at ``target`` set to ``values`` (replacing an earlier entry)."""
        kept = tuple(a for a in self.effects if not (a.name == name and a.target == target))
        return replace(self, effects=kept + (Applied.of(name, target, values),))
