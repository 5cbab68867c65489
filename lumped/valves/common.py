"""What every valve kind shares as data: the common block of packed quantities, the contact and regime
codes, the inputs the pump hands each kind's acceleration, and :class:`Common`, the checked record of the
shared quantities a kind's parameters give.

The physics on these (contact reactions, the flow through any kind, the shared force terms) is in
:mod:`lumped.valves.forces`; the kind contract and the registry in :mod:`lumped.valves.kind`.

Contact state ``contact``: 0 seat (x < 0 side), 1 free, 2 stop (x > x_stop side), -1 decide from x. The
pump integrator fixes it per step and switches it only at a located crossing (``lumped.solver.switching``),
so the right-hand side is smooth in a step.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass, fields
from typing import ClassVar, NamedTuple

#: quantities every kind packs first, at these offsets of its block (lumped.solver.layout): the fields of
#: :class:`Common`, then the bookkeeping the layout writes
COMMON = (
    "kind_id",         # registry id of the kind
    "moving_mass",     # kg (disc, ball) or kg/m^2 (reed: per unit area, eq 3.21)
    "stop_gap",        # x_stop [m]
    "seat_k",          # seat contact stiffness, N/m or Pa/m
    "seat_c",          # seat contact damping, N s/m or Pa s/m
    "stop_k",          # stop contact stiffness
    "stop_c",          # stop contact damping
    "area_1",          # A_1 of the displacement area (eqs 2.42, 3.26) [m^2]
    "area_2",          # A_2 [m^2]
    "f_closing",       # f1 (u < 0)
    "f_opening",       # f2 (u > 0)
    "cd_inf",          # Cd(Re) correlation (eqs 2.47, 3.89)
    "cd_a",
    "cd_b",
    "cd_c",
    "cd_lift_exponent",  # k: Cd at the effective Re (x / x_stop)^k (0: independent of the opening)
    "perimeter",       # orifice perimeter of the Reynolds number [m]
    "average_density",  # 1: orifice density is the mean of both sides (section 4.3.5), 0: cylinder's
    "area_per_opening",  # A_o / x at small openings [m]
    "area_curvature",  # A_o = area_per_opening x + area_curvature x^2 (a ball in a cone) [-]
    "regime_opening",  # x of a pressure-regime switch (eq 2.18) [m]; <= 0: none
    "contact_area",    # area turning the contact force into a pressure load (disc face; reed 1)
    "flow_in_acceleration",  # 1 if the kind's acceleration reads the flow inputs (flow forces), else 0
    "orifice_start",   # scratch, not a parameter: sqrt(Re) of the last orifice solve (warm start)
    "dofs",            # mechanical degrees of freedom of the valve (its states: dofs positions, dofs rates)
    "state_start",     # index of its first state in the state vector (lumped.solver.layout)
    "tail",            # offset of its variable-length data in the flat array (0: none; lumped.solver.layout)
)
#: the offsets, as a namedtuple numba folds into constants: p[o + VALVE.stop_gap]
VALVE = collections.namedtuple("ValveBlock", COMMON)(*range(len(COMMON)))

SEAT, FREE, STOP = 0, 1, 2
POISEUILLE, ORIFICE = 0, 1
#: names of the contact states and pressure regimes (event records, reports)
CONTACT_NAMES = ("seat", "free", "stop")
REGIME_NAMES = ("poiseuille", "orifice")


class ValveInputs(NamedTuple):
    """What the pump gives a kind's acceleration at one instant (SI), besides x, u and the block.

    ``dp`` = P_up - P_down [Pa]; ``p_down`` [Pa]; ``p_vap`` the vapour pressure [Pa]; ``rho`` the
    density of the orifice equation [kg/m^3]; ``mu`` [Pa s]; ``q_o`` the orifice flow [m^3/s] and
    ``cd``, ``aq`` [m^2], ``dq_ddp`` [m^3/s/Pa], ``dq_dx`` [m^2/s] from :func:`lumped.valves.forces.valve_flow`;
    ``ddp_dt`` d(dp)/dt [Pa/s] (the transient flow force of eq 2.37). A kind reads what it needs.
    """

    dp: float
    p_down: float
    p_vap: float
    rho: float
    mu: float
    q_o: float
    cd: float
    aq: float
    dq_ddp: float
    dq_dx: float
    ddp_dt: float


# --------------------------------------------------------------------------- the shared quantities
@dataclass(frozen=True)
class Common:
    """The quantities every valve kind shares (SI units), checked when built.

    ``moving_mass`` [kg, or kg/m^2 per unit area]; ``stop_gap`` x_stop [m]; ``seat_k``, ``seat_c``,
    ``stop_k``, ``stop_c`` the contact stiffness and damping of eq 2.20 (N/m, N s/m; per unit area
    for the reed: Pa/m, Pa s/m); ``area_1``, ``area_2``, ``f_closing``, ``f_opening`` the fluid
    displacement area of eqs 2.42, 3.26; ``cd_inf``, ``cd_a``, ``cd_b``, ``cd_c`` the Cd(Re)
    correlation of eqs 2.47, 3.89; ``perimeter`` [m] of its Reynolds number; ``average_density``
    (section 4.3.5); ``area_per_opening`` A_o / x [m] and ``area_curvature`` [-], the orifice area
    A_o = area_per_opening x + area_curvature x^2; ``cd_lift_exponent`` k [-]: Cd(Re) is taken at
    the effective Reynolds number Re (x / x_stop)^k (0: Cd independent of the opening, eqs 2.47, 3.89); ``regime_opening`` [m] of a pressure-regime
    switch (eq 2.18; None: none); ``contact_area`` [m^2] that turns a contact force into a
    pressure load (1 for a per-unit-area kind); ``flow_in_acceleration``: the acceleration reads
    the flow inputs (then the Jacobian recomputes the flow at each perturbation).
    """

    moving_mass: float
    stop_gap: float
    seat_k: float
    seat_c: float
    stop_k: float
    stop_c: float
    area_1: float
    area_2: float
    f_closing: float
    f_opening: float
    cd_inf: float
    cd_a: float
    cd_b: float
    cd_c: float
    perimeter: float
    area_per_opening: float
    contact_area: float
    average_density: bool = False
    regime_opening: float | None = None
    flow_in_acceleration: bool = False
    area_curvature: float = 0.0
    cd_lift_exponent: float = 0.0

    #: fields that must be > 0 and those that must be >= 0
    POSITIVE: ClassVar[tuple] = ("moving_mass", "stop_gap", "seat_k", "stop_k", "perimeter", "area_per_opening",
                                 "contact_area", "cd_inf")
    NON_NEGATIVE: ClassVar[tuple] = ("seat_c", "stop_c", "area_1", "area_2", "f_closing", "f_opening")

    def __post_init__(self):
        for name in _COMMON_FIELDS:
            v = getattr(self, name)
            if isinstance(v, bool) or (v is None and name == "regime_opening"):
                continue
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"Common.{name}: expected a finite number, got {v!r}")
            if name in self.POSITIVE and not v > 0:
                raise ValueError(f"Common.{name}: must be positive, got {v!r}")
            if name in self.NON_NEGATIVE and v < 0:
                raise ValueError(f"Common.{name}: must not be negative, got {v!r}")
        if self.regime_opening is not None and not self.regime_opening > 0:
            raise ValueError(f"Common.regime_opening: must be positive or None, got {self.regime_opening!r}")
        if self.area_1 > self.area_2:
            raise ValueError(f"Common.area_1 ({self.area_1:g}) exceeds area_2 ({self.area_2:g})")
        # A_o = k x + k2 x^2 must grow with the opening up to the stop (its sign does not matter: Merritt's
        # conical poppet, A_o = pi x sin(a) (d - x sin(a) cos(a)) (Merritt 1967, section 3.5), has k2 < 0 and
        # grows over its lift)
        slope = self.area_per_opening + 2.0 * self.area_curvature * self.stop_gap
        if not slope > 0:
            raise ValueError(f"Common.area_curvature: the orifice area A_o = area_per_opening x + area_curvature x^2 "
                             f"must grow with the opening up to the stop gap {self.stop_gap:g} m; dA_o/dx there is "
                             f"{slope:g} m (area_per_opening {self.area_per_opening:g} m, area_curvature "
                             f"{self.area_curvature:g})")

    def packed(self) -> dict:
        """{COMMON name: float} as the flat array holds them."""
        out = {}
        for name in _COMMON_FIELDS:
            v = getattr(self, name)
            out[name] = (-1.0 if v is None else (1.0 if v is True else (0.0 if v is False else float(v))))
        return out


_COMMON_FIELDS = tuple(f.name for f in fields(Common))
