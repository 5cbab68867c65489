"""Lumped (ODE) models: oil, check valves of any registered kind, the piston pump.

The subpackages are the architecture, lowest layer first (a module imports only from its own
layer and the ones below; ``tests/test_layers.py`` checks it):

- :mod:`lumped.fluid`: oil properties and the orifice flow law (plain float functions numba compiles);
- :mod:`lumped.reed`: the reed as a structure (exact Euler-Bernoulli, mode functions, modal bases,
  the fidelity registry, plucked-reed identification, the reed's fluid quantities);
- :mod:`lumped.valves`: the valve-kind contract and registry (``kind``), the disc, reed and ball valves;
- :mod:`lumped.model`: what a pump model is (pump and circuit, :class:`PumpModel`, effects and their
  library, model files, input uncertainties);
- :mod:`lumped.solver`: how it is integrated (state layout, right-hand side, Jacobian, switching
  surfaces, the compiled Rodas steppers and scipy's reference stepper);
- :mod:`lumped.run`: running a pump (:func:`simulate`, revolutions and stop rules, post-processing,
  traces, warm starts); :mod:`lumped.conformance` checks a valve kind by running it.

The public face (see README.md, "Python"):

- models: :func:`load_model` (a shipped name or a model file), :class:`PumpModel`,
  :func:`with_values` (change keys by path), :func:`to_toml`, :data:`SHIPPED`;
- simulation: :func:`simulate` -> :class:`PumpResult` (``.to_dict()``, ``.to_frame()``, ``.plot()``),
  its :class:`Trace` (``.fold()``, ``.to_frame()``, ``.plot()``); when to stop, :class:`StopRule`
  (``StopRule.steady(tol)``: until cyclic steady state); where to start, :class:`TdcState`
  (``PumpResult.tdc_state``, a warm start) and the pool :class:`WarmStarts` of a study;
- reeds: :func:`reed_properties` (kappa, gamma1..3, h_eff of a reed by a registered fidelity);
- valve kinds: :data:`KINDS` (disc, reed, ball), :class:`DiscValve`, :class:`ReedValve`, :class:`BallValve`;
  :func:`check_valve_kind` (a kind's conformance check);
- effects: :data:`LIBRARY` (the candidate effects of the discrepancy workflow).
"""

# the valve kinds register themselves on import; every module that packs or integrates a
# model needs them registered first
# (registration order is the kinds' ids and the order of the compiled dispatch: the thesis's first)
from lumped.valves import disc as _disc_valve  # noqa: F401, I001
from lumped.valves import reed as _reed_valve  # noqa: F401
from lumped.valves import ball as _ball_valve  # noqa: F401
from lumped.conformance import check_valve_kind
from lumped.run.simulate import InvariantError, PumpResult, ValveResult, simulate
from lumped.valves.ball import BallValve
from lumped.valves.disc import DiscValve
from lumped.model.effect_library import LIBRARY
from lumped.model.pump_model import PumpModel
from lumped.model.model_file import SHIPPED, load_model, to_toml, with_values
from lumped.reed.fidelities import reed_properties
from lumped.valves.reed import ReedValve
from lumped.run.options import SolverOptions, TraceOptions
from lumped.run.revolutions import StopRule, TdcState
from lumped.run.trace import Trace
from lumped.valves.kind import KINDS
from lumped.run.warmstart import WarmStarts, chain_order

__all__ = [
    "BallValve", "DiscValve", "InvariantError", "KINDS", "LIBRARY", "PumpModel", "PumpResult", "ReedValve",
    "SHIPPED", "SolverOptions", "StopRule", "TdcState", "Trace", "TraceOptions", "ValveResult", "WarmStarts",
    "chain_order", "check_valve_kind", "load_model", "reed_properties", "simulate", "to_toml", "with_values"
]
