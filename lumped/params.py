"""Frozen parameter dataclasses of the pump model, their loaders, and the flat array the physics uses.

Every number comes from a cited data file (``lumped/data/*.toml``, ``geometry/data``);
SI units throughout. Each candidate effect is a switch on the dataclass, so a study turns
it on or off with :func:`dataclasses.replace` (or :func:`set_effect`):

=================  ===============================================  ==================
effect             where                                            thesis default
=================  ===============================================  ==================
seat_compliance    ``DiscValve``/``ReedValve``: compliant k, c      disc delivery only
squeeze_film       ``DiscValve``: stiction C2 u/x^3 (eqs 2.13-2.18)  off
flow_force         ``DiscValve``: eqs 2.36, 2.37                     off
added_mass         ``DiscValve`` (m_f, eq 2.3) / ``ReedValve`` (3.17) off
fluid_damping      ``ReedValve``: c_f (section 3.8.3)                on
piston_leakage     ``Pump``: laminar, eq 4.5                         off
entrained_air      ``Oil``: R of eq 4.11                             on (0.013 / 0.008)
=================  ===============================================  ==================

Other switches: ``DiscValve.poiseuille_regime`` (the C1 regime of eq 2.18, on),
``DiscValve.drag`` (eq 2.28, on), ``ReedValve.drag`` (the gamma2 term of eq 3.21, off).

:func:`thesis_model` gives the thesis configuration of a valve type in one call,
:func:`baseline_model` the CONTRACT's baseline (every candidate effect off), and
:func:`pack` turns a :class:`PumpModel` and an operating point into the flat float64
array read by the right-hand side (index constants below), so that ``numba.njit`` can
compile the same physics.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, fields, replace
from functools import cache
from importlib import resources

import numpy as np

from geometry.disc import disc_area, load_disc_geometry, port_area
from geometry.errors import InputError
from lumped import oil as oil_mod
from lumped.orifice import discharge_coefficient, laminar_slope

VALVES = ("disc", "reed")
POSITIONS = ("inlet", "delivery")
CIRCUITS = ("simplified", "complete")
EFFECTS = ("seat_compliance", "squeeze_film", "flow_force", "added_mass", "fluid_damping",
           "piston_leakage", "entrained_air")


@cache
def _data(name: str) -> dict:
    return tomllib.loads(resources.files("lumped").joinpath(f"data/{name}.toml").read_text())


# --------------------------------------------------------------------------- dataclasses
@dataclass(frozen=True)
class Oil:
    """Mobil DTE 25 with entrained air (Table 5.1, Appendix A, eq 4.11)."""

    density_atm: float            # rho_0 at P_0 [kg/m^3]
    bulk_modulus: float           # beta of air-free oil [Pa]
    polytropic_exponent: float    # gamma of eq 4.9 (1.4: adiabatic air; 1.0: isothermal)
    atmospheric_pressure: float   # P_0 [Pa]
    viscosity: float              # mu [Pa s] (eq A.3 at room temperature)
    vapour_pressure: float        # [Pa], film cavitation limit of eq 2.16
    entrained_air: bool = True    # effect switch: R of eq 4.11 (off = air-free oil)
    air_content: float = 0.0      # R, volume fraction of air at P_0

    @property
    def effective_air(self) -> float:
        """R used by eq 4.11: the air content if the entrained_air switch is on, else 0."""
        return self.air_content if self.entrained_air else 0.0

    def density(self, p: float) -> float:
        """Mixture density at absolute pressure p [kg/m^3] (eq 4.11)."""
        return oil_mod.density(p, self.density_atm, self.atmospheric_pressure, self.bulk_modulus,
                               self.polytropic_exponent, self.effective_air)

    def pressure(self, rho: float) -> float:
        """Absolute pressure [Pa] at mixture density rho (eqs 4.12-4.16)."""
        return oil_mod.pressure(rho, self.density_atm, self.atmospheric_pressure, self.bulk_modulus,
                                self.polytropic_exponent, self.effective_air)


@dataclass(frozen=True)
class Pump:
    """Crank-slider piston pump and its circuits (Table 5.1; section 4.2)."""

    piston_diameter: float        # d_piston [m]
    rod_length: float             # l [m]
    crank_radius: float           # r [m]
    dead_volume: float            # V_tdc [m^3]
    tank_pressure: float          # P_tank [Pa]
    piston_leakage: bool = False  # effect switch (eq 4.5 m_leak)
    leakage_clearance: float = 5e-6   # radial clearance c [m]
    leakage_length: float = 20e-3     # engaged length L [m]
    line_volume: float = 5e-5         # complete circuit: load line oil volume [m^3]
    accumulator_volume: float = 0.16e-3   # gas volume at/below precharge [m^3]
    accumulator_precharge: float = 2.0e6  # [Pa]
    accumulator_exponent: float = 1.4
    needle_discharge: float = 0.61
    needle_area: float | None = None  # [m^2]; None: set to hold the requested load pressure

    @property
    def piston_area(self) -> float:
        """A_p = pi d^2 / 4 [m^2]."""
        return math.pi * self.piston_diameter**2 / 4

    @property
    def displacement(self) -> float:
        """Swept volume per revolution 2 A_p r [m^3] (section 5.4.4: 2.22 cc)."""
        return 2 * self.piston_area * self.crank_radius

    def leakage_coefficient(self, viscosity: float) -> float:
        """Laminar annulus conductance pi d c^3 / (12 mu L) [m^3/(s Pa)], 0 if the switch is off."""
        if not self.piston_leakage:
            return 0.0
        return math.pi * self.piston_diameter * self.leakage_clearance**3 / (12 * viscosity * self.leakage_length)


class _SeatSwitch:
    """The seat_compliance switch of a valve: which seat stiffness and damping are active."""

    @property
    def seat_stiffness(self) -> float:
        """Active k_seat (N/m for the disc, Pa/m for the reed): compliant if switched on, else rigid."""
        return self.compliant_seat_stiffness if self.seat_compliance else self.rigid_seat_stiffness

    @property
    def seat_damping(self) -> float:
        """Active c_seat (N s/m for the disc, Pa s/m for the reed)."""
        return self.compliant_seat_damping if self.seat_compliance else self.rigid_seat_damping


@dataclass(frozen=True)
class DiscValve(_SeatSwitch):
    """Disc check valve of chapter 2 (Table 2.3); one per position (inlet, delivery)."""

    position: str
    disc_mass: float              # m_disc [kg]
    spring_mass: float            # m_s [kg] (1/3 moves with the disc, eq 2.3)
    spring_stiffness: float       # k_spr [N/m]
    spring_preload: float         # x_pre [m]
    inner_radius: float           # R_i [m]
    outer_radius: float           # R_o [m]
    bevel_angle: float            # theta [rad]
    port_diameter: float          # d_port [m]
    port_length: float            # L [m] (eq 2.37)
    stop_gap: float               # x_stop [m]
    stop_stiffness: float         # k_stop [N/m]
    stop_damping: float           # c_stop [N s/m]
    rigid_seat_stiffness: float   # k_seat, seat FEA [N/m]
    rigid_seat_damping: float     # c_seat [N s/m]
    compliant_seat_stiffness: float   # k_seat with the O-ring under the housing [N/m]
    compliant_seat_damping: float     # [N s/m]
    seat_compliance: bool = False     # effect switch: compliant (True) or rigid seat
    poiseuille_regime: bool = True    # the C1 branch of eq 2.18 (off: F_p = dP A_disc always)
    transition: float = 0.1           # epsilon_0 of eq 2.18
    squeeze_film: bool = False        # effect switch: stiction C2 u / x^3 with limiter
    squeeze_min_gap: float = 1e-6     # film height floor [m]
    drag: bool = True                 # eq 2.28
    viscous_drag: float = 10.0        # c_visc
    inertial_drag: float = 2.0        # C_D,inf
    flow_force: bool = False          # effect switch: eqs 2.36, 2.37
    added_mass: bool = False          # effect switch: m_f of eq 2.3
    added_mass_coefficient: float = 8.0 / 3.0   # m_f = coef * rho * R_o^3
    f1: float = 1.0                   # eq 2.42
    f2: float = 1.0
    cd_inf: float = 0.9720            # eq 2.48
    cd_a: float = -1.0801
    cd_b: float = 0.1058
    cd_c: float = 0.9505
    perimeter_factor: float = 2.0     # orifice perimeter = factor * pi d_port (section 2.4.5)
    orifice_density: str = "average"  # section 4.3.5: "average" or "cylinder"

    @property
    def disc_area(self) -> float:
        """A_disc = pi R_o^2 [m^2]."""
        return disc_area(self.outer_radius)

    @property
    def port_area(self) -> float:
        """A_port = pi d_port^2 / 4 [m^2] (= A_1 of eq 2.42)."""
        return port_area(self.port_diameter)

    @property
    def c1(self) -> float:
        """Poiseuille pressure coefficient C1 (eq 2.14)."""
        from lumped.disc_valve import c1_coefficient
        return c1_coefficient(self.inner_radius, self.outer_radius)

    def c2(self, viscosity: float) -> float:
        """Stiction coefficient C2 [N m^2 s] (eq 2.15) for the oil viscosity [Pa s]."""
        from lumped.disc_valve import c2_coefficient
        return c2_coefficient(self.inner_radius, self.outer_radius, self.bevel_angle, viscosity)

    @property
    def transition_opening(self) -> float:
        """x at the Poiseuille-orifice transition of eq 2.18 [m]: eps0 (R_o - R_i) / sin^2(theta)."""
        return self.transition * (self.outer_radius - self.inner_radius) / math.sin(self.bevel_angle) ** 2

    @property
    def perimeter(self) -> float:
        """Orifice perimeter p of the Reynolds number (eq 2.46) [m]."""
        return self.perimeter_factor * math.pi * self.port_diameter

    def moving_mass(self, density: float) -> float:
        """m_disc + m_s/3 (+ m_f if added_mass) [kg] (eq 2.3)."""
        m = self.disc_mass + self.spring_mass / 3
        if self.added_mass:
            m += self.added_mass_coefficient * density * self.outer_radius**3
        return m


@dataclass(frozen=True)
class ReedValve(_SeatSwitch):
    """Prototype reed valve of chapter 3 (Table 3.13, sections 3.8, 5.5.3); one per position."""

    position: str
    density: float                # rho_c [kg/m^3]
    effective_thickness: float    # h_eff [m]
    stiffness: float              # kappa [Pa/m]
    gamma1: float
    gamma2: float
    gamma3: float
    width_tip: float              # W_2 [m] (added mass, eq 3.17)
    internal_damping: float       # c_c [Pa s/m]
    fluid_damping_coefficient: float  # c_f [Pa s/m]
    preload: float                # x_0 [m]
    stop_gap: float               # x_stop [m]
    rigid_seat_stiffness: float   # [Pa/m] (valvelab's contact model, see reed_valve.toml)
    rigid_seat_damping: float     # [Pa s/m]
    compliant_seat_stiffness: float
    compliant_seat_damping: float
    stop_stiffness: float
    stop_damping: float
    orifice_length: float         # l_o [m] (eq 3.25)
    orifice_perimeter: float      # p_o [m] (eq 3.86)
    area_min: float               # A_1 [m^2]
    area_max: float               # A_2 [m^2]
    f1: float                     # closing (u < 0), section 5.5.3
    f2: float                     # opening (u > 0)
    multiplier_poiseuille: float  # X plateau (Table 3.12)
    multiplier_n1: float          # eq 3.83 numerator/denominator coefficients (x in m)
    multiplier_n0: float
    multiplier_d2: float
    multiplier_d1: float
    multiplier_d0: float
    cd_inf: float                 # eq 3.89
    cd_a: float
    cd_b: float
    cd_c: float
    seat_compliance: bool = False # effect switch
    fluid_damping: bool = True    # effect switch: c = c_c + c_f (eq 3.81) or c_c alone
    drag: bool = False            # the gamma2 rho |u| u C_D / 2 term of eq 3.21
    drag_coefficient: float = 1.0
    added_mass: bool = False      # effect switch: gamma3 rho W2 pi/4 Gamma_f (eq 3.21)
    hydrodynamic_function: float = 0.885
    orifice_density: str = "cylinder"
    source: str = "Table 3.13"    # where kappa, gammas and h_eff come from

    @property
    def damping(self) -> float:
        """c [Pa s/m]: c_c + c_f with fluid damping on (eq 3.81), else c_c."""
        return self.internal_damping + (self.fluid_damping_coefficient if self.fluid_damping else 0.0)

    @property
    def multiplier_zero(self) -> float:
        """Tip opening where eq 3.83 first reaches 0 [m]; X = 0 beyond (docs/errata.md)."""
        return -self.multiplier_n0 / self.multiplier_n1

    def modal_mass(self, density: float) -> float:
        """rho_c h_eff (+ gamma3 rho W2 pi/4 Gamma_f with added_mass) [kg/m^2] (eq 3.21)."""
        m = self.density * self.effective_thickness
        if self.added_mass:
            m += self.gamma3 * density * self.width_tip * math.pi / 4 * self.hydrodynamic_function
        return m


@dataclass(frozen=True)
class PumpModel:
    """Everything the pump simulation needs: pump, oil, and the two check valves."""

    valve: str                    # "disc" or "reed"
    pump: Pump
    oil: Oil
    inlet: DiscValve | ReedValve
    delivery: DiscValve | ReedValve


# --------------------------------------------------------------------------- loaders
def critical_damping(stiffness: float, mass: float) -> float:
    """c_critical = 2 sqrt(k m) (eq 2.23), SI units of k and m."""
    return 2.0 * math.sqrt(stiffness * mass)


def room_viscosity() -> float:
    """mu of Mobil DTE 25 at the thesis's room temperature, 22 C (eq A.3; Table 5.1: 0.0683 Pa s)."""
    v = _data("oil")["viscosity"]
    mu0, b = oil_mod.viscosity_parameters(v["kinematic_low"], v["temperature_low"], v["kinematic_high"],
                                          v["temperature_high"], v["density"])
    return oil_mod.viscosity(v["room_temperature"], mu0, b)


