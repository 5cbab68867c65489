"""Mass-conservative single-cylinder piston pump (chapter 4): parameters and right-hand side.

:class:`Pump` and :class:`Circuit` declare the pump's parameters once (values of the
thesis rig in ``lumped/data/models/thesis-*.toml``). The physics is plain functions of
floats, the state vector and the flat parameter array (``lumped.layout.pack``), so
``numba.njit`` compiles the very same source for the fast path (``lumped.compiled``).

State (SI, :data:`N_STATES` entries): cylinder oil mass m_cyl (eq 4.5), inlet x, u,
delivery x, u, the load-line oil mass (complete circuit; constant otherwise), and the
cumulative masses through the inlet valve, delivery valve, piston clearance and needle
valve, which make the mass balance checkable to round-off. Time 0 is top dead centre.

Mode (:data:`N_MODE` entries, fixed inside a step, switched at located crossings by
``lumped.switching``): contact state and pressure regime of each valve, and whether
the cylinder is cavitating (its pressure held at the vapour pressure while the liquid
no longer fills it: the mass state still says how much oil is there, so the vapour
volume V - m / rho(P_vap) collapses exactly as the piston returns).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from geometry.declare import param
from lumped import oil as oil_mod
from lumped.oil import Oil
from lumped.valve import BLOCK_SIZE, VALVE, mass_flow, valve_acceleration, valve_flow

# state indices
S_MCYL, S_XIN, S_UIN, S_XDEL, S_UDEL, S_MLOAD, S_MIN, S_MOUT, S_MLEAK, S_MNV = range(10)
N_STATES = 10
QUADRATURES = (S_MIN, S_MOUT, S_MLEAK, S_MNV)     # running totals: never feed back
# mode entries: [contact inlet, regime inlet, contact delivery, regime delivery, cylinder]
M_CIN, M_RIN, M_CDEL, M_RDEL, M_CAV = range(5)
N_MODE = 5
LIQUID, CAVITATING = 0, 1


# ----------------------------------------------------------------- parameters
@dataclass(frozen=True)
class Pump:
    """Crank-slider piston pump (Table 5.1; section 4.2)."""

    piston_diameter: float = param("piston_diameter", "m", "d_piston (Table 5.1)", bounds=(1e-4, 2.0), positive=True)
    crank_radius: float = param("crank_radius", "m", "r (Table 5.1)", bounds=(1e-5, 2.0), positive=True, packed=True)
    rod_length: float = param("rod_length", "m", "l, connecting rod (Table 5.1)", bounds=(1e-5, 20.0), positive=True,
                              packed=True)
    dead_volume: float = param("dead_volume", "m^3", "V_tdc, cylinder volume at top dead centre (Table 5.1)",
                               bounds=(1e-12, 10.0), positive=True, packed=True)
    tank_pressure: float = param("tank_pressure", "Pa", "P_tank, absolute (Table 5.1)", bounds=(1e3, 1e7),
                                 positive=True, packed=True)
    seal_length: float = param("seal_length", "m", "L, engaged piston length of the leakage path (eq 4.5)",
                               bounds=(1e-5, 10.0), positive=True)
    # set by the piston_leakage effect (lumped/effect_library.py); zero = no leakage
    leakage_clearance: float = param(None, "m", "radial piston clearance c of eq 4.5", bounds=(0.0, 1e-3),
                                     default=0.0, effect="piston_leakage")

    @property
    def piston_area(self) -> float:
        """A_p = pi d^2 / 4 [m^2]."""
        return math.pi * self.piston_diameter**2 / 4

    @property
    def displacement(self) -> float:
        """Swept volume per revolution 2 A_p r [m^3] (section 5.4.4: 2.22 cc)."""
        return 2 * self.piston_area * self.crank_radius

    @property
    def compression_ratio(self) -> float:
        """(V_tdc + 2 A_p r) / V_tdc: cylinder volume at BDC over TDC."""
        return (self.dead_volume + self.displacement) / self.dead_volume

    def leakage_coefficient(self, viscosity: float) -> float:
        """Laminar annulus conductance pi d c^3 / (12 mu L) [m^3/(s Pa)] (eq 4.5); 0 without clearance."""
        return math.pi * self.piston_diameter * self.leakage_clearance**3 / (12 * viscosity * self.seal_length)


@dataclass(frozen=True)
class Circuit:
    """Where the pump delivers: a constant load pressure (simplified) or the complete circuit (section 4.2).

    The complete circuit (Figure 4.1): load line, accumulator and a needle valve to tank.
    The thesis gives no values for it (it ran the simplified circuit); the shipped ones
    are plausible for its bench (thesis-disc.toml).
    """

    kind: str = param("kind", "-", "simplified: constant load pressure (section 4.2.2); complete: load line, "
                      "accumulator, needle valve (section 4.2.1)", choices=("simplified", "complete"))
    line_volume: float = param("line_volume", "m^3", "oil volume of the load line", bounds=(1e-9, 10.0),
                               positive=True, packed=True)
    accumulator_volume: float = param("accumulator_volume", "m^3", "gas volume at and below the precharge",
                                      bounds=(0.0, 10.0), packed=True)
    accumulator_precharge: float = param("accumulator_precharge", "Pa", "precharge pressure, absolute",
                                         bounds=(1e3, 1e9), positive=True, packed=True)
    accumulator_exponent: float = param("accumulator_exponent", "-", "polytropic exponent of the gas charge",
                                        bounds=(1.0, 1.7), packed=True)
    needle_discharge: float = param("needle_discharge", "-", "Cd of the needle valve", bounds=(0.01, 1.0),
                                    positive=True)
    needle_area: float = param("needle_area", "m^2", "needle valve opening; left out: set so that the mean load "
                               "pressure settles at the requested one (as the experimenter did, section 5.5.2)",
                               bounds=(1e-12, 1.0), positive=True, optional=True)

    @property
    def complete(self) -> bool:
        return self.kind == "complete"


# ----------------------------------------------------------------- the global block of the flat array
def _global_block():
    """Offsets of the pump-wide quantities: operating point and derived ones, then the
    packed fields of Pump, Oil and Circuit (by field name)."""
    import collections

    from geometry.declare import specs

    derived = ("omega", "load_pressure", "piston_area", "leak", "complete", "needle_cda", "rho_vapour", "rho_tank",
               "rho_load", "pressure_start")
    packed = [n for cls in (Pump, Oil, Circuit) for n, s in specs(cls) if s.packed]
    names = derived + tuple(packed)
    assert len(set(names)) == len(names), names
    return collections.namedtuple("GlobalBlock", names)(*range(len(names)))


G = _global_block()
NG = 64                     # length of the global block
OFF_IN = NG                 # offset of the inlet valve's block
OFF_DEL = NG + BLOCK_SIZE   # ... of the delivery valve's block
NP = NG + 2 * BLOCK_SIZE    # length of the packed parameter array


# ----------------------------------------------------------------- kinematics (section 4.3.1)
def piston_position(theta: float, crank: float, rod: float) -> float:
    """Piston displacement from TDC x_p [m] at crank angle theta [rad] (eq 4.1)."""
    s = math.sin(theta)
    return crank * (1.0 - math.cos(theta)) + rod - math.sqrt(rod * rod - crank * crank * s * s)


def cylinder_volume(theta: float, omega: float, area: float, crank: float, rod: float,
                    v_tdc: float) -> tuple[float, float]:
    """(V_cyl [m^3], dV_cyl/dt [m^3/s]) of the crank-slider at angle theta, speed omega (eq 4.2)."""
    s = math.sin(theta)
    c = math.cos(theta)
    root = math.sqrt(rod * rod - crank * crank * s * s)
    xp = crank * (1.0 - c) + rod - root
    vel = omega * (crank * s + crank * crank * s * c / root)
    return v_tdc + area * xp, area * vel


def cylinder_volume_at(t: float, p) -> tuple[float, float]:
    """(V_cyl, dV_cyl/dt) at time t [s] after TDC for the packed parameters p (eq 4.2)."""
    omega = p[G.omega]
    return cylinder_volume(omega * t, omega, p[G.piston_area], p[G.crank_radius], p[G.rod_length],
                           p[G.dead_volume])


# ----------------------------------------------------------------- fluid states and their partials
def oil_density(pressure: float, p) -> float:
    """Density of the oil at absolute pressure [Pa] (eq 4.11) for the packed parameters p [kg/m^3]."""
    return oil_mod.density(pressure, p[G.density], p[G.atmospheric_pressure], p[G.bulk_modulus],
                           p[G.polytropic_exponent], p[G.air_content])


def oil_density_slope(pressure: float, p) -> float:
    """d rho / dP of eq 4.11 [kg/m^3/Pa] for the packed parameters p."""
    return oil_mod.density_slope(pressure, p[G.density], p[G.atmospheric_pressure], p[G.bulk_modulus],
                                 p[G.polytropic_exponent], p[G.air_content])


def cylinder_pressure(m: float, vol: float, p, cavitating: int) -> tuple[float, float, float]:
    """(P_cyl [Pa], dP_cyl/dm_cyl [Pa/kg], rho_cyl [kg/m^3]) of oil mass m in volume vol.

    Eq 4.11 inverted (eqs 4.12-4.16) while the liquid fills the cylinder; cavitating,
    the pressure is held at the vapour pressure (the liquid at rho(P_vap), the rest of
    the volume vapour; Wylie's discrete vapour cavity model, Wylie & Streeter, Fluid
    Transients in Systems, 1993, section 8.5), so dP/dm = 0 there.
    """
    rho = m / vol
    if cavitating == CAVITATING:
        return p[G.vapour_pressure], 0.0, rho
    pc = oil_mod.pressure(rho, p[G.density], p[G.atmospheric_pressure], p[G.bulk_modulus],
                          p[G.polytropic_exponent], p[G.air_content], p[G.pressure_start])
    # the root starts the next inversion (an integrator's stages are neighbouring states: ~1-2
    # Newton steps instead of a fresh start); scratch, not a parameter
    p[G.pressure_start] = pc
    return pc, 1.0 / (vol * oil_density_slope(pc, p)), rho


def load_mass(pl: float, p) -> tuple[float, float]:
    """(oil mass [kg], d mass/dP [kg/Pa]) in load line + accumulator at pressure pl (section 4.2.1).

    Oil volume = V_line + V_acc - V_gas, the gas at V_gas = V_acc (P_pre/P)^(1/n) above its
    precharge (polytropic) and filling the accumulator below it.
    """
    rho = oil_density(pl, p)
    drho = oil_density_slope(pl, p)
    vacc, ppre, n = p[G.accumulator_volume], p[G.accumulator_precharge], p[G.accumulator_exponent]
    vol = p[G.line_volume]
    dvol = 0.0
    if pl > ppre:
        vgas = vacc * (ppre / pl) ** (1.0 / n)
        vol += vacc - vgas
        dvol = vgas / (n * pl)
    return rho * vol, drho * vol + rho * dvol


def load_pressure(m: float, p) -> tuple[float, float]:
    """(P_load [Pa], dP_load/dm [Pa/kg]): the pressure holding oil mass m in the load line and
    accumulator (inverse of :func:`load_mass`).

    The mass is increasing in P, so Newton's method is kept inside a shrinking bracket
    (bisection when a step leaves it).
    """
    vline, vacc, ppre, n = p[G.line_volume], p[G.accumulator_volume], p[G.accumulator_precharge], \
        p[G.accumulator_exponent]
    m_pre = load_mass(ppre, p)[0]
    if m <= m_pre:
        pl = oil_mod.pressure(m / vline, p[G.density], p[G.atmospheric_pressure], p[G.bulk_modulus],
                              p[G.polytropic_exponent], p[G.air_content])
        return pl, 1.0 / (vline * oil_density_slope(pl, p))
    # gas law with incompressible oil as the first guess
    vgas = vacc + vline - m / p[G.density]
    guess = ppre * (vacc / vgas) ** n if vgas > 1e-3 * vacc else ppre * 1e3 ** n
    lo, hi = ppre, 1e12
    pl = guess if lo < guess < hi else 2.0 * ppre
    dm = 1.0
    for _ in range(200):
        f, dm = load_mass(pl, p)
        f -= m
        if f > 0.0:
            hi = pl
        else:
            lo = pl
        new = pl - f / dm
        if not (lo < new < hi):
            new = 0.5 * (lo + hi)
        if abs(new - pl) <= 1e-13 * new + 4e-16 * p[G.bulk_modulus]:
            return new, 1.0 / dm
        pl = new
    return pl, 1.0 / dm


def needle_mass_flow(pl: float, p) -> tuple[float, float]:
    """(mass flow through the needle valve to tank [kg/s], its derivative by P_load [kg/s/Pa]):
    Cd A sqrt(2 rho |dP|) sign(dP) (complete circuit)."""
    dp = pl - p[G.tank_pressure]
    rho = oil_density(pl, p)
    cda = p[G.needle_cda]
    adp = abs(dp)
    q = cda * math.sqrt(2.0 * rho * adp)
    # d/dP of rho q: q' = cda (2 rho' |dp| + 2 rho sign) / (2 sqrt(2 rho |dp|))
    root = math.sqrt(2.0 * rho * adp) if adp > 0.0 else 0.0
    dq = 0.0
    if root > 0.0:
        dq = cda * (oil_density_slope(pl, p) * adp + rho) / root
    return (q if dp >= 0.0 else -q), dq


def leakage_mass_flow(pc: float, rho: float, p) -> tuple[float, float, float]:
    """(laminar piston leakage rho K (P_cyl - P_tank) [kg/s] (eq 4.5), its partials by P_cyl and rho)."""
    k = p[G.leak]
    d = pc - p[G.tank_pressure]
    return rho * k * d, rho * k, k * d


def orifice_density(rho_cyl: float, rho_other: float, p, o: int) -> tuple[float, float]:
    """(density in the valve's orifice equation, its derivative by rho_cyl) (section 4.3.5):
    the cylinder's, or the mean of the cylinder's and the other side's ``rho_other``."""
    if p[o + VALVE.average_density] > 0.5:
        return 0.5 * (rho_cyl + rho_other), 0.5
    return rho_cyl, 1.0


def load_side_density(pl: float, p) -> float:
    """Oil density on the load side [kg/m^3]: at the constant load pressure (packed once), or at P_load."""
    if p[G.complete] > 0.5:
        return oil_density(pl, p)
    return p[G.rho_load]


# ----------------------------------------------------------------- right-hand side
class Rates(NamedTuple):
    """Everything the pump equations give at one instant (SI): the named record of :func:`evaluate`."""

    dm_cyl: float          # dm_cyl/dt = mdot_in - mdot_del - mdot_leak [kg/s] (eq 4.5)
    u_in: float            # inlet valve velocity [m/s]
    a_in: float            # inlet valve acceleration [m/s^2]
    u_del: float
    a_del: float
    dm_load: float         # d(load-line mass)/dt [kg/s] (complete circuit)
    mdot_in: float         # mass flow into the cylinder through the inlet valve [kg/s] (eq 4.3)
    mdot_del: float        # ... out through the delivery valve (eq 4.4)
    mdot_leak: float       # ... past the piston (eq 4.5)
    mdot_needle: float     # ... through the needle valve (complete circuit)
    p_cyl: float           # cylinder pressure [Pa]
    p_load: float          # load pressure [Pa]
    q_in: float            # orifice volume flow of the inlet valve [m^3/s]
    q_del: float
    rho_cyl: float         # mean oil density in the cylinder [kg/m^3]
    rho_in: float          # density in the inlet valve's orifice equation (section 4.3.5) [kg/m^3]
    rho_del: float         # ... the delivery valve's
    volume: float          # cylinder volume [m^3]
    vapour_volume: float   # volume not filled by liquid while cavitating [m^3]


def evaluate(t: float, y, p, mode) -> Rates:
    """Everything the pump equations give at time t [s] (t = 0 at TDC) for state y.

    The mass balance of eq 4.5 with the valve mass flows of eqs 4.3-4.4, cylinder
    pressure from eq 4.11 inverted by Newton (eqs 4.12-4.16) or held at the vapour
    pressure while cavitating, the load line of the complete circuit (section 4.2.1),
    and the valve dynamics of the valves' kinds (chapters 2 and 3).
    """
    vol, dvol = cylinder_volume_at(t, p)
    m = y[S_MCYL]
    pc, pc_m, rho_cyl = cylinder_pressure(m, vol, p, int(mode[M_CAV]))
    pt = p[G.tank_pressure]
    complete = p[G.complete] > 0.5
    pl = p[G.load_pressure]
    pl_m = 0.0
    if complete:
        pl, pl_m = load_pressure(y[S_MLOAD], p)
    mu = p[G.viscosity]
    x_in, u_in, x_del, u_del = y[S_XIN], y[S_UIN], y[S_XDEL], y[S_UDEL]
    rho_in = orifice_density(rho_cyl, p[G.rho_tank], p, OFF_IN)[0]
    rho_del = orifice_density(rho_cyl, load_side_density(pl, p), p, OFF_DEL)[0]
    dp_in = pt - pc
    dp_del = pc - pl
    c_in, c_del = int(mode[M_CIN]), int(mode[M_CDEL])
    qo_in, cd_in, aq_in, dqp_in, dqx_in = valve_flow(x_in, u_in, dp_in, rho_in, mu, p, OFF_IN, c_in)
    qo_del, cd_del, aq_del, dqp_del, dqx_del = valve_flow(x_del, u_del, dp_del, rho_del, mu, p, OFF_DEL, c_del)
    mdot_in = mass_flow(qo_in, aq_in, u_in, dp_in, rho_in, dqp_in, dqx_in)[0]
    mdot_del = mass_flow(qo_del, aq_del, u_del, dp_del, rho_del, dqp_del, dqx_del)[0]
    mdot_leak = leakage_mass_flow(pc, rho_cyl, p)[0]
    dm = mdot_in - mdot_del - mdot_leak                # eq 4.5
    # pressure rates, needed by the transient flow force (eq 2.37)
    dpc = (dm - rho_cyl * dvol) * pc_m
    dml = 0.0
    mdot_nv = 0.0
    dpl = 0.0
    if complete:
        mdot_nv = needle_mass_flow(pl, p)[0]
        dml = mdot_del - mdot_nv
        dpl = dml * pl_m
    a_in = valve_acceleration(x_in, u_in, dp_in, pc, p[G.vapour_pressure], rho_in, mu, qo_in, cd_in, aq_in,
                              dqp_in, dqx_in, -dpc, p, OFF_IN, c_in, int(mode[M_RIN]))
    a_del = valve_acceleration(x_del, u_del, dp_del, pl, p[G.vapour_pressure], rho_del, mu, qo_del, cd_del,
                               aq_del, dqp_del, dqx_del, dpc - dpl, p, OFF_DEL, c_del, int(mode[M_RDEL]))
    vap = 0.0
    if int(mode[M_CAV]) == CAVITATING and p[G.rho_vapour] > 0.0:
        vap = vol - m / p[G.rho_vapour]
        if vap < 0.0:
            vap = 0.0
    return Rates(dm, u_in, a_in, u_del, a_del, dml, mdot_in, mdot_del, mdot_leak, mdot_nv, pc, pl, qo_in, qo_del,
                 rho_cyl, rho_in, rho_del, vol, vap)


def rates_to_derivative(r: Rates, dydt) -> None:
    """dy/dt of the state (see the module docstring) from the record of :func:`evaluate`."""
    dydt[S_MCYL] = r.dm_cyl
    dydt[S_XIN] = r.u_in
    dydt[S_UIN] = r.a_in
    dydt[S_XDEL] = r.u_del
    dydt[S_UDEL] = r.a_del
    dydt[S_MLOAD] = r.dm_load
    dydt[S_MIN] = r.mdot_in
    dydt[S_MOUT] = r.mdot_del
    dydt[S_MLEAK] = r.mdot_leak
    dydt[S_MNV] = r.mdot_needle


def rhs(t: float, y, p, mode) -> np.ndarray:
    """dy/dt of the pump state (:data:`N_STATES` entries)."""
    out = np.empty(N_STATES)
    rates_to_derivative(evaluate(t, y, p, mode), out)
    return out


#: columns of :func:`rates_table`: the fields of :class:`Rates`
RATES_FIELDS = Rates._fields
N_RATES = len(RATES_FIELDS)


def rates_table(ts, ys, modes, p) -> np.ndarray:
    """:func:`evaluate` at sampled times, states and modes: one row per sample, columns RATES_FIELDS."""
    out = np.empty((ts.shape[0], N_RATES))
    for i in range(ts.shape[0]):
        r = evaluate(ts[i], ys[i], p, modes[i])
        for j in range(N_RATES):
            out[i, j] = r[j]
    return out
