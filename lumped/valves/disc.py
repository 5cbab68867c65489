"""Disc check valve of chapter 2: parameters, coefficients, forces (eq 2.4) and the kind entry.

:class:`DiscValve` declares every parameter once (file key, unit, source, plausible
range); the values of the thesis valve are in ``lumped/data/models/thesis-disc.toml``
and its dimensions in ``geometry/data/disc_valve.toml`` (``geometry = "thesis"``).
The dynamics functions read the flat parameter array (``lumped.solver.layout``) and floats
only, so ``numba.njit`` compiles them unchanged. SI units: x [m] opening (0 = seated,
> 0 open), u [m/s], dp = P_up - P_down [Pa], forces [N].

Pressure regime ``regime``: 0 Poiseuille, 1 orifice, -1 decide from x (eq 2.18). The
pump integrator fixes regime and contact state per step and switches them at located
crossings (``lumped.solver.switching``), so the right-hand side is smooth inside each step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from geometry.declare import param, read_table
from geometry.disc import load_disc_geometry
from geometry.errors import InputError
from lumped.valves.kind import (  # noqa: F401 - critical_damping: eq 2.23 as the thesis tables use it
    Common, ValveKind, ValveParams, check_discharge, contact_reaction, critical_damping, fluid_param, kind_block,
    register, spring_force, steady_flow_force,
)

EQ_2_23 = "critical damping 2 sqrt(k m) of eq 2.23 with the contact mass (derived when left out)"


# ----------------------------------------------------------------- coefficients (section 2.4)
def c1_coefficient(inner_radius: float, outer_radius: float) -> float:
    """Poiseuille pressure coefficient C1 of the disc: the mean pressure on the face over dP when the seat's
    annulus carries a laminar radial flow, C1 = (1 - q^2) / (2 ln(1/q)), q = R_i / R_o (eq 2.14).

    Parameters
    ----------
    inner_radius, outer_radius : float
        R_i, R_o [m] of the seat annulus.

    Returns
    -------
    float
        C1 [-].

    References
    ----------
    Knutson (2016), eqs 2.7-2.14.

    Examples
    --------
    >>> round(c1_coefficient(5.24e-3, 7.50e-3), 3)          # Table 2.3: 0.714
    0.714
    """
    q = inner_radius / outer_radius
    return (1.0 - q * q) / (2.0 * math.log(outer_radius / inner_radius))


def squeeze_area_moment(inner_radius: float, outer_radius: float) -> float:
    """The squeeze film's area moment G with C2 = 3 mu G / sin^4(theta) (eq 2.15 without the film's viscosity and
    bevel; the annulus integral of the squeeze pressure, eqs 2.11-2.12).

    Parameters
    ----------
    inner_radius, outer_radius : float
        R_i, R_o [m].

    Returns
    -------
    float
        G = (pi/2) R_i^4 (r^4 - 1)(1 - (r^2 - 1)/((r^2 + 1) ln r)) [m^4], r = R_o / R_i.

    References
    ----------
    Knutson (2016), eqs 2.11-2.15.
    """
    r = outer_radius / inner_radius
    lr = math.log(r)
    return 0.5 * math.pi * inner_radius**4 * (r**4 - 1.0) * (1.0 - (r * r - 1.0) / ((r * r + 1.0) * lr))


def c2_coefficient(inner_radius: float, outer_radius: float, bevel_angle: float, viscosity: float) -> float:
    """Stiction coefficient C2 of the squeeze film under the disc: the film force is C2 u / x^3 (eq 2.15, from
    the Reynolds equation 2.7-2.13 over the bevelled seat).

    Parameters
    ----------
    inner_radius, outer_radius : float
        R_i, R_o [m].
    bevel_angle : float
        theta [rad].
    viscosity : float
        mu [Pa s].

    Returns
    -------
    float
        C2 = 3 mu G / sin^4(theta) [N m^2 s] (:func:`squeeze_area_moment`).

    References
    ----------
    Knutson (2016), eqs 2.7-2.15.

    Examples
    --------
    Table 2.3's 7.630e-11 N m^2 s at 21 C (mu = 0.0705 Pa s by eq A.3; docs/errata.md):

    >>> import math
    >>> from lumped.fluid.oil import thesis_oil_viscosity
    >>> round(c2_coefficient(5.24e-3, 7.5e-3, math.radians(54.0), thesis_oil_viscosity(294.15)[1]) / 7.630e-11, 3)
    0.999
    """
    return 3.0 * viscosity / math.sin(bevel_angle) ** 4 * squeeze_area_moment(inner_radius, outer_radius)


def helical_spring_stiffness(wire_diameter: float, coil_diameter: float, shear_modulus: float,
                             active_coils: float) -> float:
    """Stiffness of a helical compression spring, k_spr = d^4 G / (8 D^3 N_a) (eq 2.43).

    Parameters
    ----------
    wire_diameter, coil_diameter : float
        d, D [m].
    shear_modulus : float
        G [Pa].
    active_coils : float
        N_a [-].

    Returns
    -------
    float
        k_spr [N/m].

    References
    ----------
    Knutson (2016), eq 2.43, Table 2.2.

    Examples
    --------
    >>> round(helical_spring_stiffness(0.61e-3, 9.9e-3, 80.0e9, 6.5))     # Table 2.3: 220 N/m
    220
    """
    return wire_diameter**4 * shear_modulus / (8.0 * coil_diameter**3 * active_coils)


# ----------------------------------------------------------------- parameters
@dataclass(frozen=True)
class DiscValve(ValveParams):
    """Disc check valve of chapter 2 (Tables 2.1-2.3); one per position (inlet, delivery)."""

    position: str
    geometry: str = param("geometry", "-", "disc geometry preset (thesis: geometry/data/disc_valve.toml) or "
                          "a TOML file of that schema; supplies the dimensions not given here")
    disc_mass: float = param("mass.disc", "kg", "m_disc (section 2.4.1)", bounds=(1e-7, 100.0), positive=True)
    spring_mass: float = param("mass.spring", "kg", "m_s, 1/3 of it moves with the disc (eq 2.3)",
                               bounds=(0.0, 100.0))
    contact_mass: float = param("mass.contact_reference", "kg", "mass in eq 2.23 for critical contact damping "
                                "(the thesis used Table 2.1's total 3.9 g, docs/errata.md)",
                                bounds=(1e-7, 100.0), positive=True)
    spring_stiffness: float = param("spring.stiffness", "N/m", "k_spr, measured (section 2.4.3.1)",
                                    bounds=(0.0, 1e9), packed=True)
    seat_stiffness: float = param("seat.stiffness", "N/m", "k_seat, seat FEA (section 2.4.3.2)",
                                  bounds=(1.0, 1e14), positive=True)
    stop_stiffness: float = param("stop.stiffness", "N/m", "k_stop, housing stop FEA (section 2.4.3.2)",
                                  bounds=(1.0, 1e14), positive=True)
    poiseuille_regime: bool = param("flow.poiseuille_regime", "-", "the C1 branch of eq 2.18 (off: F_p = dP A_disc)")
    transition: float = param("flow.transition", "-", "epsilon_0, Poiseuille-orifice transition of eq 2.18",
                              bounds=(1e-6, 10.0), positive=True)
    f1: float = param("flow.f1", "-", "fluid displacement parameter, closing (eq 2.42)", bounds=(0.0, 1.0))
    f2: float = param("flow.f2", "-", "fluid displacement parameter, opening (eq 2.42)", bounds=(0.0, 1.0))
    perimeter_factor: float = param("flow.perimeter_factor", "-", "orifice perimeter / (pi d_port) (section 2.4.5)",
                                    bounds=(0.01, 100.0), positive=True)
    orifice_density: str = param("flow.orifice_density", "-", "density in the orifice equation (section 4.3.5)",
                                 choices=("average", "cylinder"))
    cd_inf: float = param("discharge.cd_inf", "-", "Cd(Re) of eq 2.47, fit of eq 2.48", bounds=(1e-3, 2.0),
                          positive=True, typical=(0.05, 1.0))
    cd_a: float = param("discharge.a", "-", "eq 2.48", bounds=(-100.0, 100.0))
    cd_b: float = param("discharge.b", "-", "eq 2.48", bounds=(0.0, 100.0), positive=True)
    cd_c: float = param("discharge.c", "-", "eq 2.48", bounds=(0.0, 100.0), positive=True)
    cd_lift_exponent: float = param("discharge.lift_exponent", "-", "k: Cd(Re) of eq 2.47 taken at the effective "
                                    "Reynolds number Re (x / x_stop)^k (0: eq 2.48, Cd independent of the lift; "
                                    "fluid = \"predicted\" fits it, docs/fluid.md)", bounds=(-3.0, 3.0))
    force_coefficient: float = param("flow.force_coefficient", "-", "K_o: the pressure force of eq 2.18's orifice "
                                     "regime is K_o dP A_disc (eq 2.18: 1; fluid = \"predicted\": the axisymmetric "
                                     "flow's, docs/fluid.md)", bounds=(0.05, 2.0), positive=True, packed=True)
    drag: bool = param("drag.enabled", "-", "drag of eq 2.28 on the moving disc")
    viscous_drag: float = param("drag.viscous_coefficient", "-", "c_visc of eq 2.28 (section 2.4.4)",
                                bounds=(0.0, 1e3))
    inertial_drag: float = param("drag.inertial_coefficient", "-", "C_D,inf of eq 2.28 (section 2.4.4)",
                                 bounds=(0.0, 1e3))
    squeeze_min_gap: float = param("squeeze.min_gap", "m", "residual film at seat contact: the squeeze film of "
                                   "eqs 2.7-2.13 is x + min_gap thick (opening-equivalent; the ground seat's "
                                   "roughness, Ra ~ 1 um: valvelab's assumption, used with squeeze_film, docs/stiction.md)",
                                   bounds=(1e-9, 1e-3), positive=True, packed=True)
    squeeze_tensile_strength: float = param("squeeze.tensile_strength", "Pa", "tension the oil film holds below the "
                                            "vapour pressure before it cavitates (Roemer et al. 2015; 0: the "
                                            "thesis's eq 2.16, the film cavitates at the vapour pressure; used "
                                            "with squeeze_film, docs/stiction.md)", bounds=(0.0, 1e8), packed=True)
    # may be left out: dimensions then come from the geometry, dampings are critical (eq 2.23)
    inner_radius: float = param("seat.inner_radius", "m", "R_i, where seat contact starts (section 2.4.2)",
                                bounds=(1e-5, 1.0), positive=True, optional=True)
    outer_radius: float = param("seat.outer_radius", "m", "R_o = d_disc / 2 (Table 2.3)", bounds=(1e-5, 1.0),
                                positive=True, optional=True)
    bevel_angle: float = param("seat.bevel_angle", "rad", "theta, seat bevel (Table 2.3: 54 deg)",
                               bounds=(0.01, math.pi / 2), optional=True)
    port_diameter: float = param("port.diameter", "m", "d_port (Table 2.3)", bounds=(1e-5, 1.0), positive=True,
                                 optional=True)
    port_length: float = param("port.length", "m", "L, control-volume length of eq 2.31 (Table 2.3)",
                               bounds=(0.0, 1.0), optional=True, packed=True)
    stop_gap: float = param("stop.gap", "m", "x_stop, maximum opening set by the housing (Table 2.3)",
                            bounds=(1e-7, 0.1), positive=True, optional=True,
                            typical=(1e-5, 0.01))
    spring_preload: float = param("spring.preload", "m", "x_pre, spring compression when seated (Table 2.3)",
                                  bounds=(-0.1, 1.0), optional=True, packed=True)
    seat_damping: float = param("seat.damping", "N s/m", "c_seat; " + EQ_2_23, bounds=(0.0, 1e9), optional=True)
    stop_damping: float = param("stop.damping", "N s/m", "c_stop; " + EQ_2_23, bounds=(0.0, 1e9), optional=True)
    jet_angle: float = param("flow.jet_angle", "rad", "theta_jet, angle of the jet leaving the orifice to the "
                             "disc axis (eqs 2.30, 2.36; left out: the bevel angle, the thesis's assumption); "
                             "fitted by the flow_force effect", bounds=(0.0, math.pi / 2), optional=True)
    transient_length: float = param("flow.transient_length", "m", "length of the accelerated oil column of the "
                                    "transient flow force (eq 2.37 with L_t + x; left out: the port length L, eq "
                                    "2.31); fitted by the flow_force effect", bounds=(0.0, 1.0), optional=True)
    # set by candidate effects (lumped/model/effect_library.py); zero = the effect is off
    squeeze_c2: float = param(None, "N m^2 s", "C2 of eq 2.15", bounds=(0.0, 1.0), default=0.0,
                              effect="squeeze_film", packed=True)
    added_mass: float = param(None, "kg", "m_f of eq 2.3", bounds=(0.0, 100.0), default=0.0, effect="added_mass")
    flow_force_steady: float = param(None, "-", "multiplier of the steady flow force, eq 2.36", bounds=(0.0, 10.0),
                                     default=0.0, effect="flow_force", packed=True)
    flow_force_transient: float = param(None, "-", "multiplier of the transient flow force, eq 2.37",
                                        bounds=(0.0, 10.0), default=0.0, effect="flow_force", packed=True)
    fluid: str = fluid_param()

    #: keys a geometry supplies (dropped from inherited defaults when a file names another geometry)
    FROM_GEOMETRY = ("seat.inner_radius", "seat.outer_radius", "seat.bevel_angle", "port.diameter", "port.length",
                     "stop.gap", "spring.preload")
    #: the disc's own derived packed quantities (:meth:`packed_extra`)
    DERIVED = ("c1", "poiseuille", "port_area", "disc_area", "cos_jet", "viscous_drag", "inertial_drag",
               "disc_diameter", "transient_arm", "film_coefficient", "film_inner_radius", "film_outer_radius")

    # ---- construction
    @classmethod
    def load(cls, table: dict, where: str, position: str) -> "DiscValve":
        """A disc valve from its complete model-file table ``valves.<position>`` (lumped.model.model_file)."""
        values = read_table(cls, table, where, extra_keys=("kind",), require=True)
        return cls(position=position, **values).with_geometry(where).checked(where)

    def with_geometry(self, where: str = "") -> "DiscValve":
        """Dimensions not given take the values of the ``geometry`` preset or file."""
        missing = [n for n in ("inner_radius", "outer_radius", "bevel_angle", "port_diameter", "port_length",
                               "stop_gap", "spring_preload") if getattr(self, n) is None]
        if not missing:
            return self
        g = load_disc_geometry(self.geometry, field=f"{where}.geometry" if where else "geometry")
        fill = {"inner_radius": g.inner_radius, "outer_radius": g.outer_radius, "bevel_angle": g.bevel_angle,
                "port_diameter": g.port_diameter, "port_length": g.port_length,
                "stop_gap": g.stop_inlet if self.position == "inlet" else g.stop_delivery,
                "spring_preload": g.spring_preload}
        return replace(self, **{n: fill[n] for n in missing})

    def checked(self, where: str) -> "DiscValve":
        """Consistency of the dimensions and of the Cd(Re) correlation (each value was range-checked on reading)."""
        check_discharge(self.cd_inf, self.cd_a, self.cd_b, self.cd_c, where)
        if not self.inner_radius < self.outer_radius:
            raise InputError(f"{where}.seat.inner_radius", f"must be smaller than seat.outer_radius "
                             f"({self.outer_radius:g} m), got {self.inner_radius:g} m")
        if not self.port_diameter / 2 <= self.inner_radius * (1 + 1e-9):
            raise InputError(f"{where}.port.diameter", f"the port must lie inside the seat contact: diameter "
                             f"{self.port_diameter:g} m > 2 seat.inner_radius = {2 * self.inner_radius:g} m")
        return self

    # ---- derived quantities
    @property
    def disc_area(self) -> float:
        """A_disc = pi R_o^2 [m^2]."""
        return math.pi * self.outer_radius**2

    @property
    def port_area(self) -> float:
        """A_port = pi d_port^2 / 4 [m^2] (= A_1 of eq 2.42)."""
        return math.pi * self.port_diameter**2 / 4

    @property
    def c1(self) -> float:
        """Poiseuille pressure coefficient C1 (eq 2.14)."""
        return c1_coefficient(self.inner_radius, self.outer_radius)

    def c2(self, viscosity: float) -> float:
        """Stiction coefficient C2 [N m^2 s] (eq 2.15) for the oil viscosity [Pa s]."""
        return c2_coefficient(self.inner_radius, self.outer_radius, self.bevel_angle, viscosity)

    @property
    def transition_opening(self) -> float:
        """x at the Poiseuille-orifice transition of eq 2.18 [m]: eps0 (R_o - R_i) / sin^2(theta)."""
        return self.transition * (self.outer_radius - self.inner_radius) / math.sin(self.bevel_angle) ** 2

    @property
    def moving_mass(self) -> float:
        """m_disc + m_s/3 + m_f [kg] (eq 2.3)."""
        return self.disc_mass + self.spring_mass / 3 + self.added_mass

    def damping_reference(self) -> tuple[float, float]:
        """(m_contact, 1): a contact left without its damping is critical for ``mass.contact_reference``
        (eq 2.23; the thesis used Table 2.1's 3.9 g, docs/errata.md), not the moving mass."""
        return self.contact_mass, 1.0

    def natural_frequency(self) -> float:
        """Undamped natural frequency of disc on spring sqrt(k_spr / m) [rad/s] (eq 2.3 without fluid)."""
        return math.sqrt(self.spring_stiffness / self.moving_mass)

    def common(self, oil=None) -> Common:
        """The quantities every kind shares (lumped.valves.kind.Common): eqs 2.3, 2.20, 2.40-2.42, 2.47, 2.18."""
        return Common(
            moving_mass=self.moving_mass, stop_gap=self.stop_gap, seat_k=self.seat_stiffness,
            seat_c=self.seat_damping_value, stop_k=self.stop_stiffness, stop_c=self.stop_damping_value,
            area_1=self.port_area, area_2=self.disc_area, f_closing=self.f1, f_opening=self.f2,
            cd_inf=self.cd_inf, cd_a=self.cd_a, cd_b=self.cd_b, cd_c=self.cd_c, cd_lift_exponent=self.cd_lift_exponent,
            perimeter=self.perimeter_factor * math.pi * self.port_diameter,
            average_density=self.orifice_density == "average",
            area_per_opening=math.pi * self.port_diameter * math.sin(self.bevel_angle),   # eq 2.40: A_o / x
            regime_opening=self.transition_opening if self.poiseuille_regime else None,
            contact_area=self.disc_area,
            flow_in_acceleration=self.flow_force_steady > 0 or self.flow_force_transient > 0)

    def packed_extra(self, oil=None) -> dict:
        """The disc's own derived packed quantities (DERIVED)."""
        return {
            "c1": self.c1, "poiseuille": 1.0 if self.poiseuille_regime else 0.0, "port_area": self.port_area,
            "disc_area": self.disc_area, "cos_jet": math.cos(self.jet_angle_value),
            "viscous_drag": self.viscous_drag if self.drag else 0.0,
            "inertial_drag": self.inertial_drag if self.drag else 0.0, "disc_diameter": 2.0 * self.outer_radius,
            "transient_arm": self.transient_length_value,
            "film_coefficient": self.squeeze_c2 / squeeze_area_moment(self.inner_radius, self.outer_radius),
            "film_inner_radius": self.inner_radius, "film_outer_radius": self.outer_radius,
        }

    def geometry_supplied(self) -> set:
        """Keys whose value equals what the disc geometry preset or file supplies (``model show``)."""
        try:
            g = load_disc_geometry(self.geometry)
        except InputError:
            return set()
        fill = {"seat.inner_radius": g.inner_radius, "seat.outer_radius": g.outer_radius,
                "seat.bevel_angle": g.bevel_angle, "port.diameter": g.port_diameter, "port.length": g.port_length,
                "stop.gap": g.stop_inlet if self.position == "inlet" else g.stop_delivery,
                "spring.preload": g.spring_preload}
        from geometry.declare import specs

        return {s.key for n, s in specs(self) if s.key in fill and getattr(self, n) == fill[s.key]}

    @property
    def jet_angle_value(self) -> float:
        """theta_jet [rad] of eqs 2.30, 2.36: as given, else the bevel angle (the thesis's assumption)."""
        return self.bevel_angle if self.jet_angle is None else self.jet_angle

    @property
    def transient_length_value(self) -> float:
        """L_t [m] of the transient flow force (eq 2.37 with L_t + x): as given, else the port length L (eq 2.31)."""
        return self.port_length if self.transient_length is None else self.transient_length

    def validity(self, oil=None):
        """The disc's validity envelope (lumped.validity.Envelope): it rests at x = -x_pre (eq 2.19), lifts off
        at k_spr x_pre / (C1 A_disc) (eqs 2.13, 2.19; orifice form without the Poiseuille regime), and its
        orifice is the curtain of eq 2.40 only while that is smaller than the port: up to x = d_port / (4 sin theta)."""
        from lumped.validity import Limit

        env = super().validity(oil)
        area = self.disc_area * (self.c1 if self.poiseuille_regime else self.force_coefficient)
        x_port = self.port_diameter / (4.0 * math.sin(self.bevel_angle))
        port = Limit("port_area", "peak_opening", x_port, f"the {x_port * 1e3:.3g} mm where its curtain area "
                     "(eq 2.40) reaches the port area: the port, not the gap, throttles there")
        return replace(env, rest_opening=-self.spring_preload, rest_key="spring.preload",
                       cracking_pressure=max(0.0, self.spring_stiffness * self.spring_preload / area),
                       limits=env.limits + (port,))


#: offsets of the disc's packed quantities (common, packed fields, then its derived ones)
DISC = kind_block(DiscValve)


# ----------------------------------------------------------------- squeeze film with cavitation
#: below this argument the film functions are summed as series (their closed forms cancel)
_SERIES = 0.05


def _film_zone(t: float, side: float) -> tuple[float, float, float]:
    """A liquid zone of a cavitating film (dimensionless, exact), inner (side +1) or outer (side -1).

    Inner zone R_i..r_1 = R_i e^t: g = 1 - e^(2t) (1 - 2t) = (P_up - P_lim) / (K R_i^2) and
    J = e^(4t) - 1 - 4t e^(2t), its pressure integral over (pi K R_i^4 / 2) (Reynolds eq 2.8,
    dP/dr = 0 at r_1). Outer zone r_2 = R_o e^-t..R_o: the same functions mirrored, g(-t) =
    (P_down - P_lim) / (K R_o^2) and -J(-t) over (pi K R_o^4 / 2). Returns (g, dg/dt, J).
    """
    u = side * t
    if abs(u) < _SERIES:
        g = 0.0
        j = 0.0
        a2 = 1.0       # (2u)^n / n!
        a4 = 1.0       # (4u)^n / n!
        for n in range(1, 16):
            a2 *= 2.0 * u / n
            a4 *= 4.0 * u / n
            g += (n - 1) * a2
            j += a4 - 2.0 * n * a2          # (4^n - n 2^(n+1)) u^n / n!
        return g, 4.0 * t * math.exp(2.0 * u), side * j
    e2 = math.exp(2.0 * u)
    return 1.0 - e2 * (1.0 - 2.0 * u), 4.0 * t * e2, side * (e2 * e2 - 1.0 - 4.0 * u * e2)


def _film_root(c: float, top: float, side: float) -> float:
    """The argument in [0, top] where the zone function g of :func:`_film_zone` equals c (g increases
    from 0): safeguarded Newton, to round-off (the Jacobian differences it)."""
    if c <= 0.0:
        return 0.0
    g_top = _film_zone(top, side)[0]
    if c >= g_top:
        return top
    lo = 0.0
    hi = top
    t = math.sqrt(0.5 * c)            # g = 2 t^2 + O(t^3)
    if not lo < t < hi:
        t = 0.5 * (lo + hi)
    for _ in range(200):
        g, dg, _j = _film_zone(t, side)
        f = g - c
        if f > 0.0:
            hi = t
        else:
            lo = t
        new = t - f / dg if dg > 0.0 else 0.5 * (lo + hi)
        if not lo < new < hi:
            new = 0.5 * (lo + hi)
        if abs(new - t) <= 4e-16 * (t + 1e-300) or hi - lo <= 4e-16 * hi:
            return new
        t = new
    return t


def film_force(p_up: float, p_down: float, p_lim: float, k: float, r_i: float, r_o: float) -> float:
    """Axial force of the fluid on the disc face over r <= R_o (Poiseuille regime) with a squeeze film whose
    pressure cannot fall below p_lim: P_up inside R_i (eq 2.6), the Reynolds film of eq 2.8 on R_i..R_o, minus
    P_down on the back face (eq 2.12).

    Parameters
    ----------
    p_up, p_down : float
        Pressures upstream and behind the disc [Pa].
    p_lim : float
        The film's lowest pressure [Pa] (the vapour pressure minus the oil's tensile strength).
    k : float
        3 mu u / (x^3 sin^4 theta) [Pa/m^2], the squeeze term of eq 2.11 in the projected radius r (> 0 opening).
    r_i, r_o : float
        R_i, R_o [m].

    Returns
    -------
    float
        The force [N], positive opening.

    References
    ----------
    Knutson (2016), eqs 2.6-2.17; Scheidl & Gradl (2016) for separating plates.

    Notes
    -----
    Where the full film of eq 2.11 would fall below p_lim the film cavitates: a zone
    r_1..r_2 at p_lim bounded by liquid zones in which eq 2.8 holds with the Reynolds (Swift-Stieber)
    condition P = p_lim, dP/dr = 0 at the cavity edges, which conserves mass while the cavity grows
    (the edge moves with the liquid; Jakobsson-Floberg-Olsson theory), as in the approximate
    method of Scheidl & Gradl (2016) for separating plates. Closed form but for the edges (1-D
    roots). Fully cavitated it is eq 2.16 (with A_port = pi R_i^2); without cavity eqs 2.13-2.15.
    """
    a = p_up - p_lim
    b = p_down - p_lim
    if a < 0.0:
        a = 0.0
    if b < 0.0:
        b = 0.0
    lnr = math.log(r_o / r_i)
    ri2 = r_i * r_i
    ro2 = r_o * r_o
    # eq 2.13 with C1 of eq 2.14 and C2 u / x^3 = k G (eq 2.15)
    full = math.pi * ro2 * c1_coefficient(r_i, r_o) * (p_up - p_down) - k * squeeze_area_moment(r_i, r_o)
    if k <= 0.0:
        return full
    t1 = 0.0 if a <= 0.0 else _film_root(a / (k * ri2), lnr, 1.0)
    s2 = 0.0 if b <= 0.0 else _film_root(b / (k * ro2), lnr, -1.0)
    if t1 + s2 >= lnr:
        return full                 # the full film stays above p_lim: no cavity
    j1 = _film_zone(t1, 1.0)[2]
    j2 = _film_zone(s2, -1.0)[2]
    return math.pi * (ri2 * a - ro2 * b) + 0.5 * math.pi * k * (ri2 * ri2 * j1 + ro2 * ro2 * j2)


# ----------------------------------------------------------------- forces
def pressure_force(x: float, u: float, dp: float, p_down: float, p_vap: float, p, o: int,
                   regime: int, contact: int = -1) -> float:
    """Pressure force F_p on the disc with the Poiseuille/orifice switch of eq 2.18.

    Parameters
    ----------
    x, u : float
        Opening [m], rate [m/s].
    dp : float
        P_up - P_down [Pa].
    p_down, p_vap : float
        Pressure behind the disc and the vapour pressure [Pa].
    p : array of float
        The flat parameter array; ``o`` the disc's block offset.
    regime : int
        0 Poiseuille, 1 orifice, -1 from x.
    contact : int
        Contact state (-1: from x).

    Returns
    -------
    float
        F_p [N], positive opening.

    References
    ----------
    Knutson (2016), eqs 2.13-2.18.

    Notes
    -----
    Poiseuille regime: C1 dP A_disc (eq 2.13); with the squeeze_film effect the Reynolds film of
    eqs 2.7-2.13 over the bevelled annulus, x + min_gap thick, its pressure bounded below at the
    vapour pressure minus the oil's tensile strength (eq 2.17 applied to the film pressure, not
    only the total: :func:`film_force`). Orifice regime: K_o dP A_disc (eq 2.18: K_o = 1; the
    ``flow.force_coefficient``). With the regime switch off the orifice form always applies. The film squeezes off the seat only (``contact`` free or stop; -1:
    decided from x > 0): on the seat the disc moves with the seat's compliance, the film stays
    min_gap thick, and a free disc inside the switch's hysteresis (x just below 0) keeps its film,
    so the force has no jump inside a mode.
    """
    a_disc = p[o + DISC.disc_area]
    if p[o + DISC.poiseuille] < 0.5:
        return p[o + DISC.force_coefficient] * dp * a_disc
    if regime < 0:
        regime = 0 if x < p[o + DISC.regime_opening] else 1
    if regime == 1:
        return p[o + DISC.force_coefficient] * dp * a_disc
    kf = p[o + DISC.film_coefficient]
    h = x + p[o + DISC.squeeze_min_gap]
    if kf > 0.0 and h > 0.0 and (contact > 0 or (contact < 0 and x > 0.0)):
        return film_force(p_down + dp, p_down, p_vap - p[o + DISC.squeeze_tensile_strength], kf * u / (h * h * h),
                          p[o + DISC.film_inner_radius], p[o + DISC.film_outer_radius])
    return p[o + DISC.c1] * dp * a_disc


def disc_acceleration(x: float, u: float, f, p, o: int, contact: int, regime: int) -> float:
    """Acceleration of the disc, F / (m_disc + m_s/3 + m_f) with F of eq 2.4 (eqs 2.1-2.4).

    Parameters
    ----------
    x, u : float
        Opening [m] and its rate [m/s].
    f : lumped.valves.common.ValveInputs
        What the pump gives the valve (pressures, density, viscosity, the orifice flow and its partials).
    p : array of float
        The flat parameter array; ``o`` the disc's block offset (:data:`DISC`).
    contact, regime : int
        The valve's mode (contact state; pressure regime of eq 2.18).

    Returns
    -------
    float
        du/dt [m/s^2].

    References
    ----------
    Knutson (2016), eqs 2.1-2.4, 2.18-2.20, 2.28, 2.30, 2.36, 2.37.

    Notes
    -----
    Forces: pressure (eq 2.18), spring with preload (eq 2.19), seat/stop contact
    (eq 2.20), drag opposing the motion (eq 2.28), and with the flow_force effect the
    steady (eq 2.36, the jet leaving at theta_jet, eq 2.30) and transient (eq 2.37, an oil column
    L_t + x long) flow forces, each times its multiplier. The transient force holds
    rho (L_t + x) dQ/dt with dQ/dt = dQ/d(dp) d(dp)/dt + dQ/dx u + A_Q du/dt; its du/dt part is
    moved to the left side as an added inertia rho (L_t + x) A_Q.
    """
    dp, rho = f.dp, f.rho
    m = p[o + DISC.moving_mass]
    force = pressure_force(x, u, dp, f.p_down, f.p_vap, p, o, regime, contact)
    force -= spring_force(x, p[o + DISC.spring_stiffness], p[o + DISC.spring_preload])
    force += contact_reaction(x, u, p, o, contact)
    # drag (eq 2.28) opposes the motion
    force -= p[o + DISC.viscous_drag] * f.mu * u * p[o + DISC.disc_diameter] \
        + 0.5 * rho * abs(u) * u * p[o + DISC.inertial_drag] * p[o + DISC.disc_area]
    ks = p[o + DISC.flow_force_steady]
    kt = p[o + DISC.flow_force_transient]
    if ks > 0.0 or kt > 0.0:
        force += ks * steady_flow_force(x, u, f, p, o, contact, p[o + DISC.port_area], p[o + DISC.cos_jet])
        q = f.q_o + f.aq * u
        arm = p[o + DISC.transient_arm] + x
        force -= kt * rho * (q * u + arm * (f.dq_ddp * f.ddp_dt + f.dq_dx * u))
        m += kt * rho * arm * f.aq
    return force / m


KIND = register(ValveKind(
    name="disc", default_model="thesis-disc", params=DiscValve, acceleration=disc_acceleration, block=DISC,
    # the fast path's tolerances (lumped.solver.steppers.tolerance_table; measured in docs/models.md, "The fast
    # path's tolerances"): on its seat or stop the disc's lift-off is decided by the net force
    # (lumped.solver.switching), not by its opening or velocity there, which may be loose; in free flight its
    # velocity carries its timing and delivery, most at high speed and load
    contact_velocity_atol=100.0,
    contact_position_atol=1000.0,
    free_velocity_atol=30.0,
    # designs the fast path is checked on (lumped.model.random_designs): the O-ring compliance of
    # the delivery seat (section 2.4.3.2), its displacement factors and the inlet spring
    design_ranges={"effects.seat_compliance.delivery.k_seat": (10**5.5, 1e7), "delivery.flow.f1": (0.6, 1.0),
                   "delivery.flow.f2": (0.6, 1.0), "inlet.spring.stiffness": (150.0, 300.0)},
    summary="spring-loaded disc on a bevelled seat (thesis chapter 2)",
))