def load_oil(air_content: float = 0.0) -> Oil:
    """Oil of Table 5.1 / Appendix A with air content R (eq 4.11)."""
    c = _data("oil")["compressibility"]
    return Oil(
        density_atm=c["density_atm"], bulk_modulus=c["bulk_modulus"],
        polytropic_exponent=c["specific_heat_ratio"], atmospheric_pressure=c["atmospheric_pressure"],
        viscosity=room_viscosity(), vapour_pressure=_data("oil")["cavitation"]["vapour_pressure"],
        entrained_air=True, air_content=float(air_content),
    )


def load_pump(valve: str = "disc") -> Pump:
    """The pump of Table 5.1 with the dead volume of the ``valve`` type's manifolds (lumped/data/pump.toml).

    The reed manifolds' V_tdc is inferred, not printed (docs/errata.md, "Reed pump delivery offset").
    """
    d = _data("pump")
    p, lk, cc = d["pump"], d["leakage"], d["complete_circuit"]
    v_tdc = d["reed_manifold"]["dead_volume"] if valve == "reed" else p["dead_volume"]
    return Pump(
        piston_diameter=p["piston_diameter"], rod_length=p["rod_length"], crank_radius=p["crank_radius"],
        dead_volume=v_tdc, tank_pressure=p["tank_pressure"],
        leakage_clearance=lk["radial_clearance"], leakage_length=lk["seal_length"],
        line_volume=cc["line_volume"], accumulator_volume=cc["accumulator_volume"],
        accumulator_precharge=cc["accumulator_precharge"], accumulator_exponent=cc["accumulator_exponent"],
        needle_discharge=cc["needle_discharge"],
    )


