"""The analytic Jacobian of the pump (lumped.jacobian) against central differences of the right-hand side.

Random parameter draws, each candidate effect switched on in turn, both valve kinds, mixed
kinds and both circuits, states in every contact state and regime (and a cavitating
cylinder): every entry of df/dy and df/dt must agree. A perturbed partial must be caught.
"""

from __future__ import annotations

import numpy as np
import pytest

from lumped import compiled
from lumped import steppers  # noqa: F401  (compiled.cached digests its source: import it even when run alone)
from lumped import jacobian as J
from lumped import pump as P
from lumped import switching as sw
from lumped.layout import pack
from lumped.model_file import with_values
from lumped.pump import G
from studies.sweeps.random_designs import random_design

EFFECTS = {
    "none": {},
    "seat_compliance": {"effects.seat_compliance.delivery.k_seat": 2.0e6},
    "squeeze_film": {"effects.squeeze_film": True},
    "flow_force": {"effects.flow_force": True},
    "added_mass": {"effects.added_mass": True},
    "fluid_damping": {"effects.fluid_damping": True},
    "piston_leakage": {"effects.piston_leakage.clearance": 2e-5},
    "entrained_air": {"oil.air_content": 0.02},
    "air_free": {"oil.air_content": 0.0},
}


#: effects of one valve kind only are drawn where that kind is
APPLIES = {"fluid_damping": ("reed", "mixed"), "squeeze_film": ("disc", "mixed"), "flow_force": ("disc", "mixed")}
CASES = [(e, v, c) for e in EFFECTS for v in ("disc", "reed", "mixed") for c in ("simplified", "complete")
         if v in APPLIES.get(e, (v,))]


def _model(valve, effect, seed):
    speed, load, air, model = random_design(np.random.default_rng(seed), valve)
    return with_values(model, dict(EFFECTS[effect])), speed, load


def _states(p, model, rng, complete, n=8):
    """States spread over the contact states, regimes and (air-free oil) a cavitating cylinder."""
    vol = P.cylinder_volume_at(0.01, p)[0]
    for i in range(n):
        y = np.zeros(P.N_STATES)
        t = rng.uniform(0.0, 0.1)
        vol = P.cylinder_volume_at(t, p)[0]
        y[P.S_MCYL] = model.oil.density_at(rng.uniform(0.05e6, 4e6)) * vol
        for xi, ui, o in ((P.S_XIN, P.S_UIN, P.OFF_IN), (P.S_XDEL, P.S_UDEL, P.OFF_DEL)):
            stop = p[o + 2]
            y[xi] = (-rng.uniform(1e-9, 1e-6), rng.uniform(0.05, 0.9) * stop, stop * (1 + rng.uniform(1e-5, 1e-3)),
                     rng.uniform(1e-6, 3e-5))[(i + xi) % 4]
            y[ui] = rng.choice([-1, 1]) * rng.uniform(0.01, 0.5)
        if complete:
            y[P.S_MLOAD] = P.load_mass(rng.uniform(1.5e6, 4e6), p)[0]
        mode = np.zeros(P.N_MODE)
        sw.initial_mode(t, y, p, mode)
        if p[G.rho_vapour] > 0 and i == n - 1:           # a cylinder below the vapour density
            y[P.S_MCYL] = 0.999 * p[G.rho_vapour] * vol
            mode[P.M_CAV] = P.CAVITATING
        yield t, y, mode


def _central(t, y, p, mode, n_dyn, scales):
    f0 = P.rhs(t, y, p, mode)
    jfd = np.zeros((P.N_STATES, P.N_STATES))
    for j in range(n_dyn):
        h = (1e-9 if j == P.S_MCYL or j == P.S_MLOAD else 1e-7) * max(abs(y[j]), scales[j])
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        jfd[:, j] = (P.rhs(t, yp, p, mode) - P.rhs(t, ym, p, mode)) / (2 * h)
    dt = 1e-9
    ft = (P.rhs(t + dt, y, p, mode) - P.rhs(t - dt, y, p, mode)) / (2 * dt)
    return f0, jfd, ft


def jacobian_errors(model, speed, load, circuit, seed, jac_fn):
    """Largest normalised |analytic - central| over the states drawn, for df/dy and df/dt."""
    p = pack(model, speed, load, circuit, needle_area=2e-7 if circuit == "complete" else None)
    complete = circuit == "complete"
    n_dyn = 6 if complete else 5
    m_rev = model.oil.density * model.pump.displacement
    from lumped.steppers import state_scales
    scales = state_scales(p, m_rev)
    atol = 1e-8 * scales
    worst_j = worst_t = 0.0
    rng = np.random.default_rng(seed)
    for t, y, mode in _states(p, model, rng, complete):
        f0, jfd, ftfd = _central(t, y, p, mode, n_dyn, scales)
        ja = np.zeros((P.N_STATES, P.N_STATES))
        fa = np.zeros(P.N_STATES)
        jac_fn(t, y, p, mode, np.nan, ja, fa, np.zeros(P.N_STATES), np.zeros(P.N_STATES), atol, 1e-6, n_dyn)
        # each entry against its own size and the size of its row times the state's scale
        row = np.abs(jfd[:, :n_dyn] * scales[:n_dyn]).max(axis=1, keepdims=True) + 1e-300
        err = np.abs(ja[:, :n_dyn] - jfd[:, :n_dyn]) * scales[:n_dyn] / (1e-3 * np.abs(jfd[:, :n_dyn] * scales[:n_dyn])
                                                                           + 1e-6 * row)
        worst_j = max(worst_j, float(err.max()))
        assert np.all(ja[:, n_dyn:] == 0.0)                     # quadratures never feed back
        tscale = np.abs(ftfd) + 1e-5 * np.abs(f0) / 1e-3 + 1e-300
        worst_t = max(worst_t, float((np.abs(fa - ftfd) / (1e-3 * tscale)).max()))
    return worst_j, worst_t


@pytest.mark.parametrize("effect, valve, circuit", CASES)
def test_jacobian_equals_central_differences(effect, valve, circuit):
    model, speed, load = _model(valve, effect, seed=CASES.index((effect, valve, circuit)))
    jac = compiled.cached("lumped.jacobian", "pump_jacobian")
    ej, et = jacobian_errors(model, speed, load, circuit, 7, jac)
    assert ej < 1.0, f"df/dy off by {ej:.3g} tolerance units"
    assert et < 1.0, f"df/dt off by {et:.3g} tolerance units"


def test_the_python_jacobian_is_the_compiled_one():
    model, speed, load = _model("mixed", "piston_leakage", 3)
    ej, et = jacobian_errors(model, speed, load, "complete", 11, J.pump_jacobian)
    assert ej < 1.0 and et < 1.0


@pytest.mark.parametrize("factor", [1.01, 0.99])
def test_a_wrong_partial_is_caught(monkeypatch, factor):
    """Scale one partial (d mdot / d rho of the valve mass flows) by 1 %: the comparison fails."""
    from lumped import valve as V

    def bad_mass_flow(qo, aq, u, dp, rho, dq_ddp, dq_dx):
        m, d_dp, d_rho, d_x, d_u = V.mass_flow(qo, aq, u, dp, rho, dq_ddp, dq_dx)
        return m, d_dp, d_rho * factor, d_x, d_u

    monkeypatch.setattr(J, "mass_flow", bad_mass_flow)
    model, speed, load = _model("disc", "none", 5)
    ej, _ = jacobian_errors(model, speed, load, "simplified", 13, J.pump_jacobian)
    assert ej > 1.0
