"""The candidate effects of CONTRACT.md switch the right physics on, with priors from the thesis."""

import math

import pytest

from lumped.model.effect_library import LIBRARY, baseline, resolve
from lumped.model.effects import Applied
from lumped.model.model_file import load_model
from lumped.valves.reed import modal_critical_damping
from studies.discrepancy.workflow import RunCondition
from studies.discrepancy.measured import Run
from studies.discrepancy import pump_sim

MU = load_model("thesis-disc").oil.viscosity      # eq A.3 at 22 C


def model_for(cond, effects):
    """The resolved model (effects applied) the workflow simulates for a run condition."""
    return resolve(pump_sim.model_for(cond, effects))

CONTRACT_EFFECTS = ("seat_compliance", "squeeze_film", "flow_force", "added_mass", "fluid_damping",
                    "quadratic_drag", "piston_leakage", "entrained_air")


def cond(valve="disc", air=None):
    return RunCondition("r", valve, 593.0, 2.79e6, air)


def test_every_contract_effect_is_a_candidate():
    for name in CONTRACT_EFFECTS:
        assert name in LIBRARY and LIBRARY[name].candidate
    assert not LIBRARY["discharge_scale"].candidate


def test_baseline_has_every_effect_off_and_takes_the_stated_air():
    m = model_for(cond(), ())
    assert m == baseline(load_model("thesis-disc")) and m.effects == ()
    assert m.inlet.seat_stiffness == pytest.approx(3.02e9) and m.delivery.seat_stiffness == pytest.approx(3.02e9)
    assert m.inlet.seat_damping == pytest.approx(6860.0) and m.delivery.seat_damping == pytest.approx(6860.0)
    assert m.oil.air_content == 0.0
    assert model_for(cond(air=0.013), ()).oil.air_content == pytest.approx(0.013)


def test_seat_compliance_damping_is_critical_as_in_table_2_3():
    # Table 2.3: k_seat = 1.5e6 N/m -> c_seat = 153 N s/m (eq 2.23 with 3.9 g)
    m = model_for(cond(), (Applied.of("seat_compliance", "delivery", {"k_seat": 1.5e6}),))
    assert m.inlet.seat_stiffness == pytest.approx(3.02e9)
    assert m.delivery.seat_stiffness == 1.5e6
    assert m.delivery.seat_damping_value == pytest.approx(153.0, rel=0.005)
    assert LIBRARY["seat_compliance"].report({"k_seat": 3.02e9}, "disc")["c_seat"] == pytest.approx(6860, rel=0.002)
    assert load_model("thesis-disc").inlet.contact_mass == pytest.approx(3.9e-3)


def test_reed_seat_variant_in_pressure_units():
    eff = LIBRARY["seat_compliance"]
    assert eff.parameter("k_seat", "reed").unit == "Pa/m" and eff.parameter("k_seat", "disc").unit == "N/m"
    m = model_for(cond("reed"), (Applied.of("seat_compliance", "delivery", {"k_seat": 8.49e9}),))
    v = m.delivery
    # critical damping of the modal equation for the new stiffness (eq 2.23)
    assert v.seat_damping_value == pytest.approx(
        modal_critical_damping(8.49e9, v.gamma1, v.density * v.effective_thickness), rel=1e-12)


def test_squeeze_film_prior_is_eq_2_15():
    eff = LIBRARY["squeeze_film"]
    c2 = eff.prior_values("disc")["C2"]
    # Table 2.3 prints 7.630e-11 N m^2 s, which eq 2.15 gives with mu(21 C) = 0.0705 Pa s;
    # C2 is proportional to mu, and valvelab's oil is at 22 C (mu = 0.0683 Pa s)
    assert c2 * 0.0705 / MU == pytest.approx(7.630e-11, rel=0.01)
    m = model_for(cond(), (Applied.of("squeeze_film", "both", {"C2": 2 * c2}),))
    assert m.inlet.squeeze_c2 == pytest.approx(2 * c2) and m.delivery.squeeze_c2 == pytest.approx(2 * c2)
    assert m.delivery.c1 == pytest.approx(0.714, abs=5e-4)   # the rest of the disc is untouched


def test_added_mass_priors():
    mf = LIBRARY["added_mass"].prior_values("disc")["m_f"]
    assert mf == pytest.approx(8.0 / 3.0 * 876.0 * 7.5e-3**3, rel=1e-6)   # Lamb's disc, R_o of Table 2.3
    m = model_for(cond(), (Applied.of("added_mass", "both", {"m_f": 3e-3}),))
    assert m.inlet.moving_mass == pytest.approx(2.5e-3 + 0.6e-3 / 3 + 3e-3)
    assert LIBRARY["added_mass"].prior_values("reed")["Gamma_f"] == pytest.approx(0.885)   # Table 3.13


