"""Reed valve (chapter 3): eq 3.21 dynamics, X(x) of eq 3.83, C_d of eq 3.89, parameters from a reed model."""

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from geometry.errors import InputError
from geometry import load_reed
from lumped.valves import reed as rv
from lumped.model.effect_library import resolve
from lumped.solver.layout import pack
from lumped.reed.mode_function import ReedProperties
from lumped.model.model_file import load_model
from lumped.fluid.orifice import discharge_coefficient, orifice_flow
from lumped.solver.layout import OFF_DEL, OFF_IN
from lumped.valves.kind import ValveInputs
from lumped.valves.reed import REED
from lumped.valves.kind import displacement_area, valve_flow
from studies.tables.thesis import thesis_values


def thesis_model(_valve="reed"):
    """The thesis reed pump with its effects applied (fluid damping on)."""
    return resolve(load_model("thesis-reed"))


def load_reed_valve(position):
    return thesis_model().valve(position)


def acc(x, u, dp, p, o, contact, rho=876.0):
    """eq 3.21 through the kind's common acceleration signature (no flow arguments used)."""
    f = ValveInputs(dp, 0.0, 0.0, rho, 0.0683, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    return rv.reed_acceleration(x, u, f, p, o, contact, 1)

T313 = thesis_values()["table_3_13"]
T310 = thesis_values()["table_3_10"]
REED_CD = (0.5740, 6.144, 0.3661, 0.3379)


def X(x, v=None):
    v = v or load_reed_valve("inlet")
    return rv.pressure_load_multiplier(x, v.multiplier_poiseuille, v.multiplier_n1, v.multiplier_n0,
                                       v.multiplier_d2, v.multiplier_d1, v.multiplier_d0, v.multiplier_zero)


def printed_rational(x):
    return (-52.28 * x + 0.07158) / (x**3 + 0.8145 * x**2 - 50.23 * x + 0.08292)


def test_pressure_load_multiplier_eq_3_83():
    assert X(0.0) == pytest.approx(0.835)                 # Poiseuille plateau (Table 3.12, F4 = 0.5)
    assert X(-0.2e-3) == pytest.approx(0.835)
    for x in (0.2e-3, 0.6e-3, 1.0e-3, 1.3e-3):            # the rational fit, where below the cap
        r = printed_rational(x)
        assert X(x) == pytest.approx(max(0.0, min(0.835, r)), rel=1e-12)
    assert X(0.6e-3) < 0.835 and X(1.2e-3) > 0
    x0 = 0.07158 / 52.28
    assert X(x0 * 0.999) > 0 and X(x0) == 0.0
    # beyond the pole near 1.651 mm the printed formula turns back up to the cap; X stays 0
    assert min(0.835, printed_rational(1.7e-3)) == pytest.approx(0.835)
    for x in (1.5e-3, 1.65e-3, 1.7e-3, 1.9e-3, 3e-3):
        assert X(x) == 0.0
    # continuous (no jump) across the cap and the zero
    xs = np.linspace(-0.1e-3, 2e-3, 20001)
    vals = np.array([X(x) for x in xs])
    assert np.max(np.abs(np.diff(vals))) < 1e-3


def test_reed_discharge_coefficient_eq_3_89():
    assert discharge_coefficient(0.0, *REED_CD) == 0.0
    s = np.linspace(0.01, 400, 2000)
    cd = np.array([discharge_coefficient(x, *REED_CD) for x in s])
    assert np.all(cd > 0) and np.all(cd < 0.574) and cd[-1] == pytest.approx(0.574, rel=1e-6)


def test_reynolds_coefficient_of_eq_3_87_is_printed_as_its_reciprocal():
    v = load_reed_valve("inlet")
    k = 4 * 876.0 / (v.orifice_perimeter * 0.0683)
    assert k == pytest.approx(5.625e5, rel=1e-3)          # s/m^3
    assert 1 / k == pytest.approx(1.778e-6, rel=1e-3)     # the number printed in eq 3.87
    # and the flow solver uses it: Re = k |Q|
    q, cd, *_ = orifice_flow(v.orifice_length * 0.5e-3, 2e4, 876.0, 0.0683, v.orifice_perimeter, *REED_CD)
    assert cd == pytest.approx(discharge_coefficient(math.sqrt(k * q), *REED_CD), rel=1e-10)


def test_table_3_13_parameters_and_corrections():
    v = load_reed_valve("delivery")
    assert v.damping == pytest.approx(T313["c"], abs=1.0)                 # c = c_c + c_f = 1727 (eq 3.81)
    assert v.fluid_damping_coefficient == pytest.approx(T313["c_f"])      # 1650 (Table 3.13 swaps them)
    assert v.preload == pytest.approx(-0.18e-3) and load_reed_valve("inlet").preload == 0.0
    assert v.area_max == pytest.approx(T313["A2"]) and v.area_min == pytest.approx(T313["A1"])
    assert replace(v, fluid_damping_coefficient=0.0).damping == pytest.approx(77.5)
    # h_eff consistency (eq 3.62): FEA kappa and omega give 1.161 mm
    assert v.gamma1 * T313["kappa_fea"] / (v.density * 2523.0**2) == pytest.approx(T313["h_eff"], rel=2e-3)


def _free_reed(v):
    model = thesis_model("reed")
    model = replace(model, inlet=v)
    p = pack(model, 600.0, 2.76e6).tolist()
    return p, OFF_IN


@pytest.mark.parametrize("fluid", [False, True])
def test_free_vibration_frequency_and_decay_match_eq_3_63(fluid):
    """dp = 0, no contact: M x'' + g1 c x' + g1 kappa x = 0 -> omega_d and decay of eqs 3.65-3.70."""
    v = load_reed_valve("inlet")
    if not fluid:
        v = replace(v, fluid_damping_coefficient=0.0)
    p, o = _free_reed(v)
    M = v.density * v.effective_thickness
    wn = math.sqrt(v.gamma1 * v.stiffness / M)
    zeta = v.gamma1 * v.damping / (2 * M * wn)
    wd = wn * math.sqrt(1 - zeta**2)

    def f(t, y):
        return [y[1], acc(y[0], y[1], 0.0, p, o, 1)]

    x0 = 0.5e-3
    T = 2 * math.pi / wd
    sol = solve_ivp(f, (0, 6 * T), [x0, 0.0], rtol=1e-11, atol=1e-15, dense_output=True)
    t = np.linspace(0, 6 * T, 4000)
    phi = math.atan2(zeta, math.sqrt(1 - zeta**2))
    exact = x0 / math.sqrt(1 - zeta**2) * np.exp(-zeta * wn * t) * np.cos(wd * t - phi)
    assert np.max(np.abs(sol.sol(t)[0] - exact)) < 1e-7 * x0
    if not fluid:
        # the plucked prototype in air: omega_n = 2786 rad/s (Table 3.10) with h_eff = 1.161 mm
        assert wn == pytest.approx(T310["omega_n_mean"], rel=5e-3)


def test_static_opening_balances_stiffness_and_pressure():
    """Held at constant dP the reed settles where kappa (x - x0) = dP X(x) (eq 3.82)."""
    v = load_reed_valve("delivery")
    p, o = _free_reed(v)
    dp = 3e3
    x_eq = brentq(lambda x: v.stiffness * (x - v.preload) - dp * X(x, v), 0.0, 2e-3, xtol=1e-16)

    def f(t, y):
        return [y[1], acc(y[0], y[1], dp, p, o, -1)]
    sol = solve_ivp(f, (0, 0.04), [0.0, 0.0], method="DOP853", rtol=1e-10, atol=1e-14)
    assert sol.y[0, -1] == pytest.approx(x_eq, rel=1e-6)
    assert x_eq > 0


def test_preloaded_reed_stays_on_seat_below_its_opening_pressure():
    v = load_reed_valve("delivery")
    p, o = _free_reed(v)
    dp_open = v.stiffness * (0 - v.preload) / 0.835            # 1.66 kPa
    for dp, sign in ((0.9 * dp_open, -1), (1.1 * dp_open, 1)):
        a = acc(0.0, 0.0, dp, p, o, 1)
        assert math.copysign(1, a) == sign


def test_rigid_seat_contact_is_stiff_and_critically_damped():
    v = load_reed_valve("inlet")
    proto = load_reed("prototype")
    assert v.seat_stiffness == pytest.approx(proto.material.youngs_modulus / proto.thickness)
    M = v.density * v.effective_thickness
    # critical damping of the modal equation M x'' + g1 c x' + g1 k x (eq 2.23)
    assert v.seat_damping_value == pytest.approx(2 * math.sqrt(v.gamma1 * v.seat_stiffness * M) / v.gamma1)
    p, o = _free_reed(v)
    # pressed onto the seat by 2.7 MPa, the tip sinks by dP X / k_seat only
    dp = -2.7e6
    x_eq = brentq(lambda x: acc(x, 0.0, dp, p, o, 0), -1e-3, 0.0)
    assert x_eq == pytest.approx(dp * 0.835 / (v.seat_stiffness + v.stiffness), rel=1e-6)
    assert abs(x_eq) < 1.1e-6          # ~1 um: rigid compared with the 1.2 mm lift


def test_added_mass_switch_eq_3_21():
    v = load_reed_valve("inlet")
    m0 = thesis_model("reed")
    p0 = pack(m0, 600, 2.76e6)
    gamma_f = 0.885
    p1 = pack(replace(m0, inlet=replace(v, hydrodynamic_function=gamma_f)), 600, 2.76e6)
    extra = v.gamma3 * 876.0 * v.width_tip * math.pi / 4 * gamma_f
    assert p1[OFF_IN + REED.moving_mass] - p0[OFF_IN + REED.moving_mass] == pytest.approx(extra, rel=1e-12)
    assert p1[OFF_DEL + REED.moving_mass] == p0[OFF_DEL + REED.moving_mass]


def test_displacement_area_direction_and_seat():
    v = load_reed_valve("inlet")
    a1, a2 = v.area_min, v.area_max
    assert displacement_area(-0.1, a1, a2, 0.22, 0.35, 1) == pytest.approx(a1 + 0.22 * (a2 - a1))
    assert displacement_area(0.1, a1, a2, 0.22, 0.35, 1) == pytest.approx(a1 + 0.35 * (a2 - a1))
    # seated: the same area both ways, so compressing and releasing the seat pumps nothing net
    assert displacement_area(-0.1, a1, a2, 0.22, 0.35, 0) == displacement_area(0.1, a1, a2, 0.22, 0.35, 0)


def test_reed_orifice_area_per_opening():
    p, o = _free_reed(load_reed_valve("inlet"))
    v = load_reed_valve("inlet")
    x, dp = 0.4e-3, 1e4
    q = valve_flow(x, 0.0, dp, 876.0, 0.0683, p, o, 1)[0]
    assert q == pytest.approx(orifice_flow(v.orifice_length * x, dp, 876.0, 0.0683, v.orifice_perimeter, *REED_CD)[0])


def _props(**kw):
    base = dict(fidelity="analytic", omega_n=2500.0, kappa=6.4e6, gamma1=1.62, gamma2=0.70, gamma3=0.87,
                h_eff=1.20e-3, s=np.linspace(0, 0.0254, 5), psi=np.linspace(0, 1, 5))
    base.update(kw)
    return ReedProperties(**base)


def test_reed_parameters_from_a_reed_model():
    v = load_reed_valve("delivery")
    w = v.with_properties(_props())
    assert (w.stiffness, w.gamma1, w.gamma2, w.gamma3, w.effective_thickness) == (6.4e6, 1.62, 0.70, 0.87, 1.20e-3)
    # the empirical prototype quantities stay as in Table 3.13
    for f in ("orifice_length", "area_min", "area_max", "f1", "f2", "multiplier_n0", "cd_inf", "preload",
              "internal_damping", "fluid_damping_coefficient"):
        assert getattr(w, f) == getattr(v, f)
    assert w.source == "analytic model"
    M = 1410.0 * 1.20e-3
    assert w.seat_damping_value == pytest.approx(2 * math.sqrt(1.62 * w.seat_stiffness * M) / 1.62)
    with pytest.raises(InputError, match="kappa"):
        v.with_properties(_props(kappa=float("nan")))
    with pytest.raises(InputError, match="h_eff"):
        v.with_properties(_props(h_eff=-1e-3))
