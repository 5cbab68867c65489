"""The piston pump of chapter 4: its parameters and the crank-slider kinematics.

:class:`Pump` and :class:`Circuit` declare the pump's parameters once (values of the
thesis rig in ``lumped/data/models/thesis-*.toml``). The kinematics are plain functions of
floats. The pump's right-hand side (the mass balance, the cylinder pressure, the valves)
is in :mod:`lumped.solver.rhs`; where each quantity sits in the flat parameter and state arrays
in :mod:`lumped.solver.layout`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from geometry.declare import param

# ----------------------------------------------------------------- parameters
@dataclass(frozen=True)
class Pump:
    """Crank-slider piston pump (Table 5.1; section 4.2)."""

    piston_diameter: float = param("piston_diameter", "m", "d_piston (Table 5.1)", bounds=(1e-4, 2.0), positive=True)
    crank_radius: float = param("crank_radius", "m", "r (Table 5.1)", bounds=(1e-5, 2.0), positive=True, packed=True)
    rod_length: float = param("rod_length", "m", "l, connecting rod (Table 5.1)", bounds=(1e-5, 20.0), positive=True,
                              packed=True)
    dead_volume: float = param("dead_volume", "m^3", "V_tdc, cylinder volume at top dead centre (Table 5.1)",
                               bounds=(1e-12, 10.0), positive=True, packed=True)
    tank_pressure: float = param("tank_pressure", "Pa", "P_tank, absolute (Table 5.1)", bounds=(1e3, 1e7),
                                 positive=True, packed=True)
    seal_length: float = param("seal_length", "m", "L, engaged piston length of the leakage path (eq 4.5)",
                               bounds=(1e-5, 10.0), positive=True)
    # set by the piston_leakage effect (lumped/model/effect_library.py); zero = no leakage
    leakage_clearance: float = param(None, "m", "radial piston clearance c of eq 4.5", bounds=(0.0, 1e-3),
                                     default=0.0, effect="piston_leakage")

    @property
    def piston_area(self) -> float:
        """A_p = pi d^2 / 4 [m^2]."""
        return math.pi * self.piston_diameter**2 / 4

    @property
    def displacement(self) -> float:
        """Swept volume per revolution 2 A_p r [m^3] (section 5.4.4: 2.22 cc)."""
        return 2 * self.piston_area * self.crank_radius

    @property
    def compression_ratio(self) -> float:
        """(V_tdc + 2 A_p r) / V_tdc: cylinder volume at BDC over TDC."""
        return (self.dead_volume + self.displacement) / self.dead_volume

    def leakage_coefficient(self, viscosity: float) -> float:
        """Laminar annulus conductance pi d c^3 / (12 mu L) [m^3/(s Pa)] (eq 4.5); 0 without clearance."""
        return math.pi * self.piston_diameter * self.leakage_clearance**3 / (12 * viscosity * self.seal_length)


@dataclass(frozen=True)
class Circuit:
    """Where the pump delivers: a constant load pressure (simplified) or the complete circuit (section 4.2).

    The complete circuit (Figure 4.1): load line, accumulator and a needle valve to tank.
    The thesis gives no values for it (it ran the simplified circuit); the shipped ones
    are plausible for its bench (thesis-disc.toml).
    """

    kind: str = param("kind", "-", "simplified: constant load pressure (section 4.2.2); complete: load line, "
                      "accumulator, needle valve (section 4.2.1)", choices=("simplified", "complete"))
    line_volume: float = param("line_volume", "m^3", "oil volume of the load line", bounds=(1e-9, 10.0),
                               positive=True, packed=True)
    accumulator_volume: float = param("accumulator_volume", "m^3", "gas volume at and below the precharge",
                                      bounds=(0.0, 10.0), packed=True)
    accumulator_precharge: float = param("accumulator_precharge", "Pa", "precharge pressure, absolute",
                                         bounds=(1e3, 1e9), positive=True, packed=True)
    accumulator_exponent: float = param("accumulator_exponent", "-", "polytropic exponent of the gas charge",
                                        bounds=(1.0, 1.7), packed=True)
    needle_discharge: float = param("needle_discharge", "-", "Cd of the needle valve", bounds=(0.01, 1.0),
                                    positive=True)
    needle_area: float = param("needle_area", "m^2", "needle valve opening; left out: set so that the mean load "
                               "pressure settles at the requested one (as the experimenter did, section 5.5.2)",
                               bounds=(1e-12, 1.0), positive=True, optional=True)

    @property
    def complete(self) -> bool:
        return self.kind == "complete"


# ----------------------------------------------------------------- kinematics (section 4.3.1)
def piston_position(theta: float, crank: float, rod: float) -> float:
    """Displacement of the piston from top dead centre at a crank angle, x_p = r (1 - cos theta) + l - sqrt(l^2 -
    r^2 sin^2 theta) (eq 4.1).

    Parameters
    ----------
    theta : float
        Crank angle from TDC [rad].
    crank : float
        Crank radius r [m].
    rod : float
        Connecting-rod length l [m].

    Returns
    -------
    float
        x_p [m].

    References
    ----------
    Knutson (2016), eq 4.1, Table 5.1.

    Examples
    --------
    >>> import math
    >>> round(piston_position(math.pi, 5.6e-3, 86.0e-3) * 1e3, 3)     # BDC: the stroke 2 r of Table 5.1
    11.2
    """
    s = math.sin(theta)
    return crank * (1.0 - math.cos(theta)) + rod - math.sqrt(rod * rod - crank * crank * s * s)


def cylinder_volume(theta: float, omega: float, area: float, crank: float, rod: float,
                    v_tdc: float) -> tuple[float, float]:
    """Cylinder volume of the crank-slider pump and its rate at a crank angle, V = V_TDC + A_p x_p (eq 4.2).

    Parameters
    ----------
    theta : float
        Crank angle [rad].
    omega : float
        Crank speed [rad/s].
    area : float
        Piston area A_p [m^2].
    crank, rod : float
        r, l [m].
    v_tdc : float
        Dead volume at TDC [m^3].

    Returns
    -------
    tuple of float
        (V [m^3], dV/dt [m^3/s]).

    References
    ----------
    Knutson (2016), eqs 4.1-4.2, Table 5.1.

    Examples
    --------
    >>> import math
    >>> v, dv = cylinder_volume(math.pi, 62.1, math.pi * 15.88e-3**2 / 4, 5.6e-3, 86.0e-3, 2.17e-5)
    >>> round((v - 2.17e-5) * 1e6, 3), abs(dv) < 1e-15      # the swept volume at BDC, 2.22 cc (Table 5.1)
    (2.218, True)
    """
    s = math.sin(theta)
    c = math.cos(theta)
    root = math.sqrt(rod * rod - crank * crank * s * s)
    xp = crank * (1.0 - c) + rod - root
    vel = omega * (crank * s + crank * crank * s * c / root)
    return v_tdc + area * xp, area * vel
