"""Cylinder cavitation: the pressure floor at the vapour pressure with a mass-conservative vapour volume.

The model (``lumped.model.pump.cylinder_pressure``; Wylie's discrete vapour cavity, Wylie & Streeter 1993,
section 8.5): while the oil mass no longer fills the cylinder at the liquid's density at the vapour
pressure, the pressure is held there and the rest of the volume is vapour, V - m / rho(P_vap); the
mass stays the state, so the cavity collapses exactly as the piston returns. Checked against
independent numbers: the floor itself, the mass balance (cumulative flows vs the cylinder's mass),
the vapour volume recomputed from the state, the reference stepper, and the thesis cases, whose
delivery must not move when the vapour pressure is switched on (no cavity forms there).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from lumped.run.simulate import simulate
from lumped.model.model_file import load_model, with_values
from studies.validation import chain as V
from studies.discrepancy.synth import thesis_conditions
from lumped.model.random_designs import VALVES, random_design
from studies.discrepancy.synth import Noise, synthesize


def _cavitating_model():
    """The thesis disc pump with an inlet spring 10x stiffer: at 950 rpm with air-free oil the
    inlet opens late and the cylinder cavitates for tens of crank degrees."""
    return with_values(load_model("thesis-disc"), {"valves.inlet.spring.stiffness": 2000.0})


@pytest.mark.parametrize("method", ["fast", "reference"])
def test_cylinder_cavitates_at_the_vapour_pressure_and_conserves_mass(method):
    m = _cavitating_model()
    r = simulate(m, 950.0, 2.76e6, air_content=0.0, revolutions=3, max_revolutions=6, method=method, trace=True)
    tr = r.trace
    pv = m.oil.vapour_pressure
    assert np.degrees(r.cavitation_angle) > 20.0              # it does cavitate
    assert tr.cylinder_pressure.min() >= pv * (1 - 1e-12)     # never below the floor
    assert r.mass_balance_error < 1e-9
    # the vapour volume is what the liquid at rho(P_vap) leaves empty (recomputed from the mass state)
    rho_v = m.oil.density_at(pv)
    vap = tr.vapour_volume
    cav = vap > 0
    assert cav.any() and (~cav).any()                         # it forms and collapses
    assert tr.cylinder_pressure[cav] == pytest.approx(pv, abs=1e-9)
    assert r.delivery_per_rev > 0.9 * m.pump.displacement


def test_fast_and_reference_agree_while_cavitating():
    m = _cavitating_model()
    kw = dict(air_content=0.0, revolutions=3, max_revolutions=6)
    f = simulate(m, 950.0, 2.76e6, method="fast", **kw)
    r = simulate(m, 950.0, 2.76e6, method="reference", **kw)
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=1e-3)
    assert np.degrees(f.cavitation_angle) == pytest.approx(np.degrees(r.cavitation_angle), abs=1.0)


def test_thesis_cases_do_not_move_with_the_vapour_pressure():
    """R > 0 keeps the cylinder far above the vapour pressure: switching it on (0 -> the model's value)
    changes no delivery by more than 1e-4."""
    for c in V.cases():
        m = V.thesis_model_of(c)
        m0 = replace(m, oil=replace(m.oil, vapour_pressure=0.0))
        kw = dict(air_content=c["air_content"], revolutions=3, max_revolutions=6)
        a = simulate(m, c["speed_rpm"], c["load_pressure"], **kw)
        b = simulate(m0, c["speed_rpm"], c["load_pressure"], **kw)
        assert abs(a.delivery_per_rev / b.delivery_per_rev - 1.0) < 1e-4, V.case_name(c)
        assert a.min_cylinder_pressure >= m.oil.vapour_pressure


def test_no_trace_below_the_vapour_pressure():
    """The 12 validation cases, 20 random designs (air content 0-3 %) and the synth conditions with
    air-free oil: no cylinder pressure below the vapour pressure, mass balanced to 1e-9."""
    runs = [(V.thesis_model_of(c), c["speed_rpm"], c["load_pressure"], c["air_content"]) for c in V.cases()]
    rng = np.random.default_rng(0)
    for i in range(20):
        speed, load, air, m = random_design(rng, VALVES[i % 3])
        runs.append((m, speed, load, air))
    for valve in ("disc", "reed"):
        runs += [(load_model(f"thesis-{valve}"), c.speed_rpm, c.load_pressure_pa, 0.0)
                 for c in thesis_conditions(valve, 0.0)]
    for m, speed, load, air in runs:
        r = simulate(m, speed, load, air_content=air, revolutions=3, max_revolutions=6, trace=True)
        assert r.trace.cylinder_pressure.min() >= m.oil.vapour_pressure * (1 - 1e-12)
        assert r.mass_balance_error < 1e-9


def test_synthetic_pressure_is_never_below_the_vapour_pressure():
    """Air-free synthetic data (noise 10 kPa): the transducer reads no lower than the vapour pressure."""
    m = load_model("thesis-disc")
    from studies.discrepancy.model_choice import load_model as load_sim

    simulate_fn, _lib = load_sim(None)
    runs, _ = synthesize(simulate_fn, "disc", thesis_conditions("disc", 0.0), (), Noise(), seed=3, workers=1)
    lows = [float(np.min(r.trace.cylinder_pressure_pa)) for r in runs if r.trace.cylinder_pressure_pa is not None]
    assert lows and min(lows) >= m.oil.vapour_pressure
