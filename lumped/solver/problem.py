"""The pump problem a stepper integrates: the resolved model, its packed parameters and state layout.

Like an ``OdeSolver``'s problem in scipy.integrate: :meth:`PumpProblem.build` resolves a
model (its effects applied), packs it with an operating point (:func:`lumped.solver.layout.pack`)
and fixes the state layout (:class:`lumped.solver.layout.StateLayout`); a stepper
(:mod:`lumped.solver.steppers`) advances its state, the revolution runner (:mod:`lumped.run.revolutions`)
and the post-processors (:mod:`lumped.run.postprocess`) read it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lumped.solver.layout import LOAD_STATES, S_MCYL, G, StateLayout, layout_of, pack
from lumped.model.pump_model import PumpModel


@dataclass
class PumpProblem:
    """One pump at one operating point, ready to integrate (SI units).

    ``model``: the resolved model (effects applied); ``p``: the packed parameters (the driver
    may change the needle valve's Cd A in them); ``layout``: where each state sits;
    ``tune_needle``: the complete circuit's needle valve is set by the start-up procedure.
    """

    model: PumpModel
    speed_rpm: float
    load_pressure: float
    circuit: str
    p: np.ndarray
    layout: StateLayout
    tune_needle: bool = False

    @classmethod
    def build(cls, model: PumpModel, speed_rpm: float, load_pressure: float, circuit: str | None = None,
              needle_area: float | None = None) -> "PumpProblem":
        """The problem of ``model`` (resolved here) at ``speed_rpm`` [rpm], ``load_pressure`` [Pa]."""
        from lumped.model.effect_library import resolve

        resolved = resolve(model)
        circ = circuit or resolved.circuit.kind
        complete = circ == "complete"
        p = pack(resolved, speed_rpm, load_pressure, circ, needle_area)
        tune = complete and p[G.needle_cda] <= 0.0
        problem = cls(resolved, float(speed_rpm), float(load_pressure), circ, p, layout_of(resolved, complete), tune)
        if tune:
            p[G.needle_cda] = problem.needle_cda_estimate()
        return problem

    @property
    def complete(self) -> bool:
        return self.circuit == "complete"

    @property
    def omega(self) -> float:
        """Crank speed [rad/s]."""
        return float(self.p[G.omega])

    @property
    def period(self) -> float:
        """One revolution [s]."""
        return 2.0 * math.pi / self.omega

    @property
    def rho0(self) -> float:
        """Oil density at atmospheric pressure [kg/m^3] (eq 4.17's reference)."""
        return self.model.oil.density

    @property
    def m_rev(self) -> float:
        """Oil mass of one swept volume at atmospheric density [kg]."""
        return self.rho0 * self.model.pump.displacement

    @property
    def n_dyn(self) -> int:
        return self.layout.n_dyn

    @property
    def scales(self) -> np.ndarray:
        """Characteristic scale of each state (lumped.solver.layout.StateLayout.scales)."""
        return self.layout.scales(self.p, self.m_rev)

    def initial_state(self, load_mass) -> np.ndarray:
        """At TDC: the cylinder full at the load pressure, the valves at rest on their seats
        (``load_mass(P, p)``: the load line's oil mass at pressure P, lumped.solver.rhs.load_mass)."""
        y = np.zeros(self.layout.n_states)
        pl = self.p[G.load_pressure]
        y[S_MCYL] = self.model.oil.density_at(pl) * self.model.pump.dead_volume
        if self.complete:
            y[self.layout.index(LOAD_STATES[0])] = load_mass(pl, self.p)[0]
        return y

    def needle_cda_estimate(self) -> float:
        """First guess of Cd A of the needle valve [m^2]: pass 85 % of the ideal delivery at the load pressure."""
        p, oil = self.p, self.model.oil
        pl, pt = p[G.load_pressure], p[G.tank_pressure]
        ideal = self.model.pump.displacement - (oil.density_at(pl) / oil.density_at(pt) - 1.0) * self.model.pump.dead_volume
        mdot = 0.85 * ideal * oil.density * p[G.omega] / (2 * math.pi)
        return mdot / math.sqrt(2.0 * oil.density_at(pl) * (pl - pt))
