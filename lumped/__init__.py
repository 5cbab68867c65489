"""Lumped (ODE) models: oil, check valves of any registered kind, the piston pump.

The public face (see README.md, "Python"):

- models: :func:`load_model` (a shipped name or a model file), :class:`PumpModel`,
  :func:`with_values` (change keys by path), :func:`to_toml`, :data:`SHIPPED`;
- simulation: :func:`simulate` -> :class:`PumpResult` (``.to_dict()``, ``.to_frame()``, ``.plot()``);
- valve kinds: :data:`KINDS` (disc, reed), :class:`DiscValve`, :class:`ReedValve`;
- effects: :data:`LIBRARY` (the candidate effects of the discrepancy workflow).
"""

# the valve kinds register themselves on import; every module that packs or integrates a
# model needs them registered first
from lumped import disc_valve as _disc_valve  # noqa: F401
from lumped import reed_valve as _reed_valve  # noqa: F401
from lumped.disc_valve import DiscValve
from lumped.effect_library import LIBRARY
from lumped.model import PumpModel
from lumped.model_file import SHIPPED, load_model, to_toml, with_values
from lumped.reed_valve import ReedValve
from lumped.valve import KINDS

__all__ = ["DiscValve", "KINDS", "LIBRARY", "PumpModel", "ReedValve", "SHIPPED", "load_model", "to_toml",
           "with_values"]