def thesis_air_content(valve: str) -> float:
    """R the thesis's model used: 0.013 for the disc pump (Table 5.4), 0.008 for the reed (Table 5.6)."""
    return _data("pump")["air_content"][valve]


def table_5_1_dead_volume() -> float:
    """V_tdc [m^3] as printed in Table 5.1 (the disc pump's; the reed's is inferred, see load_pump)."""
    return _data("pump")["pump"]["dead_volume"]


def load_disc_valve(position: str) -> DiscValve:
    """Disc valve of Table 2.3 in the thesis configuration for its position.

    The inlet valve sits on the rigid steel seat; the delivery valve's housing was not
    fully seated, so its O-ring makes the seat compliant (sections 2.4.3.2, 5.4.5).
    Stiction and flow forces are off, drag on, added mass off (section 2.6).
    """
    _check_position(position)
    g = load_disc_geometry()
    d = _data("disc_valve")
    return DiscValve(
        position=position,
        disc_mass=d["mass"]["disc"], spring_mass=d["mass"]["spring"],
        spring_stiffness=d["spring"]["stiffness"], spring_preload=g.spring_preload,
        inner_radius=g.inner_radius, outer_radius=g.outer_radius, bevel_angle=g.bevel_angle,
        port_diameter=g.port_diameter, port_length=g.port_length,
        stop_gap=g.stop_inlet if position == "inlet" else g.stop_delivery,
        stop_stiffness=d["stop"]["stiffness"], stop_damping=d["stop"]["damping"],
        rigid_seat_stiffness=d["seat"]["rigid_stiffness"], rigid_seat_damping=d["seat"]["rigid_damping"],
        compliant_seat_stiffness=d["seat"]["compliant_stiffness"],
        compliant_seat_damping=d["seat"]["compliant_damping"],
        seat_compliance=(position == "delivery"),
        poiseuille_regime=True, transition=d["pressure"]["transition"],
        squeeze_film=False, squeeze_min_gap=d["squeeze_film"]["min_gap"],
        drag=True, viscous_drag=d["drag"]["viscous_coefficient"], inertial_drag=d["drag"]["inertial_coefficient"],
        flow_force=False, added_mass=False, added_mass_coefficient=d["added_mass"]["coefficient"],
        f1=d["displacement"]["f1"], f2=d["displacement"]["f2"],
        cd_inf=d["discharge"]["cd_inf"], cd_a=d["discharge"]["a"], cd_b=d["discharge"]["b"],
        cd_c=d["discharge"]["c"], perimeter_factor=d["discharge"]["perimeter_factor"],
        orifice_density=d["orifice_density"]["mode"],
    )


