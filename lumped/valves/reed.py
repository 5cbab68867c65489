"""Reed check valve of chapter 3: parameters, the tip equation 3.21 and the kind entry.

Equation of motion per unit area (Pa), x the tip opening [m] (eq 3.21)::

    M x'' + gamma1 c x' + gamma2 rho |x'| x' C_D / 2 + gamma1 kappa (x - x0)
        = gamma1 dP X(x) + gamma1 F_c(x, x')

with M = rho_c h_eff (+ gamma3 rho W2 pi/4 Gamma_f with added mass), c = c_c + c_f,
X(x) the pressure load multiplier (eq 3.83) and F_c valvelab's seat/stop contact (the
thesis gives none; thesis-reed.toml documents it). The drag term is printed x'^2 in
eq 3.21; it must oppose the motion, so |x'| x' is used (docs/errata.md).

:class:`ReedValve` declares every parameter once; the prototype's values are in
``lumped/data/models/thesis-reed.toml``. A reed valve may instead name a reed geometry
(preset, file, or an inline table of the reed-file schema) and a fidelity (analytic,
beam, plate, solid: :mod:`lumped.reed.fidelities`) from which kappa, gamma1..3, h_eff,
rho_c and W2 are derived. The flow (eqs 3.22-3.26, C_d of eq 3.89) is shared with every
kind (:func:`lumped.valves.forces.valve_flow`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from geometry.declare import param, read_table
from geometry.errors import InputError
from geometry.reed import Reed
from geometry.reed_io import PRESETS
from lumped.valves.kind import (
    SEAT, STOP, Common, ValveKind, ValveParams, check_discharge, contact_reaction, contact_slopes, contact_state,
    critical_damping, fluid_param, kind_block, register,
)

CRITICAL = "critical damping of the modal equation (eq 2.23: 2 sqrt(gamma1 k rho_c h_eff) / gamma1), derived when left out"
DERIVED = "left out when the valve names a geometry: derived from it by the fidelity"


def modal_critical_damping(stiffness: float, gamma1: float, modal_mass: float) -> float:
    """Critical damping [Pa s/m] of the modal equation M x'' + gamma1 (c x' + k x) = F (eq 3.21 with eq 2.23).

    Parameters
    ----------
    stiffness : float
        k [Pa/m] (kappa, or a contact's stiffness per unit area).
    gamma1 : float
        The modal factor of eq 3.21 [-].
    modal_mass : float
        M = rho_c h_eff [kg/m^2].

    Returns
    -------
    float
        2 sqrt(gamma1 k M) / gamma1 (:func:`lumped.valves.forces.critical_damping` with gamma = gamma1).
    """
    return critical_damping(stiffness, modal_mass, gamma1)


@dataclass(frozen=True)
class ReedValve(ValveParams):
    """Reed valve of chapter 3 (Table 3.13, sections 3.8, 5.5.3); one per position."""

    position: str
    internal_damping: float = param("damping.internal", "Pa s/m", "c_c, plucked-reed runs (Table 3.10)",
                                    bounds=(0.0, 1e9))
    drag: bool = param("damping.drag", "-", "the gamma2 rho |u| u C_D / 2 term of eq 3.21 (thesis: off)")
    drag_coefficient: float = param("damping.drag_coefficient", "-", "C_D of eq 3.21 (section 3.8.2.2: ~1)",
                                    bounds=(0.0, 100.0))
    preload: float = param("seat.preload", "m", "x_0, tip opening at zero load (negative: pressed on the seat)",
                           bounds=(-0.1, 0.1), packed=True)
    seat_stiffness: float = param("seat.stiffness", "Pa/m", "seat contact per unit area (valvelab's contact "
                                  "model: E/h of the reed, thesis-reed.toml)", bounds=(1.0, 1e16), positive=True)
    stop_gap: float = param("stop.gap", "m", "x_stop (section 3.8.5)", bounds=(1e-7, 0.1), positive=True,
                            typical=(1e-5, 0.01))
    stop_stiffness: float = param("stop.stiffness", "Pa/m", "stop contact per unit area", bounds=(1.0, 1e16),
                                  positive=True)
    orifice_length: float = param("flow.orifice_length", "m", "l_o, orifice area per tip opening (eq 3.25)",
                                  bounds=(1e-6, 10.0), positive=True)
    orifice_perimeter: float = param("flow.orifice_perimeter", "m", "p_o of the Reynolds number (eq 3.86)",
                                     bounds=(1e-6, 10.0), positive=True)
    area_min: float = param("flow.area_min", "m^2", "A_1 (eq 3.28)", bounds=(0.0, 10.0))
    area_max: float = param("flow.area_max", "m^2", "A_2, the face area (docs/errata.md)", bounds=(0.0, 10.0))
    f1: float = param("flow.f1", "-", "fluid displacement, closing (section 5.5.3)", bounds=(0.0, 1.0))
    f2: float = param("flow.f2", "-", "fluid displacement, opening (section 5.5.3)", bounds=(0.0, 1.0))
    orifice_density: str = param("flow.orifice_density", "-", "density in the orifice equation (section 4.3.5)",
                                 choices=("average", "cylinder"))
    multiplier_poiseuille: float = param("pressure_multiplier.poiseuille", "-", "X plateau (Table 3.12, F4 = 0.5)",
                                         bounds=(0.0, 1.0), packed=True)
    multiplier_n1: float = param("pressure_multiplier.n1", "1/m", "eq 3.83 numerator, x in m", bounds=(-1e9, 1e9), packed=True)
    multiplier_n0: float = param("pressure_multiplier.n0", "-", "eq 3.83", bounds=(-1e9, 1e9), packed=True)
    multiplier_d2: float = param("pressure_multiplier.d2", "m", "eq 3.83 denominator", bounds=(-1e9, 1e9), packed=True)
    multiplier_d1: float = param("pressure_multiplier.d1", "m^2", "eq 3.83", bounds=(-1e9, 1e9), packed=True)
    multiplier_d0: float = param("pressure_multiplier.d0", "m^3", "eq 3.83", bounds=(-1e9, 1e9), packed=True)
    cd_inf: float = param("discharge.cd_inf", "-", "C_d(Re) of eq 3.89", bounds=(1e-3, 2.0), positive=True,
                          typical=(0.05, 1.0))
    cd_a: float = param("discharge.a", "-", "eq 3.89", bounds=(-100.0, 100.0))
    cd_b: float = param("discharge.b", "-", "eq 3.89", bounds=(0.0, 100.0), positive=True)
    cd_c: float = param("discharge.c", "-", "eq 3.89", bounds=(0.0, 100.0), positive=True)
    cd_lift_exponent: float = param("discharge.lift_exponent", "-", "k: Cd(Re) of eq 3.88 taken at the effective "
                                    "Reynolds number Re (x / x_stop)^k (0: eq 3.89, Cd independent of the opening; "
                                    "fluid = \"predicted\" fits it, docs/fluid.md)", bounds=(-3.0, 3.0), default=0.0,
                                    optional=True)
    # geometry and fidelity, or the structural parameters directly
    geometry: str = param("geometry", "-", f"reed geometry: preset ({', '.join(PRESETS)}), reed TOML file, or an "
                          "inline table of the reed-file schema", optional=True)
    fidelity: str = param("fidelity", "-", "reed model deriving kappa, gamma1..3, h_eff from the geometry "
                          "(analytic, beam, plate, solid)", optional=True)
    density: float = param("structure.density", "kg/m^3", "rho_c (Table 3.13); " + DERIVED, bounds=(10.0, 3e4),
                           positive=True, optional=True)
    effective_thickness: float = param("structure.effective_thickness", "m", "h_eff (eq 3.62); " + DERIVED,
                                       bounds=(1e-8, 1.0), positive=True, optional=True)
    stiffness: float = param("structure.stiffness", "Pa/m", "kappa (Table 3.10 plucked-reed mean); " + DERIVED,
                             bounds=(1e-3, 1e16), positive=True, optional=True, packed=True,
                             typical=(1e4, 1e10))
    gamma1: float = param("structure.gamma1", "-", "Table 3.8 (stepped #2, load); " + DERIVED, bounds=(0.01, 100.0),
                          positive=True, optional=True, packed=True)
    gamma2: float = param("structure.gamma2", "-", "Table 3.8; " + DERIVED, bounds=(0.0, 100.0), optional=True)
    gamma3: float = param("structure.gamma3", "-", "Table 3.8; " + DERIVED, bounds=(0.0, 100.0), optional=True)
    width_tip: float = param("structure.width_tip", "m", "W2, for the added mass of eq 3.17; " + DERIVED,
                             bounds=(1e-6, 10.0), positive=True, optional=True)
    seat_damping: float = param("seat.damping", "Pa s/m", "c_seat; " + CRITICAL, bounds=(0.0, 1e12), optional=True)
    stop_damping: float = param("stop.damping", "Pa s/m", "c_stop; " + CRITICAL, bounds=(0.0, 1e12), optional=True)
    # beyond one mode (lumped/reed/structure.py): the reed's first modes or the whole FE reed
    dynamics: str = param("dynamics", "-", "one-mode (eq 3.21), modal (the fidelity's first `modes` modes, the "
                          "port's load on each) or fe (the whole FE reed; the reference stepper)",
                          choices=("one-mode", "modal", "fe"), default="one-mode", optional=True)
    modes: int = param("modes", "-", "modes of the modal reed (dynamics = modal)", bounds=(1, 6), optional=True)
    mesh_size: float = param("mesh_size", "m", "element size of the fidelity's FE model for the modal or FE reed "
                             "(left out: the fidelity's default)", bounds=(1e-6, 1.0), positive=True, optional=True)
    port_s_start: float = param("port.s_start", "m", "port footprint on the reed face, from the clamp (left out: the "
                                "whole face, eq 3.21's load)", bounds=(0.0, 10.0), optional=True)
    port_s_end: float = param("port.s_end", "m", "port footprint: end, from the clamp", bounds=(0.0, 10.0),
                              optional=True)
    port_width: float = param("port.width", "m", "port footprint: width across the reed", bounds=(0.0, 10.0),
                              optional=True)
    port_y_center: float = param("port.y_center", "m", "port footprint: centre, from the reed's centre line",
                                 bounds=(-10.0, 10.0), optional=True)
    # set by candidate effects (lumped/model/effect_library.py); zero = the effect is off
    fluid_damping_coefficient: float = param(None, "Pa s/m", "c_f of eq 3.80", bounds=(0.0, 1e9), default=0.0,
                                             effect="fluid_damping")
    hydrodynamic_function: float = param(None, "-", "Gamma_f of eq 3.13 (added mass)", bounds=(0.0, 1e3),
                                         default=0.0, effect="added_mass")
    fluid: str = fluid_param()
    flow_geometry: str = param("flow.geometry", "-", "the reed the fluid references mesh (preset or reed TOML file) "
                               "when the structural parameters are given directly (left out: the valve's geometry)",
                               optional=True)
    # set by fluid = "predicted" (lumped.valves.fluid_forms): the range its compact forms were computed on
    fluid_opening_max: float = param(None, "m", "largest tip opening the predicted fluid forms were computed at "
                                     "(0: not predicted)", bounds=(0.0, 10.0), default=0.0)
    fluid_reynolds_max: float = param(None, "-", "largest Reynolds number (eq 3.87) the predicted fluid forms were "
                                      "computed at (0: not predicted)", bounds=(0.0, 1e9), default=0.0)
    reed: Reed | None = None         # the parsed geometry (None: parameters given directly)
    source: str = "given"            # where kappa, gammas and h_eff come from

    #: keys a geometry supplies (dropped from inherited defaults when a file names a geometry)
    STRUCTURE = ("structure.density", "structure.effective_thickness", "structure.stiffness",
                 "structure.gamma1", "structure.gamma2", "structure.gamma3", "structure.width_tip")
    #: and the reed the fluid references mesh, when the structure is given directly (flow.geometry)
    FROM_GEOMETRY = STRUCTURE + ("flow.geometry",)
    #: the reed's own derived packed quantities (:meth:`packed_extra`)
    DERIVED = ("drag_term", "damping_total", "x_zero", "dynamics_code", "n_stations", "drag_half_cd")

    # ---- construction
    @classmethod
    def load(cls, table: dict, where: str, position: str) -> "ReedValve":
        """A reed valve from its complete model-file table ``valves.<position>`` (lumped.model.model_file)."""
        table = dict(table)
        geo = table.pop("geometry", None)
        values = read_table(cls, table, where, extra_keys=("kind",), require=True)
        v = cls(position=position, **values)
        if v.flow_geometry is not None:
            if geo is not None:
                raise InputError(f"{where}.flow.geometry", "the valve names a geometry, which the fluid references "
                                 "mesh; give one or the other")
            _reed_from(v.flow_geometry, f"{where}.flow.geometry")        # a bad name fails here, not in a solve
        if geo is None:
            if v.fidelity is not None:
                raise InputError(f"{where}.fidelity", "needs a geometry to derive the reed parameters from")
            by_key = {k: n for n, k in _keys(cls)}
            for key in cls.STRUCTURE:
                if getattr(v, by_key[key]) is None:
                    raise InputError(f"{where}.{key}", "missing: give the reed parameters or a geometry")
            return v.checked(where)
        given = [k for k in cls.FROM_GEOMETRY if _has(table, k)]
        if given:
            raise InputError(f"{where}.{given[0]}", "is derived from the geometry; give one or the other")
        reed = _reed_from(geo, f"{where}.geometry")
        name = geo if isinstance(geo, str) else "inline"
        return v.with_geometry(reed, name, v.fidelity or "analytic", f"{where}.fidelity").checked(where)

    def with_geometry(self, reed: Reed, name: str, fidelity: str = "analytic",
                      field: str = "fidelity", mesh_size=None) -> "ReedValve":
        """This valve with kappa, gamma1..3, h_eff, rho_c and W2 from ``reed`` by ``fidelity``.

        Only the structural quantities change; the empirical prototype quantities of Table
        3.13 (X(x), C_d, l_o, A_1, A_2, f1, f2, c_c, x_0) stay as given.
        """
        from lumped.reed.fidelities import reed_properties

        props = reed_properties(reed, fidelity, mesh_size=mesh_size, field=field)
        return self.with_properties(props, reed.material.density, reed.width_tip, reed=reed, geometry=name,
                                    fidelity=fidelity)

    def with_properties(self, props, density: float | None = None, width_tip: float | None = None,
                        **extra) -> "ReedValve":
        """This valve with kappa, gamma1..3 and h_eff of a reed model's ``ReedProperties``."""
        for name in ("kappa", "gamma1", "gamma2", "gamma3", "h_eff"):
            v = getattr(props, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"reed properties.{name}", f"expected a positive finite number, got {v!r}")
        return replace(self, stiffness=float(props.kappa), gamma1=float(props.gamma1), gamma2=float(props.gamma2),
                       gamma3=float(props.gamma3), effective_thickness=float(props.h_eff),
                       density=float(density if density is not None else self.density),
                       width_tip=float(width_tip if width_tip is not None else self.width_tip),
                       source=f"{props.fidelity} model", **extra)

    def checked(self, where: str) -> "ReedValve":
        """Consistency: X(x) of eq 3.83 must fall to zero at a positive opening; A_1 <= A_2; Cd(Re); the modal or
        FE reed needs a geometry, 1..6 modes the fidelity provides, and a port on the reed."""
        check_discharge(self.cd_inf, self.cd_a, self.cd_b, self.cd_c, where)
        self._check_dynamics(where)
        if not self.multiplier_zero > 0:
            raise InputError(f"{where}.pressure_multiplier.n0", "X(x) of eq 3.83 must reach 0 at a positive "
                             f"opening (-n0/n1 > 0), got {self.multiplier_zero:g} m")
        if self.area_min > self.area_max:
            raise InputError(f"{where}.flow.area_min", f"must not exceed flow.area_max ({self.area_max:g} m^2)")
        return self

    def _check_dynamics(self, where: str) -> None:
        from lumped.reed.structure import structure
        from lumped.reed.modal_basis import check_modes

        dyn = self.dynamics or "one-mode"
        port_keys = [self.port_s_start, self.port_s_end, self.port_width, self.port_y_center]
        if dyn == "one-mode":
            if self.modes is not None:
                raise InputError(f"{where}.modes", "applies to dynamics = \"modal\" (this reed is one-mode, eq 3.21)")
            if any(v is not None for v in port_keys):
                raise InputError(f"{where}.port", "a port footprint loads the modal or FE reed (dynamics = "
                                                  "\"modal\" or \"fe\"); eq 3.21 loads the whole face")
            return
        if self.reed is None:
            raise InputError(f"{where}.dynamics", f"{dyn} dynamics need the reed's geometry (valves.<pos>.geometry)")
        if dyn == "modal":
            if self.modes is None:
                raise InputError(f"{where}.modes", "missing: how many modes (1..6) the modal reed keeps")
            check_modes(self.modes, f"{where}.modes")
        elif self.modes is not None:
            raise InputError(f"{where}.modes", "applies to dynamics = \"modal\" (the FE reed keeps every DOF)")
        if any(v is not None for v in port_keys[:3]) and not all(v is not None for v in port_keys[:3]):
            missing = ("s_start", "s_end", "width")[[v is None for v in port_keys[:3]].index(True)]
            raise InputError(f"{where}.port.{missing}", "missing; a port is a rectangle s_start..s_end [m] from the "
                             "clamp, width [m] across, centred at y_center [m] (default 0)")
        if self.mesh_size is not None and self.mesh_size > self.reed.length / 4:
            # the fidelity's FE model needs at least 4 elements along the reed (fea.mesh.check_size)
            raise InputError(f"{where}.mesh_size", f"{self.mesh_size:g} m is too coarse for the {self.reed.length:g} m "
                                                   "reed: at most a quarter of its length")
        structure(self, 1.0)          # the basis or FE reed exists: modes, fidelity and port checked here

    def fluid_reed(self, where: str) -> Reed:
        """The reed the fluid references mesh: the valve's geometry, else ``flow.geometry``; InputError
        naming ``where``.geometry when the valve has neither."""
        if self.reed is not None:
            return self.reed
        if self.flow_geometry is not None:
            return _reed_from(self.flow_geometry, f"{where}.flow.geometry")
        raise InputError(f"{where}.geometry", "the fluid references mesh the reed: give its geometry (a preset, a "
                         "reed file or an inline table), or flow.geometry when the structural parameters are given")

    @property
    def port(self):
        """The port footprint (geometry.reed_port.ReedPort), or None: the whole face (eq 3.21)."""
        if self.port_s_start is None:
            return None
        from geometry.reed_port import ReedPort

        return ReedPort(self.port_s_start, self.port_s_end, self.port_width,
                        0.0 if self.port_y_center is None else self.port_y_center)

    def dofs(self) -> int:
        """Mechanical DOFs: 1 (eq 3.21), the modes kept (modal) or the FE reed's DOFs (fe)."""
        if (self.dynamics or "one-mode") == "one-mode":
            return 1
        from lumped.reed.structure import structure

        return structure(self, 1.0).n

    def several(self) -> bool:
        """The modal or FE reed moves by :func:`reed_accelerations` (even with one mode)."""
        return (self.dynamics or "one-mode") != "one-mode"

    def tail(self, oil):
        """The modal or FE reed's matrices for :func:`reed_accelerations` (lumped.reed.structure.tail)."""
        if (self.dynamics or "one-mode") == "one-mode":
            return None
        from lumped.reed.structure import tail

        return tail(self, oil.density)

    # ---- derived quantities
    @property
    def damping(self) -> float:
        """c [Pa s/m]: c_c + c_f (eq 3.81; c_f = 0 with fluid damping off)."""
        return self.internal_damping + self.fluid_damping_coefficient

    @property
    def multiplier_zero(self) -> float:
        """Tip opening where eq 3.83 first reaches 0 [m]; X = 0 beyond (docs/errata.md)."""
        return -self.multiplier_n0 / self.multiplier_n1

    def modal_mass(self, density: float) -> float:
        """rho_c h_eff (+ gamma3 rho W2 pi/4 Gamma_f with added mass) [kg/m^2] (eq 3.21)."""
        return (self.density * self.effective_thickness
                + self.gamma3 * density * self.width_tip * math.pi / 4 * self.hydrodynamic_function)

    def critical_mass(self) -> tuple[float, float]:
        """(rho_c h_eff [kg/m^2], gamma1): the modal equation 3.21, M x'' + gamma1 (c x' + k x) = F, in
        vacuum; its contacts left without their damping are critical for it (eq 2.23)."""
        return self.density * self.effective_thickness, self.gamma1

    def natural_frequency(self) -> float:
        """Undamped tip frequency in vacuum sqrt(gamma1 kappa / (rho_c h_eff)) [rad/s] (eq 3.21)."""
        return math.sqrt(self.gamma1 * self.stiffness / (self.density * self.effective_thickness))

    def damping_ratios(self) -> dict:
        """Damping ratios of the free reed (c = c_c + c_f against kappa) and of its seat and stop contacts, each
        against the critical damping of eq 3.21's modal equation (:meth:`critical_mass`, eq 2.23)."""
        m, g1 = self.critical_mass()
        return {"structure": self.damping / critical_damping(self.stiffness, m, g1), **super().damping_ratios()}

    def common(self, oil) -> Common:
        """The quantities every kind shares (lumped.valves.kind.Common), per unit area (eqs 3.21, 3.23-3.26, 3.89)."""
        return Common(
            moving_mass=self.modal_mass(oil.density if oil is not None else 0.0), stop_gap=self.stop_gap,
            seat_k=self.seat_stiffness, seat_c=self.seat_damping_value, stop_k=self.stop_stiffness,
            stop_c=self.stop_damping_value, area_1=self.area_min, area_2=self.area_max, f_closing=self.f1,
            f_opening=self.f2, cd_inf=self.cd_inf, cd_a=self.cd_a, cd_b=self.cd_b, cd_c=self.cd_c,
            cd_lift_exponent=self.cd_lift_exponent or 0.0, perimeter=self.orifice_perimeter,
            average_density=self.orifice_density == "average",
            area_per_opening=self.orifice_length,                                      # eq 3.25: A_o / x
            regime_opening=None,           # no pressure-regime switch: X(x) covers both regimes
            contact_area=1.0)              # eq 3.21 is per unit area

    def packed_extra(self, oil=None) -> dict:
        """The reed's own derived packed quantities (DERIVED)."""
        from lumped.reed.structure import DYNAMICS, n_stations

        dyn = self.dynamics or "one-mode"
        return {"drag_term": 0.5 * self.gamma2 * self.drag_coefficient if self.drag else 0.0,
                "damping_total": self.damping, "x_zero": self.multiplier_zero,
                "dynamics_code": float(DYNAMICS.index(dyn)),
                "n_stations": float(n_stations(self, oil.density)) if dyn != "one-mode" else 0.0,
                "drag_half_cd": 0.5 * self.drag_coefficient if self.drag else 0.0}

    def describe(self) -> dict:
        """What ``valvelab model check`` reports of a reed: its structural parameters and where they come from,
        and beyond one mode the modes kept (frequencies in vacuum [rad/s], names)."""
        out = {"reed_parameters": {"source": self.source, "kappa": self.stiffness, "gamma1": self.gamma1,
                                   "gamma2": self.gamma2, "gamma3": self.gamma3, "h_eff": self.effective_thickness,
                                   "geometry": self.geometry, "fidelity": self.fidelity}}
        dyn = self.dynamics or "one-mode"
        if dyn != "one-mode":
            from lumped.reed.structure import structure

            s = structure(self, 1.0)
            out["dynamics"] = {"kind": dyn, "dofs": s.n, "frequencies_rad_s": [float(w) for w in s.frequencies[:6]],
                               "modes": list(s.kinds[:6]) if dyn == "modal" else None}
        return out

    def validity(self, oil=None):
        """The reed's validity envelope (lumped.validity.Envelope): it rests at x_0 (eq 3.21), lifts off at
        kappa (-x_0) / X(0) when pressed on its seat, X(x) of eq 3.83 holds up to where it falls to 0 (the fit's
        end, docs/errata.md) and, with a geometry, small-deflection beam theory (eq 3.8) up to a tip deflection
        of 10 % of the length (the elastica's tip deflection under a tip load is then 1.0 % below the linear one)."""
        from lumped.validity import Limit

        env = super().validity(oil)
        x0 = self.preload
        x_at_seat = pressure_load_multiplier(0.0, self.multiplier_poiseuille, self.multiplier_n1, self.multiplier_n0,
                                             self.multiplier_d2, self.multiplier_d1, self.multiplier_d0,
                                             self.multiplier_zero)
        crack = 0.0 if x0 >= 0.0 else (self.stiffness * -x0 / x_at_seat if x_at_seat > 0.0 else math.inf)
        limits = [Limit("multiplier_range", "peak_opening", self.multiplier_zero,
                        f"the {self.multiplier_zero * 1e3:.3g} mm where X(x) of eq 3.83 falls to 0: beyond the "
                        "openings it was fitted to")]
        if self.fluid_opening_max > 0.0:
            limits.append(Limit("fluid_range", "peak_opening", self.fluid_opening_max,
                                f"the {self.fluid_opening_max * 1e3:.3g} mm its predicted fluid forms were computed "
                                "up to (fluid = \"predicted\": X(x) and Cd beyond it are extrapolated)"))
        if self.fluid_reynolds_max > 0.0:
            limits.append(Limit("fluid_range", "max_reynolds", self.fluid_reynolds_max,
                                f"the Re = {self.fluid_reynolds_max:.3g} its predicted fluid forms were computed "
                                "up to (fluid = \"predicted\": Cd(Re) beyond it is extrapolated)"))
        if self.reed is not None:
            length = self.reed.length
            limits.append(Limit("beam_deflection", "deflection", 0.1 * length,
                                f"10 % of its {length * 1e3:.3g} mm length (small-deflection beam theory, eq 3.8)"))
        return replace(env, rest_opening=x0, rest_key="seat.preload", cracking_pressure=crack,
                       limits=env.limits + tuple(limits))


def _keys(cls):
    from geometry.declare import specs
    return [(n, s.key) for n, s in specs(cls) if s.key is not None]


def _has(table: dict, dotted: str) -> bool:
    d = table
    for part in dotted.split("."):
        if not isinstance(d, dict) or part not in d:
            return False
        d = d[part]
    return True


def _reed_from(geo, field: str) -> Reed:
    """A Reed from a preset name, a reed TOML path or an inline table of the [reed] schema."""
    from geometry.reed_io import load_reed, parse_reed

    if isinstance(geo, dict):
        try:
            return parse_reed({"reed": geo}, source="inline")
        except InputError as exc:      # name the key path in the model file
            inner = exc.field[len("reed"):] if exc.field.startswith("reed") else f".{exc.field}"
            raise InputError(f"{field}{inner}", exc.message) from None
    if not isinstance(geo, str):
        raise InputError(field, f"expected a reed preset, a reed TOML file or a table, got {geo!r}")
    try:
        return load_reed(geo)
    except InputError as exc:
        raise InputError(field, f"{exc.field}: {exc.message}" if exc.field != geo else exc.message) from None


#: offsets of the reed's packed quantities (common, packed fields, then its derived ones)
REED = kind_block(ReedValve)


def pressure_load_multiplier(x: float, plateau: float, n1: float, n0: float, d2: float, d1: float,
                             d0: float, x_zero: float) -> float:
    """Pressure load multiplier X(x) of the reed: the fraction of dP that loads it at tip opening x (eq 3.83),
    max(0, min(plateau, (n1 x + n0) / (x^3 + d2 x^2 + d1 x + d0))), and 0 from x_zero = -n0/n1 on.

    The printed rational function has a pole near 1.651 mm and turns back up to the 0.835 cap above it,
    which the measurements of Figure 3.24 do not show: X is held at 0 beyond its first zero (docs/errata.md).

    Parameters
    ----------
    x : float
        Tip opening [m].
    plateau : float
        The cap at small openings [-] (Table 3.12).
    n1, n0, d2, d1, d0 : float
        The fit's coefficients, x in m.
    x_zero : float
        -n0/n1 [m].

    Returns
    -------
    float
        X [-].

    References
    ----------
    Knutson (2016), eq 3.83, Table 3.12, Figure 3.24.

    Examples
    --------
    The prototype's fit (thesis-reed.toml): the 0.835 plateau, and 0 from 1.369 mm on:

    >>> fit = (0.835, -52.28, 0.07158, 0.8145, -50.23, 0.08292, 0.07158 / 52.28)
    >>> pressure_load_multiplier(0.0, *fit), round(pressure_load_multiplier(1e-3, *fit), 3)
    (0.835, 0.59)
    >>> pressure_load_multiplier(1.37e-3, *fit)
    0.0
    """
    if x >= x_zero:
        return 0.0
    r = (n1 * x + n0) / (((x + d2) * x + d1) * x + d0)
    if r > plateau:
        return plateau
    if r < 0.0:
        return 0.0
    return r


def pressure_load_multiplier_slope(x: float, plateau: float, n1: float, n0: float, d2: float, d1: float,
                                   d0: float, x_zero: float) -> float:
    """Slope dX/dx of :func:`pressure_load_multiplier` (eq 3.83 differentiated), 0 where X is held at its
    plateau or at 0.

    Parameters
    ----------
    x, plateau, n1, n0, d2, d1, d0, x_zero : float
        As :func:`pressure_load_multiplier`.

    Returns
    -------
    float
        dX/dx [1/m].
    """
    if x >= x_zero:
        return 0.0
    den = ((x + d2) * x + d1) * x + d0
    num = n1 * x + n0
    r = num / den
    if r > plateau or r < 0.0:
        return 0.0
    return (n1 * den - num * ((3.0 * x + 2.0 * d2) * x + d1)) / (den * den)


def packed_multiplier(x: float, p, o: int) -> float:
    """X(x) of eq 3.83 (:func:`pressure_load_multiplier`) with the fit packed in the reed's block.

    Parameters
    ----------
    x : float
        Tip opening [m].
    p : array of float
        The flat parameter array; ``o`` the reed's block offset.

    Returns
    -------
    float
        X [-].
    """
    return pressure_load_multiplier(x, p[o + REED.multiplier_poiseuille], p[o + REED.multiplier_n1],
                                    p[o + REED.multiplier_n0], p[o + REED.multiplier_d2], p[o + REED.multiplier_d1],
                                    p[o + REED.multiplier_d0], p[o + REED.x_zero])


def packed_multiplier_slope(x: float, p, o: int) -> float:
    """dX/dx of eq 3.83 (:func:`pressure_load_multiplier_slope`) with the fit packed in the reed's block.

    Parameters
    ----------
    x : float
        Tip opening [m].
    p : array of float
        The flat parameter array; ``o`` the reed's block offset.

    Returns
    -------
    float
        dX/dx [1/m].
    """
    return pressure_load_multiplier_slope(x, p[o + REED.multiplier_poiseuille], p[o + REED.multiplier_n1],
                                          p[o + REED.multiplier_n0], p[o + REED.multiplier_d2],
                                          p[o + REED.multiplier_d1], p[o + REED.multiplier_d0], p[o + REED.x_zero])


def reed_acceleration(x: float, u: float, f, p, o: int, contact: int, regime: int) -> float:
    """Tip acceleration of the one-mode reed from eq 3.21 (per unit area):
    M x'' = gamma1 (dP X(x) - c x' - kappa (x - x0) + F_c) - gamma2 rho |x'| x' C_D / 2.

    Parameters
    ----------
    x, u : float
        Tip opening [m] and its rate [m/s].
    f : lumped.valves.common.ValveInputs
        What the pump gives the valve (dp, rho used).
    p : array of float
        The flat parameter array; ``o`` the reed's block offset (:data:`REED`).
    contact, regime : int
        The valve's mode (contact state; the reed has no regime switch).

    Returns
    -------
    float
        x'' [m/s^2].

    References
    ----------
    Knutson (2016), eq 3.21 (the drag as |x'| x': docs/errata.md), eq 3.83; valvelab's contact (eq 2.20 per
    unit area).
    """
    g1 = p[o + REED.gamma1]
    X = packed_multiplier(x, p, o)
    force = g1 * (f.dp * X - p[o + REED.damping_total] * u - p[o + REED.stiffness] * (x - p[o + REED.preload]))
    force += g1 * contact_reaction(x, u, p, o, contact)
    force -= p[o + REED.drag_term] * f.rho * abs(u) * u
    return force / p[o + REED.moving_mass]


#: True in the compiled physics (lumped.solver.compiled sets it, numba folds it): loops there, numpy in the Python
#: reference (an FE reed's matrices are ~50 x 50)
COMPILED = False


def reed_accelerations(y, s: int, n: int, x: float, u: float, f, p, o: int, contact: int, regime: int,
                       dydt) -> None:
    """Accelerations q'' of the modal or FE reed (lumped.reed.structure):
    M q'' + C q' + K (q - q0) = b [dP X(x) + F_c(x, x')] - Q_drag.

    A = M^-1 K, B = M^-1 C, g = M^-1 b are packed in the tail; X of eq 3.83 and the seat and stop of eq 2.20
    (per unit area) act at the port's opening x = e . q, the drag of eq 3.21 on the width-mean rate of each
    strip.

    Parameters
    ----------
    y : array of float
        The pump's state; the reed's coordinates q [m] at ``y[s:s + n]``, rates at ``y[s + n:s + 2n]``.
    s, n : int
        First state index, number of coordinates.
    x, u : float
        The opening [m] and its rate [m/s].
    f : lumped.valves.common.ValveInputs
        What the pump gives the valve.
    p : array of float
        The flat parameter array; ``o`` the reed's block offset.
    contact, regime : int
        The valve's mode.
    dydt : array of float
        Written: q'' [m/s^2] at ``dydt[s + n:s + 2n]``.

    References
    ----------
    Knutson (2016), eqs 3.21, 3.83; docs/reed_dynamics.md.
    """
    w = int(p[o + REED.tail])
    g, q0 = w + n, w + 2 * n
    a_m = w + 3 * n
    b_m = a_m + n * n
    r = s + n                                  # its rates, and where their derivatives go
    load = f.dp * packed_multiplier(x, p, o)
    load += contact_reaction(x, u, p, o, contact)
    if COMPILED:
        for i in range(n):
            acc = p[g + i] * load
            for j in range(n):
                acc -= p[a_m + i * n + j] * (y[s + j] - p[q0 + j]) + p[b_m + i * n + j] * y[r + j]
            dydt[r + i] = acc
    else:
        # the same in numpy: the reference stepper's Python physics (an FE reed has ~50 DOFs)
        pa = np.asarray(p)
        q, v = np.asarray(y[s:r]), np.asarray(y[r:r + n])
        dydt[r:r + n] = pa[g:g + n] * load - pa[a_m:b_m].reshape(n, n) @ (q - pa[q0:q0 + n]) \
            - pa[b_m:b_m + n * n].reshape(n, n) @ v
    half_cd = p[o + REED.drag_half_cd]
    if half_cd > 0.0:
        k_st = int(p[o + REED.n_stations])
        d_m = b_m + n * n
        r_m = d_m + n * k_st
        for k in range(k_st):
            vk = strip_rate(p, y, r_m, r, n, k)
            drag = half_cd * f.rho * abs(vk) * vk
            for i in range(n):
                dydt[r + i] -= p[d_m + i * k_st + k] * drag


def strip_rate(p, y, r_m: int, r: int, n: int, k: int) -> float:
    """Width-mean rate wbar'_k = W_k . q' of the reed's strip k: the velocity eq 3.21's quadratic drag acts on.

    Parameters
    ----------
    p, y : array of float
        The flat parameter array (W at ``p[r_m:]``, lumped.reed.structure.tail) and the state (the modal
        rates at ``y[r:r + n]``).
    r_m, r, n, k : int
        Offset of W, of the rates, their number, the strip.

    Returns
    -------
    float
        wbar'_k [m/s].
    """
    vk = 0.0
    for j in range(n):
        vk += p[r_m + k * n + j] * y[r + j]
    return vk


def reed_accelerations_jacobian(y, s: int, n: int, x: float, u: float, f, p, o: int, contact: int, regime: int,
                                jac) -> None:
    """The partials of :func:`reed_accelerations` by the reed's positions q and rates q' into the pump's Jacobian:
    dq''/dq = g L_x e^T - A, dq''/dq' = g L_u e^T - B - D diag(C_D rho |wbar'_k|) W.

    L(x, u) = dP X(x) + F_c(x, u), the load on the opening x = e . q; wbar'_k = W_k . q' the strips' width-mean
    rates (lumped.reed.structure.tail's D, W). Exact: the accelerations are linear in q and q' but for L and the
    drag.

    Parameters
    ----------
    y, s, n, x, u, f, p, o, contact, regime
        As :func:`reed_accelerations`.
    jac : array of float
        Written: rows s + n.., columns s.. [1/s^2] and s + n.. [1/s].

    Returns
    -------
    None

    References
    ----------
    Knutson (2016), eqs 2.20, 3.21, 3.83.
    """
    w = int(p[o + REED.tail])
    g, a_m = w + n, w + 3 * n
    b_m = a_m + n * n
    fx, fu = contact_slopes(x, p, o, contact)
    lx = fx + f.dp * packed_multiplier_slope(x, p, o)
    r = s + n
    for i in range(n):
        gi = p[g + i]
        for j in range(n):
            ej = p[w + j]
            jac[r + i, s + j] = gi * lx * ej - p[a_m + i * n + j]
            jac[r + i, r + j] = gi * fu * ej - p[b_m + i * n + j]
    half_cd = p[o + REED.drag_half_cd]
    if half_cd > 0.0:
        k_st = int(p[o + REED.n_stations])
        d_m = b_m + n * n
        r_m = d_m + n * k_st
        for k in range(k_st):
            vk = strip_rate(p, y, r_m, r, n, k)
            c = 2.0 * half_cd * f.rho * abs(vk)             # d(|v| v)/dv = 2 |v|
            for i in range(n):
                dik = p[d_m + i * k_st + k] * c
                for j in range(n):
                    jac[r + i, r + j] -= dik * p[r_m + k * n + j]


KIND = register(ValveKind(
    name="reed", default_model="thesis-reed", params=ReedValve, acceleration=reed_acceleration, block=REED,
    accelerations=reed_accelerations, accelerations_jacobian=reed_accelerations_jacobian,
    # the fast path's tolerances (docs/models.md, "The fast path's tolerances"): a reed lifts off its seat at
    # near-zero speed, the most sensitive timing, so its velocity in contact keeps the kinds' default; its
    # stop rebounds are a few hundred nanometres deep, so its opening in contact is held tighter
    contact_velocity_atol=1.0,
    contact_position_atol=3.0,
    # designs the fast path is checked on (lumped.model.random_designs): stiffness and the
    # displacement factors of section 5.5.3
    design_ranges={"flow.f1": (0.1, 0.4), "flow.f2": (0.2, 0.5), "structure.stiffness": (5e6, 1e7)},
    summary="cantilevered reed over a slotted seat, single-mode tip model (thesis chapter 3)",
))
