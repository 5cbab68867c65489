"""Ball check valve: a sphere on a conical seat, held by a spring; parameters, forces and the kind entry.

The most common check valve of piston pumps. A ball of diameter d_b sits in a conical seat
(countersink) of half-angle alpha drilled over a port of diameter d_port, pressed by a
helical spring; a housing stop limits its lift x. SI units: x [m] lift (0 = seated),
u [m/s], dp = P_up - P_down [Pa], forces [N].

Geometry (valvelab's derivation, after the conical poppet of Merritt 1967, *Hydraulic
Control Systems*, section 3.5): the ball touches the cone on the circle of diameter
d_c = d_b cos(alpha); lifted by x it stands off the cone by h = x sin(alpha), and the gap's
mid-circle has the diameter d_c + x sin(alpha) cos(alpha), so the flow (curtain) area is

    A_o(x) = pi x sin(alpha) (d_c + x sin(alpha) cos(alpha))                       (ball 1)

Forces on the ball, as for the thesis's disc (eq 2.4) with the ball's areas:

- pressure: dp pi d_c^2 / 4 over the seat circle (the orifice regime of eq 2.18; the seat line
  contact leaves no Poiseuille film);
- spring with preload, eq 2.19; seat and stop contact, eq 2.20, critically damped by eq 2.23
  when the damping is left out;
- drag opposing the motion, eq 2.28 with a sphere's coefficients: Stokes 3 pi mu d_b u and
  C_D rho pi d_b^2 / 8 |u| u (C_D ~ 0.47 for a sphere at Re 1e3-1e5, e.g. White, *Fluid
  Mechanics*, 7th ed., Figure 7.16);
- the steady flow force of the control volume of eq 2.36 (Merritt 1967, eq 3-63 for poppets):
  rho Q^2 / A_port - 2 Cd^2 A_o |dp| cos(theta_jet), the jet leaving along the cone
  (theta_jet = alpha unless given).

The flow (orifice equation with Cd(Re) of eq 2.47, displacement area of eq 2.42) is shared with
every kind (:func:`lumped.valves.forces.valve_flow`). Values of the shipped ball valve:
``lumped/data/models/thesis-ball.toml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from geometry.declare import param, read_table
from geometry.errors import InputError
from lumped.valves.kind import (
    Common, ValveKind, ValveParams, check_discharge, contact_reaction, kind_block, register, spring_force,
    steady_flow_force,
)

CRITICAL = "critical damping 2 sqrt(k m) of eq 2.23 with the moving mass (derived when left out)"


def contact_diameter(ball_diameter: float, half_angle: float) -> float:
    """Diameter of the circle where a ball touches a cone of half-angle alpha, d_c = d_b cos(alpha) (ball 1).

    Parameters
    ----------
    ball_diameter : float
        d_b [m].
    half_angle : float
        alpha [rad].

    Returns
    -------
    float
        d_c [m].

    Examples
    --------
    A 1/2 in ball in a 90 deg countersink (thesis-ball.toml):

    >>> import math
    >>> round(contact_diameter(12.7e-3, math.pi / 4) * 1e3, 3)
    8.98
    """
    return ball_diameter * math.cos(half_angle)


def curtain_area(x: float, ball_diameter: float, half_angle: float) -> float:
    """Flow (curtain) area between a ball lifted by x and its conical seat,
    A_o = pi x sin(alpha) (d_c + x sin(alpha) cos(alpha)) (ball 1, after Merritt 1967, section 3.5).

    Parameters
    ----------
    x : float
        Lift [m].
    ball_diameter : float
        d_b [m].
    half_angle : float
        alpha [rad].

    Returns
    -------
    float
        A_o [m^2].

    Examples
    --------
    Small lifts: the gap h = x sin(alpha) around the circle pi d_c:

    >>> import math
    >>> a = curtain_area(1e-6, 12.7e-3, math.pi / 4)
    >>> round(a / (math.pi * contact_diameter(12.7e-3, math.pi / 4) * 1e-6 * math.sin(math.pi / 4)), 3)
    1.0
    """
    s = math.sin(half_angle)
    return math.pi * x * s * (contact_diameter(ball_diameter, half_angle) + x * s * math.cos(half_angle))


@dataclass(frozen=True)
class BallValve(ValveParams):
    """Ball check valve on a conical seat (lumped/data/models/thesis-ball.toml); one per position."""

    position: str
    ball_diameter: float = param("ball.diameter", "m", "d_b", bounds=(1e-4, 0.2), positive=True)
    ball_density: float = param("ball.density", "kg/m^3", "rho_b of the ball material", bounds=(500.0, 25000.0),
                                positive=True)
    spring_mass: float = param("mass.spring", "kg", "m_s, 1/3 of it moves with the ball (eq 2.3)", bounds=(0.0, 10.0))
    spring_stiffness: float = param("spring.stiffness", "N/m", "k_spr (eq 2.19)", bounds=(0.0, 1e9), packed=True)
    spring_preload: float = param("spring.preload", "m", "x_pre, spring compression when seated (eq 2.19)",
                                  bounds=(-0.1, 1.0), packed=True)
    half_angle: float = param("seat.half_angle", "rad", "alpha, half-angle of the conical seat (a 90 deg "
                              "countersink: pi/4)", bounds=(0.05, 1.5), positive=True)
    port_diameter: float = param("port.diameter", "m", "d_port under the seat", bounds=(1e-5, 0.2), positive=True)
    seat_stiffness: float = param("seat.stiffness", "N/m", "k_seat of the ring contact (eq 2.20)", bounds=(1.0, 1e14),
                                  positive=True)
    stop_gap: float = param("stop.gap", "m", "x_stop, largest lift the housing allows", bounds=(1e-7, 0.1),
                            positive=True, typical=(1e-5, 0.01))
    stop_stiffness: float = param("stop.stiffness", "N/m", "k_stop of the housing stop (eq 2.20)",
                                  bounds=(1.0, 1e14), positive=True)
    f1: float = param("flow.f1", "-", "fluid displacement parameter, closing (eq 2.42)", bounds=(0.0, 1.0))
    f2: float = param("flow.f2", "-", "fluid displacement parameter, opening (eq 2.42)", bounds=(0.0, 1.0))
    perimeter_factor: float = param("flow.perimeter_factor", "-", "wetted perimeter of the gap / (pi d_c): 2 "
                                    "for its two walls (eq 2.46)", bounds=(0.01, 100.0), positive=True)
    orifice_density: str = param("flow.orifice_density", "-", "density in the orifice equation (section 4.3.5)",
                                 choices=("average", "cylinder"))
    flow_force: bool = param("flow.flow_force", "-", "the steady flow force of eq 2.36 on the ball (Merritt 1967)")
    cd_inf: float = param("discharge.cd_inf", "-", "Cd(Re) of eq 2.47", bounds=(1e-3, 2.0), positive=True,
                          typical=(0.05, 1.0))
    cd_a: float = param("discharge.a", "-", "eq 2.47", bounds=(-100.0, 100.0))
    cd_b: float = param("discharge.b", "-", "eq 2.47", bounds=(0.0, 100.0), positive=True)
    cd_c: float = param("discharge.c", "-", "eq 2.47", bounds=(0.0, 100.0), positive=True)
    drag: bool = param("drag.enabled", "-", "drag of eq 2.28 on the moving ball")
    viscous_drag: float = param("drag.viscous_coefficient", "-", "c_visc of eq 2.28 (Stokes sphere: 3 pi)",
                                bounds=(0.0, 1e3))
    inertial_drag: float = param("drag.inertial_coefficient", "-", "C_D of a sphere (eq 2.28 with the ball's "
                                 "projected area)", bounds=(0.0, 1e3))
    seat_damping: float = param("seat.damping", "N s/m", "c_seat; " + CRITICAL, bounds=(0.0, 1e9), optional=True)
    stop_damping: float = param("stop.damping", "N s/m", "c_stop; " + CRITICAL, bounds=(0.0, 1e9), optional=True)
    jet_angle: float = param("flow.jet_angle", "rad", "theta_jet of eq 2.36 (left out: the seat half-angle, the "
                             "jet leaving along the cone)", bounds=(0.0, math.pi / 2), optional=True)
    # set by candidate effects (lumped/model/effect_library.py); zero = the effect is off
    added_mass: float = param(None, "kg", "m_f of eq 2.3", bounds=(0.0, 100.0), default=0.0, effect="added_mass")

    #: the ball's own derived packed quantities (:meth:`packed_extra`)
    DERIVED = ("seat_area", "port_area", "cos_jet", "flow_force_on", "viscous_term", "inertial_term")

    # ---- construction
    @classmethod
    def load(cls, table: dict, where: str, position: str) -> "BallValve":
        """A ball valve from its complete model-file table ``valves.<position>`` (lumped.model.model_file)."""
        values = read_table(cls, table, where, extra_keys=("kind",), require=True)
        return cls(position=position, **values).checked(where)

    def checked(self, where: str) -> "BallValve":
        """Consistency: the ball must close the port (d_c > d_port) and Cd(Re) must be valid."""
        check_discharge(self.cd_inf, self.cd_a, self.cd_b, self.cd_c, where)
        if not self.contact_diameter > self.port_diameter:
            raise InputError(f"{where}.port.diameter", f"the ball must close the port: its seat circle d_b cos(alpha) = "
                             f"{self.contact_diameter:g} m is not larger than the port {self.port_diameter:g} m")
        return self

    # ---- derived quantities
    @property
    def contact_diameter(self) -> float:
        """d_c = d_b cos(alpha) [m] (ball 1)."""
        return contact_diameter(self.ball_diameter, self.half_angle)

    @property
    def ball_mass(self) -> float:
        """rho_b pi d_b^3 / 6 [kg]."""
        return self.ball_density * math.pi * self.ball_diameter**3 / 6.0

    @property
    def moving_mass(self) -> float:
        """m_ball + m_s/3 + m_f [kg] (eq 2.3)."""
        return self.ball_mass + self.spring_mass / 3.0 + self.added_mass

    @property
    def seat_area(self) -> float:
        """pi d_c^2 / 4 [m^2]: where the pressure difference acts on the seated ball."""
        return math.pi * self.contact_diameter**2 / 4.0

    @property
    def port_area(self) -> float:
        """pi d_port^2 / 4 [m^2] (= A_1 of eq 2.42)."""
        return math.pi * self.port_diameter**2 / 4.0

    @property
    def projected_area(self) -> float:
        """pi d_b^2 / 4 [m^2] (= A_2 of eq 2.42, and the drag area)."""
        return math.pi * self.ball_diameter**2 / 4.0

    def natural_frequency(self) -> float:
        """Undamped natural frequency of the ball on its spring sqrt(k_spr / m) [rad/s]."""
        return math.sqrt(self.spring_stiffness / self.moving_mass)

    def common(self, oil=None) -> Common:
        """The quantities every kind shares (lumped.valves.kind.Common): eqs 2.3, 2.20, 2.42, 2.47 and ball 1."""
        s, c = math.sin(self.half_angle), math.cos(self.half_angle)
        return Common(
            moving_mass=self.moving_mass, stop_gap=self.stop_gap, seat_k=self.seat_stiffness,
            seat_c=self.seat_damping_value, stop_k=self.stop_stiffness, stop_c=self.stop_damping_value,
            area_1=self.port_area, area_2=self.projected_area, f_closing=self.f1, f_opening=self.f2,
            cd_inf=self.cd_inf, cd_a=self.cd_a, cd_b=self.cd_b, cd_c=self.cd_c,
            perimeter=self.perimeter_factor * math.pi * self.contact_diameter,
            average_density=self.orifice_density == "average",
            area_per_opening=math.pi * s * self.contact_diameter, area_curvature=math.pi * s * s * c,   # ball 1
            regime_opening=None, contact_area=self.seat_area, flow_in_acceleration=self.flow_force)

    def packed_extra(self, oil=None) -> dict:
        """The ball's own derived packed quantities (DERIVED)."""
        jet = self.half_angle if self.jet_angle is None else self.jet_angle
        return {"seat_area": self.seat_area, "port_area": self.port_area, "cos_jet": math.cos(jet),
                "flow_force_on": 1.0 if self.flow_force else 0.0,
                "viscous_term": self.viscous_drag * self.ball_diameter if self.drag else 0.0,
                "inertial_term": 0.5 * self.inertial_drag * self.projected_area if self.drag else 0.0}

    def describe(self) -> dict:
        """What ``valvelab model check`` reports of a ball valve: its masses and seat geometry."""
        return {"ball": {"mass_kg": self.ball_mass, "moving_mass_kg": self.moving_mass,
                         "contact_diameter_m": self.contact_diameter, "seat_area_m2": self.seat_area,
                         "cracking_pressure_pa": self.spring_stiffness * self.spring_preload / self.seat_area}}

    def validity(self, oil=None):
        """The ball's validity envelope (lumped.validity.Envelope): it rests at x = -x_pre (eq 2.19), lifts off
        at k_spr x_pre / (pi d_c^2 / 4), and its curtain area (ball 1) throttles only while smaller than the port:
        up to the lift where pi x sin(alpha) (d_c + x sin(alpha) cos(alpha)) = pi d_port^2 / 4."""
        from dataclasses import replace

        from lumped.validity import Limit

        env = super().validity(oil)
        s, c = math.sin(self.half_angle), math.cos(self.half_angle)
        d_c = self.contact_diameter
        x_port = (-s * d_c + math.sqrt((s * d_c) ** 2 + s * s * c * self.port_diameter**2)) / (2.0 * s * s * c)
        port = Limit("port_area", "peak_opening", x_port, f"the {x_port * 1e3:.3g} mm where its curtain area "
                     "(ball 1) reaches the port area: the port, not the gap, throttles there")
        return replace(env, rest_opening=-self.spring_preload, rest_key="spring.preload",
                       cracking_pressure=max(0.0, self.spring_stiffness * self.spring_preload / self.seat_area),
                       limits=env.limits + (port,))