def load_reed_valve(position: str) -> ReedValve:
    """Prototype reed valve of Table 3.13 in the thesis configuration for its position.

    Fluid damping on (c = c_c + c_f = 1727 Pa s/m), added mass and drag off (section 3.3),
    rigid seat, x_0 = 0 (inlet) or -0.18 mm (delivery).
    """
    _check_position(position)
    d = _data("reed_valve")
    st, dm, seat, fl, X, cd, ct = (d["structure"], d["damping"], d["seat"], d["flow"],
                                   d["pressure_multiplier"], d["discharge"], d["contact"])
    modal = st["density"] * st["effective_thickness"]
    g1 = st["gamma1"]

    def crit(k):  # eq 2.23 for the modal equation: M x'' + g1 c x' + g1 k x
        return critical_damping(g1 * k, modal) / g1

    k_rigid, k_soft = ct["rigid_seat_stiffness"], ct["compliant_seat_stiffness"]
    return ReedValve(
        position=position, density=st["density"], effective_thickness=st["effective_thickness"],
        stiffness=st["stiffness"], gamma1=g1, gamma2=st["gamma2"], gamma3=st["gamma3"],
        width_tip=st["width_tip"], internal_damping=dm["internal"], fluid_damping_coefficient=dm["fluid"],
        preload=seat["preload_inlet"] if position == "inlet" else seat["preload_delivery"],
        stop_gap=seat["stop"],
        rigid_seat_stiffness=k_rigid, rigid_seat_damping=crit(k_rigid),
        compliant_seat_stiffness=k_soft, compliant_seat_damping=crit(k_soft),
        stop_stiffness=k_rigid, stop_damping=crit(k_rigid),
        orifice_length=fl["orifice_length"], orifice_perimeter=fl["orifice_perimeter"],
        area_min=fl["area_min"], area_max=fl["area_max"], f1=fl["f1"], f2=fl["f2"],
        multiplier_poiseuille=X["poiseuille"], multiplier_n1=X["n1"], multiplier_n0=X["n0"],
        multiplier_d2=X["d2"], multiplier_d1=X["d1"], multiplier_d0=X["d0"],
        cd_inf=cd["cd_inf"], cd_a=cd["a"], cd_b=cd["b"], cd_c=cd["c"],
        seat_compliance=False, fluid_damping=True, drag=False, drag_coefficient=dm["drag_coefficient"],
        added_mass=False, hydrodynamic_function=d["added_mass"]["hydrodynamic_function"],
        orifice_density=d["orifice_density"]["mode"],
    )


