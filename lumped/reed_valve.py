"""Reed check valve of chapter 3: the single-degree-of-freedom tip equation 3.21 and its flow.

Equation of motion per unit area (Pa), x the tip opening [m] (eq 3.21)::

    M x'' + gamma1 c x' + gamma2 rho |x'| x' C_D / 2 + gamma1 kappa (x - x0)
        = gamma1 dP X(x) + gamma1 F_c(x, x')

with M = rho_c h_eff (+ gamma3 rho W2 pi/4 Gamma_f with added mass), c = c_c + c_f,
X(x) the pressure load multiplier (eq 3.83) and F_c valvelab's seat/stop contact (the
thesis gives none; lumped/data/reed_valve.toml documents it). The drag term is printed
x'^2 in eq 3.21; it must oppose the motion, so |x'| x' is used (docs/errata.md).

The flow (eqs 3.22-3.26, C_d of eq 3.89) is shared with the disc valve:
:func:`lumped.disc_valve.valve_flow`. Floats and the flat parameter array only, so
``numba.njit`` can compile these functions unchanged.
"""

from __future__ import annotations

from lumped.disc_valve import contact_force, contact_state
from lumped.params import (
    V_CSEAT, V_CSTOP, V_DAMP, V_G1, V_KAPPA, V_KSEAT, V_KSTOP, V_MASS, V_RDRAG, V_X0,
    V_XD0, V_XD1, V_XD2, V_XN0, V_XN1, V_XPOIS, V_XSTOP, V_XZERO,
)


def pressure_load_multiplier(x: float, plateau: float, n1: float, n0: float, d2: float, d1: float,
                             d0: float, x_zero: float) -> float:
    """X(x) of eq 3.83 (dimensionless), x the tip opening in m.

    max(0, min(plateau, (n1 x + n0) / (x^3 + d2 x^2 + d1 x + d0))), and 0 from the opening
    x_zero = -n0/n1 (1.369 mm) on: the printed rational function has a pole near 1.651 mm
    and turns back up to the 0.835 cap above it, which the measurements of Figure 3.24 do
    not show (docs/errata.md).
    """
    if x >= x_zero:
        return 0.0
    r = (n1 * x + n0) / (((x + d2) * x + d1) * x + d0)
    if r > plateau:
        return plateau
    if r < 0.0:
        return 0.0
    return r


def reed_acceleration(x: float, u: float, dp: float, rho: float, p, o: int, contact: int) -> float:
    """Tip acceleration x'' [m/s^2] of the reed from eq 3.21 (per unit area, Pa)."""
    g1 = p[o + V_G1]
    xstop = p[o + V_XSTOP]
    if contact < 0:
        contact = contact_state(x, xstop)
    X = pressure_load_multiplier(x, p[o + V_XPOIS], p[o + V_XN1], p[o + V_XN0], p[o + V_XD2],
                                 p[o + V_XD1], p[o + V_XD0], p[o + V_XZERO])
    f = g1 * (dp * X - p[o + V_DAMP] * u - p[o + V_KAPPA] * (x - p[o + V_X0]))
    f += g1 * contact_force(x, u, p[o + V_KSEAT], p[o + V_CSEAT], p[o + V_KSTOP], p[o + V_CSTOP],
                            xstop, contact)
    f -= p[o + V_RDRAG] * rho * abs(u) * u
    return f / p[o + V_MASS]
