"""What every fluid fidelity takes and returns: the valve with its oil, and one operating point.

A fidelity is a function ``(valve, lift, reynolds, options) -> FlowPoint``: ``valve`` a
:class:`FluidValve` (a valve of a pump model with that model's oil), ``lift`` the opening x [m]
(the reed's tip opening), ``reynolds`` the Reynolds number in the thesis's definition for the
kind (eq 2.46 for the disc: Re = 4 rho Q / (mu p), p the orifice perimeter), ``options`` a
mapping of the fidelity's settings. The keys of :class:`FlowPoint` are those of ``valvelab flow
--json`` (CONTRACT.md, "Fluid references").
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields

from geometry.errors import InputError


@dataclass(frozen=True)
class FluidValve:
    """A valve (``params``: the model's ``lumped`` parameter object) with the oil it runs in."""

    name: str
    kind: str
    position: str
    params: object
    density: float          # kg/m^3
    viscosity: float        # Pa s
    vapour_pressure: float  # Pa, absolute

    @property
    def perimeter(self) -> float:
        """Orifice perimeter p [m] of eq 2.46 (disc: perimeter_factor pi d_port, section 2.4.5)."""
        v = self.params
        return v.perimeter_factor * math.pi * v.port_diameter

    def flow_of(self, reynolds: float) -> float:
        """Q [m^3/s] of a Reynolds number by eq 2.46: Q = Re mu p / (4 rho)."""
        return reynolds * self.viscosity * self.perimeter / (4.0 * self.density)

    def orifice_area(self, lift: float) -> float:
        """A_o = pi d_port sin(theta) x [m^2] (eq 2.40)."""
        v = self.params
        return math.pi * v.port_diameter * math.sin(v.bevel_angle) * lift

    @property
    def face_area(self) -> float:
        """The area the force coefficient refers to [m^2]: the disc's face pi R_o^2."""
        return math.pi * self.params.outer_radius**2


@dataclass(frozen=True)
class FlowPoint:
    """One operating point of one fidelity (SI units; the ``valvelab flow`` JSON keys).

    ``flow`` [m^3/s] through the orifice, ``dp`` [Pa] across the valve, ``cd`` by eq 2.44 with
    A_o of eq 2.40, ``force`` [N] of the fluid on the moving part (positive opening),
    ``force_coefficient`` = force / (dp A_face), ``flow_force`` [N] the steady flow force of eq
    2.36 (None where the fidelity has no inertia), ``pressure_load_multiplier`` the reed's X of
    eq 3.49 (None for a disc), ``u_num`` {output: standard numerical uncertainty} where a mesh
    ladder ran. ``extra`` holds a fidelity's further outputs (``jet_angle`` [rad], ``film``,
    ``displacement``, ``mesh``).
    """

    lift: float
    reynolds: float
    flow: float
    dp: float
    cd: float
    force: float
    force_coefficient: float
    flow_force: float | None = None
    pressure_load_multiplier: float | None = None
    u_num: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        """The point's JSON object: the CONTRACT keys, then the extras."""
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "extra"}
        return {**d, "u_num": dict(self.u_num), **self.extra}


def check_valve(valve, field: str = "valve") -> "FluidValve":
    """``valve`` if it is a :class:`FluidValve` (or ``MODEL[:POSITION]``, loaded), else InputError naming ``field``."""
    if isinstance(valve, str):
        return load_fluid_valve(valve, field)
    if not isinstance(valve, FluidValve):
        raise InputError(field, f"expected a fea.fluid.FluidValve (load_fluid_valve('thesis-disc:inlet')) or "
                                f"'MODEL[:POSITION]', got {type(valve).__name__} {valve!r}")
    return valve


def check_reynolds(reynolds: float, field: str = "reynolds") -> float:
    """Re if finite and > 0, else InputError naming ``field``."""
    if isinstance(reynolds, bool) or not (isinstance(reynolds, (int, float)) and math.isfinite(reynolds)
                                          and reynolds > 0):
        raise InputError(field, f"the Reynolds number must be a positive number, got {reynolds!r}")
    return float(reynolds)


def check_lift(valve: FluidValve, lift: float, field: str = "lift") -> float:
    """The lift [m] if 0 < lift <= the valve's stop gap, else InputError naming ``field``."""
    stop = check_valve(valve).params.stop_gap
    if isinstance(lift, bool) or not isinstance(lift, (int, float)):
        raise InputError(field, f"expected a lift in m (a number), got {lift!r}")
    if not (math.isfinite(lift) and 0.0 < lift <= stop * (1 + 1e-9)):
        raise InputError(field, f"the lift must lie in (0, {stop * 1e3:.4g}] mm (the stop of the "
                         f"{valve.position} valve), got {lift * 1e3:.4g} mm")
    return float(lift)


def parse_valve(spec: str, field: str = "spec") -> tuple[str, str]:
    """(model, position) of ``MODEL[:POSITION]`` (position inlet by default)."""
    model, sep, position = str(spec).rpartition(":")
    if not sep:
        model, position = position, "inlet"
    if position not in ("inlet", "delivery"):
        raise InputError(field, f"expected MODEL:inlet or MODEL:delivery, got {spec!r}")
    return model, position


def load_fluid_valve(spec, field: str = "spec") -> FluidValve:
    """The valve ``MODEL[:POSITION]`` (a shipped model name or a model file) with its model's oil."""
    from lumped import load_model
    from lumped.valves.kind import kind_of

    if isinstance(spec, FluidValve):
        return spec
    if not isinstance(spec, (str, os.PathLike)) or not str(spec).strip():
        raise InputError(field, f"expected 'MODEL[:POSITION]' (a shipped model or a model file), got {spec!r}")
    model_spec, position = parse_valve(spec, field)
    model = load_model(model_spec, field=field)
    params = model.valve(position)
    oil = model.oil
    return FluidValve(name=f"{model.name}:{position}", kind=kind_of(params).name, position=position, params=params,
                      density=oil.density, viscosity=oil.viscosity, vapour_pressure=oil.vapour_pressure)
