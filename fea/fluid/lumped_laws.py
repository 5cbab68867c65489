"""The ``orifice`` fluid fidelity: today's lumped laws of the disc valve at one operating point.

For comparison with the field models: Cd(Re) of eq 2.47 with the valve's coefficients (eq 2.48
for the thesis disc), the pressure drop from the orifice equation 2.38 with A_o of eq 2.40,
the pressure force of eq 2.18 (C1 dP A_disc below the Poiseuille-orifice transition, dP A_disc
above it; the squeeze term needs a velocity and is left out of a steady point) and the steady
flow force of eq 2.36 with the valve's jet angle (the bevel angle unless the model sets one).
"""

from __future__ import annotations

import math

from lumped.fluid.orifice import discharge_coefficient

from .point import FlowPoint, FluidValve, check_lift, check_reynolds, check_valve


def orifice_point(valve: FluidValve, lift: float, reynolds: float, options=None) -> FlowPoint:
    """One operating point of the lumped laws (module docstring).

    Examples
    --------
    The thesis disc at Re = 50 and 1 mm: eq 2.48 gives Cd = 0.461

    >>> from fea.fluid.point import load_fluid_valve
    >>> p = orifice_point(load_fluid_valve("thesis-disc:inlet"), 1e-3, 50.0)
    >>> print(f"Cd = {p.cd:.3f}, force coefficient {p.force_coefficient:.3f}")
    Cd = 0.461, force coefficient 1.000
    """
    valve = check_valve(valve)
    if valve.kind != "disc":
        from geometry.errors import InputError

        raise InputError("valve", f"the orifice laws here are the disc's; the {valve.kind} valve has its own")
    lift = check_lift(valve, lift)
    reynolds = check_reynolds(reynolds)
    v = valve.params
    q = valve.flow_of(reynolds)
    a_o = valve.orifice_area(lift)
    cd = float(discharge_coefficient(math.sqrt(reynolds), v.cd_inf, v.cd_a, v.cd_b, v.cd_c))
    dp = 0.5 * valve.density * (q / (cd * a_o)) ** 2                             # eq 2.38
    poiseuille = v.poiseuille_regime and lift < v.transition_opening           # eq 2.18
    coefficient = v.c1 if poiseuille else 1.0
    force = coefficient * dp * v.disc_area
    flow_force = valve.density * (q * q / v.port_area - q * q / a_o * math.cos(v.jet_angle_value))   # eq 2.36
    return FlowPoint(lift=lift, reynolds=reynolds, flow=q, dp=dp, cd=cd, force=force,
                     force_coefficient=coefficient, flow_force=flow_force,
                     extra={"jet_angle": v.jet_angle_value, "regime": "poiseuille" if poiseuille else "orifice"})