def test_fluid_damping_and_leakage():
    m = model_for(cond("reed"), (Applied.of("fluid_damping", "both", {"c_f": 1650.0}),))
    assert m.inlet.damping == pytest.approx(1727.5)          # eq 3.81: c = c_c + c_f
    assert model_for(cond("reed"), ()).inlet.damping == pytest.approx(77.5)
    eff = LIBRARY["piston_leakage"]
    k = eff.report({"clearance": 2e-5}, "disc")["conductance"]
    assert k == pytest.approx(math.pi * 15.88e-3 * 2e-5**3 / (12 * MU * 20e-3), rel=1e-9)
    m = model_for(cond(), (Applied.of("piston_leakage", "pump", {"clearance": 2e-5}),))
    assert m.pump.leakage_coefficient(MU) == pytest.approx(k)


def test_quadratic_drag_is_eq_3_21s_drag_term():
    """quadratic_drag switches on the gamma2 rho |x'| x' C_D / 2 term of eq 3.21 on both reeds (the thesis model
    leaves it off): the packed coefficient is gamma2 C_D / 2 (Table 3.8's gamma2 = 0.6986), prior C_D = 1."""
    from lumped.solver.layout import BLOCK_OFFSET, pack
    from lumped.valves.reed import REED

    eff = LIBRARY["quadratic_drag"]
    assert eff.prior_values("reed") == {"C_D": 1.0} and not eff.applies_to("disc", "both")
    m = model_for(cond("reed"), (Applied.of("quadratic_drag", "both", {"C_D": 2.5}),))
    assert m.inlet.drag and m.delivery.drag and m.inlet.drag_coefficient == 2.5
    p = pack(m, 593.0, 2.79e6)
    for o in BLOCK_OFFSET:
        assert p[o + REED.drag_term] == pytest.approx(0.5 * 0.6986 * 2.5)
    assert pack(model_for(cond("reed"), ()), 593.0, 2.79e6)[BLOCK_OFFSET[0] + REED.drag_term] == 0.0


def test_squeeze_film_and_flow_force_take_one_valve_or_both():
    for name, values in (("squeeze_film", {"C2": 7e-11}), ("flow_force", {"theta_jet": 1.1, "L_t": 0.01})):
        assert LIBRARY[name].placement and LIBRARY[name].targets == ("both", "inlet", "delivery")
        field = "squeeze_c2" if name == "squeeze_film" else "flow_force_steady"
        one = model_for(cond(), (Applied.of(name, "delivery", values),))
        both = model_for(cond(), (Applied.of(name, "both", values),))
        assert getattr(one.delivery, field) > 0 and getattr(one.inlet, field) == 0
        assert getattr(both.delivery, field) > 0 and getattr(both.inlet, field) > 0
    # the workflow searches them at "both" and tries each valve from there (Effect.placement)
    targets = [t for e, t in LIBRARY.candidates("disc")[0] if e.name == "squeeze_film"]
    assert targets == ["both"]


def test_entrained_air_only_when_not_stated():
    lib = LIBRARY
    stated = [Run("a", "disc", 600.0, 2.8e6, air_content=0.013)]
    unstated = [Run("a", "disc", 600.0, 2.8e6)]
    names = lambda runs: {e.name for e, _ in lib.candidates("disc", runs)[0]}  # noqa: E731
    assert "entrained_air" not in names(stated) and "entrained_air" in names(unstated)
    assert "fluid_damping" not in names(unstated)        # a reed effect
    assert "fluid_damping" in {e.name for e, _ in lib.candidates("reed", unstated)[0]}
    m = model_for(cond(), (Applied.of("entrained_air", "pump", {"R": 0.01}),))
    assert m.oil.air_content == pytest.approx(0.01)


def test_discharge_scale_scales_cd_everywhere():
    from lumped.fluid.orifice import discharge_coefficient
    m0 = model_for(cond(), ())
    m = model_for(cond(), (Applied.of("discharge_scale", "both", {"scale": 1.03}),))
    for re in (1.0, 30.0, 1000.0):
        a = discharge_coefficient(math.sqrt(re), m0.inlet.cd_inf, m0.inlet.cd_a, m0.inlet.cd_b, m0.inlet.cd_c)
        b = discharge_coefficient(math.sqrt(re), m.inlet.cd_inf, m.inlet.cd_a, m.inlet.cd_b, m.inlet.cd_c)
        assert b == pytest.approx(1.03 * a, rel=1e-9)


@pytest.mark.parametrize("kind", ["disc", "reed", "ball"])
def test_every_reported_value_has_the_unit_of_the_field_it_sets(kind):
    """Effect.units names a unit for every value report() gives (the discrepancy output prints them beside the
    numbers); a derived seat damping carries the unit the valve declares for seat.damping."""
    from geometry.declare import spec_of

    model = load_model(f"thesis-{kind}")
    for name in LIBRARY.names():
        eff = LIBRARY[name]
        for target in eff.targets:
            if not eff.applies_to(model, target):
                continue
            values = eff.prior_values(model, target)
            units = eff.units(model, target)
            assert set(units) == set(eff.report(values, model, target)), (name, target)
            assert all(units.values()), (name, target, units)
            if name == "seat_compliance":
                valve = getattr(model, target)
                assert units["k_seat"] == spec_of(valve, "seat_stiffness").unit
                assert units["c_seat"] == spec_of(valve, "seat_damping").unit