def thesis_model(valve: str, air_content: float | None = None) -> PumpModel:
    """The thesis configuration of the pump with disc or reed valves (Tables 2.3, 3.13, 5.1).

    ``air_content`` None: the R the thesis's model used (0.013 disc, 0.008 reed).
    """
    if valve not in VALVES:
        raise InputError("valve", f"expected one of {', '.join(VALVES)}, got {valve!r}")
    air = thesis_air_content(valve) if air_content is None else air_content
    loader = load_disc_valve if valve == "disc" else load_reed_valve
    return PumpModel(valve=valve, pump=load_pump(valve), oil=load_oil(air),
                     inlet=loader("inlet"), delivery=loader("delivery"))


def baseline_model(valve: str) -> PumpModel:
    """CONTRACT's baseline: the thesis parameters with every candidate effect of EFFECTS off.

    Rigid seats on both valves (disc: k_seat = 3.02e9 N/m, c_seat = 6860 N s/m), no stiction,
    flow force, added mass, reed fluid damping or piston leakage, and air-free oil.
    """
    m = thesis_model(valve)
    for effect in EFFECTS:
        m = set_effect(m, effect, False)
    return m


def set_effect(model: PumpModel, effect: str, on: bool, valves: tuple[str, ...] = POSITIONS) -> PumpModel:
    """``model`` with one candidate effect (see EFFECTS) switched on or off.

    Valve effects apply to the positions in ``valves`` that have them; ``piston_leakage``
    and ``entrained_air`` are pump/oil effects. Parameters of an effect are changed with
    :func:`dataclasses.replace` on the component (e.g. ``compliant_seat_stiffness``).
    """
    if effect not in EFFECTS:
        raise InputError("effect", f"expected one of {', '.join(EFFECTS)}, got {effect!r}")
    if effect == "piston_leakage":
        return replace(model, pump=replace(model.pump, piston_leakage=on))
    if effect == "entrained_air":
        return replace(model, oil=replace(model.oil, entrained_air=on))
    out = model
    for pos in valves:
        v = getattr(out, pos)
        if effect in {f.name for f in fields(v)}:
            out = replace(out, **{pos: replace(v, **{effect: on})})
    return out


