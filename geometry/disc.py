"""Disc check valve geometry (thesis chapter 2): disc, port, stop gap and spring."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from importlib import resources


@dataclass(frozen=True)
class DiscValveGeometry:
    """Disc valve dimensions, SI units (Tables 2.2, 2.3)."""

    inner_radius: float          # R_i [m]
    outer_radius: float          # R_o [m]
    bevel_angle: float           # theta [rad]
    port_diameter: float         # d_port [m]
    port_length: float           # L [m]
    stop_inlet: float            # x_stop of the inlet valve [m]
    stop_delivery: float         # x_stop of the delivery valve [m]
    wire_diameter: float         # spring d [m]
    coil_diameter: float         # spring D [m]
    shear_modulus: float         # spring G [Pa]
    active_coils: float          # spring N_a
    spring_preload: float        # x_pre [m]

    @property
    def disc_area(self) -> float:
        """A_disc = pi R_o^2 [m^2] (Table 2.3: 177 mm^2)."""
        return disc_area(self.outer_radius)

    @property
    def port_area(self) -> float:
        """A_port = pi d_port^2 / 4 [m^2] (Table 2.3: A_1 = 86.3 mm^2)."""
        return port_area(self.port_diameter)


def disc_area(outer_radius: float) -> float:
    """Face area of the disc A_disc = pi R_o^2 [m^2] (Table 2.3)."""
    return math.pi * outer_radius**2


def port_area(port_diameter: float) -> float:
    """Area of the seat's port A_port = A_1 = pi d_port^2 / 4 [m^2] (eq 2.42, Table 2.3)."""
    return math.pi * port_diameter**2 / 4


def load_disc_geometry() -> DiscValveGeometry:
    """The thesis disc valve from ``geometry/data/disc_valve.toml``."""
    d = tomllib.loads(resources.files("geometry").joinpath("data/disc_valve.toml").read_text())
    disc, stop, spring = d["disc"], d["stop"], d["spring"]
    return DiscValveGeometry(
        inner_radius=disc["inner_radius"],
        outer_radius=disc["outer_radius"],
        bevel_angle=math.radians(disc["bevel_angle_deg"]),
        port_diameter=disc["port_diameter"],
        port_length=disc["port_length"],
        stop_inlet=stop["inlet"],
        stop_delivery=stop["delivery"],
        wire_diameter=spring["wire_diameter"],
        coil_diameter=spring["coil_diameter"],
        shear_modulus=spring["shear_modulus"],
        active_coils=spring["active_coils"],
        spring_preload=spring["preload"],
    )
