"""Seat ring and housing stop of the disc valve; the slotted seat of the reed valve.

The thesis gives these parts only in figures, so ``geometry/data/seat_stop.toml`` holds
valvelab's documented, plausible dimensions (consistent with ``disc_valve.toml``).
SI units; all solids are axisymmetric about z except the housing's flow windows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from geometry.data_files import package_toml
from geometry.reed import Material


@dataclass(frozen=True)
class SeatRing:
    """Steel seat ring: bore (the port), countersunk seating cone, flat top; z up from its base [m]."""

    bore_radius: float
    bore_length: float
    outer_radius: float
    cone_outer_radius: float
    bevel_angle: float      # rad, cone half-angle
    load: float             # N
    material: Material

    @property
    def cone_height(self) -> float:
        """Axial rise of the seating cone [m]: (R_o - R_bore) / tan(theta)."""
        return (self.cone_outer_radius - self.bore_radius) / math.tan(self.bevel_angle)

    @property
    def height(self) -> float:
        return self.bore_length + self.cone_height


@dataclass(frozen=True)
class HousingStop:
    """ABS housing: a cylindrical wall with flow windows under an end wall that stops the disc [m]."""

    outer_radius: float
    inner_radius: float
    wall_height: float
    end_thickness: float
    hole_radius: float
    windows: int
    window_width: float
    window_height: float
    window_base: float
    contact_inner_radius: float
    contact_outer_radius: float
    load: float
    material: Material


@dataclass(frozen=True)
class ReedSeat:
    """Slots of the reed valve seat under the reed (s from the clamp, y across) [m], and the reverse load [Pa]."""

    slot_width: float
    slot_pitch: float
    slots: int
    slot_start: float
    slot_end: float
    reverse_pressure: float

    def slot_centres(self) -> list[float]:
        return [(k - (self.slots - 1) / 2) * self.slot_pitch for k in range(self.slots)]

    def in_slot(self, s, y):
        """True where (s, y) lies over a slot (vectorised)."""
        import numpy as np

        s, y = np.asarray(s, float), np.asarray(y, float)
        inside = np.zeros(np.broadcast(s, y).shape, bool)
        for yc in self.slot_centres():
            inside |= (s >= self.slot_start) & (s <= self.slot_end) & (np.abs(y - yc) <= self.slot_width / 2)
        return inside


def _data() -> dict:
    return package_toml("geometry", "seat_stop.toml")


def _material(d: dict) -> Material:
    return Material(youngs_modulus=d["youngs_modulus"], density=d["density"], poisson_ratio=d["poisson_ratio"])


def load_seat_ring() -> SeatRing:
    """The disc valve's seat ring (``seat_stop.toml`` [seat]).

    Returns
    -------
    SeatRing
        SI units.
    """
    d = _data()["seat"]
    return SeatRing(d["bore_radius"], d["bore_length"], d["outer_radius"], d["cone_outer_radius"],
                    math.radians(d["bevel_angle_deg"]), d["load"], _material(d["material"]))


def load_housing_stop() -> HousingStop:
    """The disc valve's housing with its stop (``seat_stop.toml`` [stop]).

    Returns
    -------
    HousingStop
        SI units.
    """
    d = _data()["stop"]
    return HousingStop(d["outer_radius"], d["inner_radius"], d["wall_height"], d["end_thickness"],
                       d["hole_radius"], int(d["windows"]), d["window_width"], d["window_height"],
                       d["window_base"], d["contact_inner_radius"], d["contact_outer_radius"],
                       d["load"], _material(d["material"]))


def load_reed_seat() -> ReedSeat:
    """The reed valve's slotted seat (``seat_stop.toml`` [reed_seat]).

    Returns
    -------
    ReedSeat
        SI units.
    """
    d = _data()["reed_seat"]
    return ReedSeat(d["slot_width"], d["slot_pitch"], int(d["slots"]), d["slot_start"], d["slot_end"],
                    d["reverse_pressure"])
