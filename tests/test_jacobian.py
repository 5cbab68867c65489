"""The analytic Jacobian of the pump (lumped.solver.jacobian) against central differences of the right-hand side.

Random parameter draws, each candidate effect switched on in turn, every valve kind, mixed
kinds and both circuits, states in every contact state and regime (and a cavitating
cylinder): every entry of df/dy and df/dt must agree. A perturbed partial must be caught.
"""

from __future__ import annotations

import numpy as np
import pytest

from lumped.solver import compiled
from lumped.solver import jacobian as J
from lumped.solver import steppers  # noqa: F401  (compiled.cached digests its source: import it even when run alone)
from lumped.conformance import jacobian_errors as _errors
from lumped.model.effect_library import LIBRARY
from lumped.model.model_file import with_values
from lumped.solver.problem import PumpProblem
from lumped.valves.kind import KINDS
from lumped.model.random_designs import random_design

#: every effect of the library switched on at its priors, and the oil with and without air
EFFECTS = {"none": {}, **{name: {f"effects.{name}": True} for name in LIBRARY.names() if name != "entrained_air"},
           "entrained_air": {"oil.air_content": 0.02}, "air_free": {"oil.air_content": 0.0}}
DESIGNS = (*KINDS, "mixed", "ball/reed", "modal")
#: the design "modal": the reed pump with the prototype geometry and a three-mode delivery valve under an
#: off-axis port (lumped/reed/structure.py), with the drag of eq 3.21 on (its partials are the reed's own)
MODAL = {"valves.geometry": "prototype", "valves.delivery.dynamics": "modal", "valves.delivery.modes": 3,
         "valves.delivery.damping.drag": True, "valves.delivery.damping.drag_coefficient": 1.2,
         "valves.delivery.port.s_start": 8e-3, "valves.delivery.port.s_end": 20e-3,
         "valves.delivery.port.width": 4e-3, "valves.delivery.port.y_center": 2.5e-3}


def _design(rng, valve):
    if valve == "modal":
        speed, load, air, model = random_design(rng, "reed")
        return speed, load, air, with_values(model, MODAL)
    return random_design(rng, valve)


def _applies(effect: str, valve: str) -> bool:
    """Whether an effect has a meaning for a design's valves (lumped.model.effects.Effect.applies_to)."""
    if effect not in LIBRARY:
        return True
    _, _, _, model = _design(np.random.default_rng(0), valve)
    e = LIBRARY[effect]
    return any(e.applies_to(model, t) for t in e.targets)


CASES = [(e, v, c) for e in EFFECTS for v in DESIGNS for c in ("simplified", "complete") if _applies(e, v)]


def _model(valve, effect, seed):
    speed, load, air, model = _design(np.random.default_rng(seed), valve)
    return with_values(model, dict(EFFECTS[effect])), speed, load


def jacobian_errors(model, speed, load, circuit, seed, jac_fn):
    """Largest normalised |analytic - central| over the states drawn (lumped.conformance.jacobian_errors)."""
    problem = PumpProblem.build(model, speed, load, circuit, needle_area=2e-7 if circuit == "complete" else None)
    return _errors(problem, seed, jac_fn)


@pytest.mark.parametrize("effect, valve, circuit", CASES)
def test_jacobian_equals_central_differences(effect, valve, circuit):
    model, speed, load = _model(valve, effect, seed=CASES.index((effect, valve, circuit)))
    # the flavour of the compiled physics the fast path integrates the pump with
    jac = compiled.cached("lumped.solver.jacobian", "pump_jacobian", valve != "modal")
    ej, et = jacobian_errors(model, speed, load, circuit, 7, jac)
    assert ej < 1.0, f"df/dy off by {ej:.3g} tolerance units"
    assert et < 1.0, f"df/dt off by {et:.3g} tolerance units"


def test_the_python_jacobian_is_the_compiled_one():
    model, speed, load = _model("mixed", "piston_leakage", 3)
    ej, et = jacobian_errors(model, speed, load, "complete", 11, J.pump_jacobian)
    assert ej < 1.0 and et < 1.0


@pytest.mark.parametrize("factor", [1.01, 0.99])
def test_a_wrong_partial_is_caught(monkeypatch, factor):
    """Scale one partial (d mdot / d rho of the valve mass flows) by 1 %: the comparison fails."""
    from lumped.valves import kind as V

    def bad_mass_flow(qo, aq, u, dp, rho, dq_ddp, dq_dx):
        m, d_dp, d_rho, d_x, d_u = V.mass_flow(qo, aq, u, dp, rho, dq_ddp, dq_dx)
        return m, d_dp, d_rho * factor, d_x, d_u

    monkeypatch.setattr(J, "mass_flow", bad_mass_flow)
    model, speed, load = _model("disc", "none", 5)
    ej, _ = jacobian_errors(model, speed, load, "simplified", 13, J.pump_jacobian)
    assert ej > 1.0