def with_reed_properties(valve: ReedValve, props) -> ReedValve:
    """The reed valve with kappa, gamma1..3 and h_eff from a reed model's ``ReedProperties``.

    Only the structural quantities change; the empirical prototype quantities of Table 3.13
    (X(x), C_d, l_o, A_1, A_2, f1, f2, c_c, c_f, x_0) stay as measured. Contact dampings
    are kept critical for the new modal mass (eq 2.23).
    """
    for name in ("kappa", "gamma1", "gamma2", "gamma3", "h_eff"):
        v = getattr(props, name)
        if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v > 0):
            raise InputError(f"reed properties.{name}", f"expected a positive finite number, got {v!r}")
    modal = valve.density * props.h_eff

    def crit(k):
        return critical_damping(props.gamma1 * k, modal) / props.gamma1

    return replace(
        valve, stiffness=float(props.kappa), gamma1=float(props.gamma1), gamma2=float(props.gamma2),
        gamma3=float(props.gamma3), effective_thickness=float(props.h_eff),
        rigid_seat_damping=crit(valve.rigid_seat_stiffness),
        compliant_seat_damping=crit(valve.compliant_seat_stiffness),
        stop_damping=crit(valve.stop_stiffness), source=f"{props.fidelity} model",
    )


def _check_position(position: str) -> None:
    if position not in POSITIONS:
        raise InputError("position", f"expected inlet or delivery, got {position!r}")