#: offsets of the ball's packed quantities (common, packed fields, then its derived ones)
BALL = kind_block(BallValve)


def ball_acceleration(x: float, u: float, f, p, o: int, contact: int, regime: int) -> float:
    """Acceleration of the ball, F / (m_ball + m_s/3 + m_f), F the forces of the module docstring.

    Parameters
    ----------
    x, u : float
        Lift [m] and its rate [m/s].
    f : lumped.valves.common.ValveInputs
        What the pump gives the valve.
    p : array of float
        The flat parameter array; ``o`` the ball's block offset (:data:`BALL`).
    contact, regime : int
        The valve's mode.

    Returns
    -------
    float
        du/dt [m/s^2].

    References
    ----------
    Knutson (2016), eqs 2.3, 2.19, 2.20, 2.28, 2.36; Merritt (1967), section 3.5.

    Notes
    -----
    Pressure over the seat circle, spring with preload (eq 2.19), seat/stop contact (eq 2.20),
    drag opposing the motion (eq 2.28 with a sphere's coefficients) and the steady flow force
    (eq 2.36; Merritt 1967) with the jet along the cone.
    """
    dp, rho = f.dp, f.rho
    force = dp * p[o + BALL.seat_area]
    force -= spring_force(x, p[o + BALL.spring_stiffness], p[o + BALL.spring_preload])
    force += contact_reaction(x, u, p, o, contact)
    force -= p[o + BALL.viscous_term] * f.mu * u + p[o + BALL.inertial_term] * rho * abs(u) * u
    if p[o + BALL.flow_force_on] > 0.5:
        force += steady_flow_force(x, u, f, p, o, contact, p[o + BALL.port_area], p[o + BALL.cos_jet])
    return force / p[o + BALL.moving_mass]


KIND = register(ValveKind(
    name="ball", default_model="thesis-ball", params=BallValve, acceleration=ball_acceleration, block=BALL,
    # the fast path's tolerances (docs/models.md, "The fast path's tolerances"): a stiff steel seat and a
    # housing stop like the disc's, its lift-off decided by the net force; in free flight the ball floats on
    # the flow between seat and stop, and its velocity decides its timing. On its seat the velocity is the
    # reference's (1, not the disc's 100): pressed a tenth of a micrometre into a steel seat, the ball creeps out
    # of it at ~1e-5 m/s as the cylinder pressure decays, and a looser velocity let the creep lag and the inlet
    # open up to 14 deg late (6 of 320 random designs, benchmarks/fast_accuracy_study.py; +15-20 % steps)
    contact_velocity_atol=1.0,
    contact_position_atol=1000.0,
    free_velocity_atol=3.0,
    # designs the fast path is checked on (lumped.model.random_designs)
    design_ranges={"spring.stiffness": (150.0, 300.0), "ball.diameter": (12.3e-3, 14.0e-3),
                   "flow.f1": (0.6, 1.0), "flow.f2": (0.6, 1.0)},
    summary="spring-loaded ball on a conical seat (Merritt 1967; valvelab)",
))
