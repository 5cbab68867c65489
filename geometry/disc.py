"""Disc check valve geometry (thesis chapter 2): disc, seat, port, stop gaps and spring.

One description of the part, used by the lumped model (``lumped.valves.disc``), the
seat/stop FEA and the thesis tables. The thesis valve is the preset ``thesis``
(``geometry/data/disc_valve.toml``); a user's valve is a TOML file of the same schema::

    [disc]
    inner_radius = 5.24e-3      # m, R_i: seat contact starts here
    outer_radius = 7.50e-3      # m, R_o = d_disc / 2
    bevel_angle_deg = 54.0      # deg, seat bevel theta
    port_diameter = 10.48e-3    # m
    port_length = 5.2e-3        # m, control-volume length of eq 2.31
    [stop]                      # maximum opening x_stop of each position
    inlet = 1.19e-3
    delivery = 1.01e-3
    [spring]
    wire_diameter = 0.61e-3     # m (optional: for eq 2.43 only)
    coil_diameter = 9.9e-3      # m (optional)
    shear_modulus = 80.0e9      # Pa (optional)
    active_coils = 6.5          # (optional)
    preload = 6.2e-3            # m, compression when seated
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from .data_files import package_toml
from .declare import param, read_table
from .errors import InputError
from .validate import read_toml

#: disc geometry presets shipped in geometry/data
PRESETS = {"thesis": "disc_valve.toml"}


@dataclass(frozen=True)
class DiscValveGeometry:
    """Disc valve dimensions, SI units (Tables 2.2, 2.3)."""

    inner_radius: float = param("disc.inner_radius", "m", "R_i (section 2.4.2)", bounds=(1e-5, 1.0), positive=True)
    outer_radius: float = param("disc.outer_radius", "m", "R_o (Table 2.3)", bounds=(1e-5, 1.0), positive=True)
    bevel_angle_deg: float = param("disc.bevel_angle_deg", "deg", "theta (Table 2.3)", bounds=(0.5, 90.0))
    port_diameter: float = param("disc.port_diameter", "m", "d_port (Table 2.3)", bounds=(1e-5, 1.0), positive=True)
    port_length: float = param("disc.port_length", "m", "L of eq 2.31 (Table 2.3)", bounds=(0.0, 1.0))
    stop_inlet: float = param("stop.inlet", "m", "x_stop, inlet valve (Table 2.3)", bounds=(1e-7, 0.1), positive=True)
    stop_delivery: float = param("stop.delivery", "m", "x_stop, delivery valve (Table 2.3)", bounds=(1e-7, 0.1),
                                 positive=True)
    spring_preload: float = param("spring.preload", "m", "x_pre (Table 2.3)", bounds=(-0.1, 1.0))
    wire_diameter: float = param("spring.wire_diameter", "m", "spring d (Table 2.2)", bounds=(1e-6, 0.1),
                                 positive=True, optional=True)
    coil_diameter: float = param("spring.coil_diameter", "m", "spring D (Table 2.2)", bounds=(1e-5, 1.0),
                                 positive=True, optional=True)
    shear_modulus: float = param("spring.shear_modulus", "Pa", "spring G (Table 2.2)", bounds=(1e8, 1e12),
                                 positive=True, optional=True)
    active_coils: float = param("spring.active_coils", "-", "N_a (Table 2.2)", bounds=(0.5, 1000.0), optional=True)

    @property
    def bevel_angle(self) -> float:
        """theta [rad]."""
        return math.radians(self.bevel_angle_deg)

    @property
    def disc_area(self) -> float:
        """Face area of the disc, A_disc = pi R_o^2 (Table 2.3).

        Parameters
        ----------
        outer_radius : float
            R_o [m].

        Returns
        -------
        float
            [m^2].

        Examples
        --------
        >>> round(disc_area(7.50e-3) * 1e6)          # Table 2.3: A_2 = 177 mm^2
        177
        """
        return disc_area(self.outer_radius)

    @property
    def port_area(self) -> float:
        """Area of the seat's port, A_port = A_1 = pi d_port^2 / 4 (eq 2.42, Table 2.3).

        Parameters
        ----------
        port_diameter : float
            d_port [m].

        Returns
        -------
        float
            [m^2].

        Examples
        --------
        >>> round(port_area(10.48e-3) * 1e6, 1)      # Table 2.3: A_1 = 86.3 mm^2
        86.3
        """
        return port_area(self.port_diameter)


def disc_area(outer_radius: float) -> float:
    """Face area of the disc, A_disc = pi R_o^2 (Table 2.3).

    Parameters
    ----------
    outer_radius : float
        R_o [m].

    Returns
    -------
    float
        [m^2].

    Examples
    --------
    >>> round(disc_area(7.50e-3) * 1e6)          # Table 2.3: A_2 = 177 mm^2
    177
    """
    return math.pi * outer_radius**2


def port_area(port_diameter: float) -> float:
    """Area of the seat's port, A_port = A_1 = pi d_port^2 / 4 (eq 2.42, Table 2.3).

    Parameters
    ----------
    port_diameter : float
        d_port [m].

    Returns
    -------
    float
        [m^2].

    Examples
    --------
    >>> round(port_area(10.48e-3) * 1e6, 1)      # Table 2.3: A_1 = 86.3 mm^2
    86.3
    """
    return math.pi * port_diameter**2 / 4


def load_disc_geometry(spec: str | Path = "thesis", field: str = "geometry") -> DiscValveGeometry:
    """A disc valve geometry from a preset name or a TOML file.

    Parameters
    ----------
    spec : str or Path
        A preset (``thesis``) or a TOML file of the schema of geometry/data/disc_valve.toml.
    field : str
        The name a bad ``spec`` is reported under (InputError).

    Returns
    -------
    DiscValveGeometry
        (SI units).
    """
    name = str(spec)
    if name in PRESETS:
        data, where = package_toml("geometry", PRESETS[name]), name
    else:
        path = Path(name)
        if not path.exists():
            raise InputError(field, f"{name!r}: no such file; expected a disc geometry preset "
                                    f"({', '.join(PRESETS)}) or a TOML file")
        data, where = read_toml(path, field), path.name
    values = read_table(DiscValveGeometry, data, where, require=True)
    return DiscValveGeometry(**values)