# --------------------------------------------------------------------------- validation
def validate_model(model: PumpModel) -> None:
    """Raise InputError naming the first non-physical parameter of ``model``."""
    if model.valve not in VALVES:
        raise InputError("params.valve", f"expected disc or reed, got {model.valve!r}")
    kind = DiscValve if model.valve == "disc" else ReedValve
    for pos in POSITIONS:
        v = getattr(model, pos)
        if not isinstance(v, kind):
            raise InputError(f"params.{pos}", f"expected a {kind.__name__} for valve {model.valve!r}")
    for comp in ("pump", "oil", "inlet", "delivery"):
        obj = getattr(model, comp)
        for f in fields(obj):
            v = getattr(obj, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                continue
            where = f"params.{comp}.{f.name}"
            if not math.isfinite(v):
                raise InputError(where, f"must be finite, got {v}")
            if f.name in ("preload", "cd_a", "multiplier_n1", "multiplier_d1", "multiplier_d2",
                          "vapour_pressure"):
                continue                                    # may be negative
            if v < 0:
                raise InputError(where, f"must not be negative, got {v}")
    o = model.oil
    if not 0.0 <= o.air_content < 1.0:
        raise InputError("air_content", f"must be in [0, 1), got {o.air_content}")
    for pos in POSITIONS:
        v = getattr(model, pos)
        where = f"params.{pos}"
        for f in ("f1", "f2"):
            if not 0.0 <= getattr(v, f) <= 1.0:
                raise InputError(f"{where}.{f}", f"must be in [0, 1], got {getattr(v, f)}")
        if v.orifice_density not in ("average", "cylinder"):
            raise InputError(f"{where}.orifice_density", f"expected 'average' or 'cylinder', got {v.orifice_density!r}")
        if v.stop_gap <= 0:
            raise InputError(f"{where}.stop_gap", f"must be positive, got {v.stop_gap}")
        _check_discharge(v, where)
        if isinstance(v, DiscValve) and v.disc_mass + v.spring_mass <= 0:
            raise InputError(f"{where}.disc_mass", "the moving mass must be positive")
        if isinstance(v, ReedValve):
            if v.density * v.effective_thickness <= 0:
                raise InputError(f"{where}.effective_thickness", "the modal mass rho_c h_eff must be positive")
            if not v.multiplier_zero > 0:
                raise InputError(f"{where}.multiplier_n0", "X(x) of eq 3.83 must reach 0 at a positive opening")


def _check_discharge(v, where: str) -> None:
    """The Cd(Re) correlation must start with a positive slope and keep s^2/Cd(s) increasing."""
    args = (v.cd_inf, v.cd_a, v.cd_b, v.cd_c)
    if not laminar_slope(*args) > 0 or not v.cd_inf > 0:
        raise InputError(f"{where}.cd_inf", "Cd(Re) must rise from 0 with a positive slope (eq 2.47)")
    s = np.geomspace(1e-6, 1e4, 2000)
    cd = discharge_coefficient(s, *args)
    if np.any(cd <= 0) or np.any(np.diff(np.log(s**2 / cd)) <= 0):
        raise InputError(f"{where}.cd_a", "Cd(Re) must stay positive with s^2/Cd(s) increasing in s = sqrt(Re)")


# --------------------------------------------------------------------------- flat array
# global block
G_OMEGA, G_AP, G_CRANK, G_ROD, G_VTDC, G_PTANK, G_PLOAD = 0, 1, 2, 3, 4, 5, 6
G_RHO0, G_P0, G_BETA, G_GAMMA, G_AIR, G_MU, G_PVAP = 7, 8, 9, 10, 11, 12, 13
G_LEAK, G_CIRCUIT, G_VLINE, G_VACC, G_PPRE, G_NACC, G_NVCDA = 14, 15, 16, 17, 18, 19, 20
NG = 24
# valve block (offset OFF_IN or OFF_DEL); common entries
V_KIND, V_MASS, V_XSTOP, V_KSEAT, V_CSEAT, V_KSTOP, V_CSTOP = 0, 1, 2, 3, 4, 5, 6
V_A1, V_A2, V_F1, V_F2 = 7, 8, 9, 10
V_CDINF, V_CDA, V_CDB, V_CDC, V_PERIM, V_RHOMODE, V_AREA = 11, 12, 13, 14, 15, 16, 17
# disc entries
V_KSPR, V_XPRE, V_C1, V_POIS, V_XTRANS, V_C2, V_HMIN = 18, 19, 20, 21, 22, 23, 24
V_APORT, V_ADISC, V_COS, V_LPORT, V_CVISC, V_CDRAG, V_DDISC, V_FLOW = 25, 26, 27, 28, 29, 30, 31, 32
# reed entries
V_G1, V_RDRAG, V_KAPPA, V_X0, V_DAMP = 33, 34, 35, 36, 37
V_XPOIS, V_XN1, V_XN0, V_XD2, V_XD1, V_XD0, V_XZERO = 38, 39, 40, 41, 42, 43, 44
NV = 48
OFF_IN = NG
OFF_DEL = NG + NV
NP = NG + 2 * NV
KIND_DISC, KIND_REED = 0.0, 1.0


def pack(model: PumpModel, speed_rpm: float, load_pressure: float, circuit: str = "simplified",
         needle_area: float | None = None) -> np.ndarray:
    """Flat float64 parameter array of the right-hand side (index constants G_*, V_*, OFF_*).

    Switches become numbers here: an effect that is off contributes a zero coefficient
    (or a 0/1 flag), so the physics functions read floats only.
    """
    p = np.zeros(NP)
    pump, oil = model.pump, model.oil
    p[G_OMEGA] = speed_rpm * 2.0 * math.pi / 60.0
    p[G_AP] = pump.piston_area
    p[G_CRANK] = pump.crank_radius
    p[G_ROD] = pump.rod_length
    p[G_VTDC] = pump.dead_volume
    p[G_PTANK] = pump.tank_pressure
    p[G_PLOAD] = load_pressure
    p[G_RHO0] = oil.density_atm
    p[G_P0] = oil.atmospheric_pressure
    p[G_BETA] = oil.bulk_modulus
    p[G_GAMMA] = oil.polytropic_exponent
    p[G_AIR] = oil.effective_air
    p[G_MU] = oil.viscosity
    p[G_PVAP] = oil.vapour_pressure
    p[G_LEAK] = pump.leakage_coefficient(oil.viscosity)
    p[G_CIRCUIT] = 1.0 if circuit == "complete" else 0.0
    p[G_VLINE] = pump.line_volume
    p[G_VACC] = pump.accumulator_volume
    p[G_PPRE] = pump.accumulator_precharge
    p[G_NACC] = pump.accumulator_exponent
    area = pump.needle_area if needle_area is None else needle_area
    p[G_NVCDA] = 0.0 if area is None else pump.needle_discharge * area
    for off, v in ((OFF_IN, model.inlet), (OFF_DEL, model.delivery)):
        _pack_valve(p, off, v, oil)
    return p


def _pack_valve(p: np.ndarray, o: int, v, oil: Oil) -> None:
    rho = oil.density_atm
    p[o + V_XSTOP] = v.stop_gap
    p[o + V_KSEAT] = v.seat_stiffness
    p[o + V_CSEAT] = v.seat_damping
    p[o + V_KSTOP] = v.stop_stiffness
    p[o + V_CSTOP] = v.stop_damping
    p[o + V_F1] = v.f1
    p[o + V_F2] = v.f2
    p[o + V_CDINF] = v.cd_inf
    p[o + V_CDA] = v.cd_a
    p[o + V_CDB] = v.cd_b
    p[o + V_CDC] = v.cd_c
    p[o + V_RHOMODE] = 1.0 if v.orifice_density == "average" else 0.0
    if isinstance(v, DiscValve):
        p[o + V_KIND] = KIND_DISC
        p[o + V_MASS] = v.moving_mass(rho)
        p[o + V_A1] = v.port_area
        p[o + V_A2] = v.disc_area
        p[o + V_PERIM] = v.perimeter
        p[o + V_AREA] = math.pi * v.port_diameter * math.sin(v.bevel_angle)   # eq 2.40: A_o / x
        p[o + V_KSPR] = v.spring_stiffness
        p[o + V_XPRE] = v.spring_preload
        p[o + V_C1] = v.c1
        p[o + V_POIS] = 1.0 if v.poiseuille_regime else 0.0
        p[o + V_XTRANS] = v.transition_opening
        p[o + V_C2] = v.c2(oil.viscosity) if v.squeeze_film else 0.0
        p[o + V_HMIN] = v.squeeze_min_gap
        p[o + V_APORT] = v.port_area
        p[o + V_ADISC] = v.disc_area
        p[o + V_COS] = math.cos(v.bevel_angle)
        p[o + V_LPORT] = v.port_length
        p[o + V_CVISC] = v.viscous_drag if v.drag else 0.0
        p[o + V_CDRAG] = v.inertial_drag if v.drag else 0.0
        p[o + V_DDISC] = 2.0 * v.outer_radius
        p[o + V_FLOW] = 1.0 if v.flow_force else 0.0
    else:
        p[o + V_KIND] = KIND_REED
        p[o + V_MASS] = v.modal_mass(rho)
        p[o + V_A1] = v.area_min
        p[o + V_A2] = v.area_max
        p[o + V_PERIM] = v.orifice_perimeter
        p[o + V_AREA] = v.orifice_length                                      # eq 3.25: A_o / x
        p[o + V_G1] = v.gamma1
        p[o + V_RDRAG] = 0.5 * v.gamma2 * v.drag_coefficient if v.drag else 0.0
        p[o + V_KAPPA] = v.stiffness
        p[o + V_X0] = v.preload
        p[o + V_DAMP] = v.damping
        p[o + V_XPOIS] = v.multiplier_poiseuille
        p[o + V_XN1] = v.multiplier_n1
        p[o + V_XN0] = v.multiplier_n0
        p[o + V_XD2] = v.multiplier_d2
        p[o + V_XD1] = v.multiplier_d1
        p[o + V_XD0] = v.multiplier_d0
        p[o + V_XZERO] = v.multiplier_zero
        p[o + V_XTRANS] = -1.0         # no pressure-regime switch: X(x) covers both regimes
