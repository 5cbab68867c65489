"""Axisymmetric Navier-Stokes (fea.fluid.navier_stokes, fea.fluid.axisymmetric) against independent numbers.

Hagen-Poiseuille pipe flow in the port, the viscous log law of radial flow between parallel
discs, the convergence orders of Taylor-Hood elements on an exact axisymmetric Stokes flow
(radial source flow: it needs the u_r / r^2 term and the r-weighting), the thin-film fidelity
in the thin-gap low-Re limit, conservation, and the input errors of the ``flow`` fidelities.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from skfem import MeshTri

from fea import fluid
from fea.fluid.axisymmetric import AxiOptions, solve_point
from fea.fluid.disc_film import thin_film_point
from fea.fluid.navier_stokes import FlowBCs, solve_flow
from fea.fluid.point import load_fluid_valve
from fea.fluid.valve_mesh import disc_domain
from geometry.errors import InputError

MU, RHO = 0.0683, 876.0


def test_port_pipe_flow_is_hagen_poiseuille():
    R, L, Q = 5.24e-3, 5.2e-3, 2e-5
    m = MeshTri.init_tensor(np.linspace(0, R, 5), np.linspace(0, L, 9)).with_boundaries({
        "axis": lambda x: x[0] < 1e-12, "wall": lambda x: x[0] > R - 1e-12,
        "in": lambda x: x[1] < 1e-12, "out": lambda x: x[1] > L - 1e-12})
    V = Q / (math.pi * R**2)
    bcs = FlowBCs(axis=("axis",), velocity={"wall": (0, 0), "in": lambda r, z: (0 * r, 2 * V * (1 - (r / R) ** 2))},
                  pressure={"out": 0.0})
    s = solve_flow(m, bcs, RHO, MU, R, V)
    assert s.mean_pressure("in") == pytest.approx(8 * MU * Q * L / (math.pi * R**4), rel=1e-8)
    ur, uz, _ = s.probe(np.array([0.3 * R, 0.7 * R]), np.array([L / 2, L / 2]))
    assert uz == pytest.approx(2 * V * (1 - np.array([0.09, 0.49])), rel=1e-8)
    assert np.abs(ur).max() < 1e-8 * V
    assert s.flow("out") == pytest.approx(Q, rel=1e-12)


def radial_flow(n: int, rho: float = RHO * 1e-9, outlet_exact: bool = True):
    """Source flow between parallel discs R1..R2, gap h: u_r = f(z) / r, p = -6 mu Q ln(r/R2) / (pi h^3)."""
    R1, R2, h, Q = 1e-3, 5e-3, 0.2e-3, 1e-7

    def f(z):
        return 3 * Q / (math.pi * h) * (z / h) * (1 - z / h)

    def p_exact(r):
        return -6 * MU * Q * np.log(r / R2) / (math.pi * h**3)

    m = MeshTri.init_tensor(np.linspace(R1, R2, 8 * n + 1), np.linspace(0, h, n + 1)).with_boundaries({
        "in": lambda x: x[0] < R1 + 1e-12, "out": lambda x: x[0] > R2 - 1e-12,
        "walls": lambda x: (x[1] < 1e-12) | (x[1] > h - 1e-12)})
    # the exact traction at the outlet: p_b = p - mu du_r/dr = p + mu f / r^2
    out = (lambda r, z: p_exact(r) + MU * f(z) / r**2) if outlet_exact else 0.0
    bcs = FlowBCs(velocity={"walls": (0, 0), "in": lambda r, z: (f(z) / r, 0 * z)}, pressure={"out": out})
    s = solve_flow(m, bcs, rho, MU, h, Q / (2 * math.pi * R1 * h))
    return s, f, p_exact, (R1, R2, h, Q)


def test_radial_flow_between_discs_follows_the_viscous_log_law():
    s, _, _, (R1, R2, h, Q) = radial_flow(4, outlet_exact=False)     # a plain do-nothing outlet
    _, _, p = s.probe(np.array([1.5e-3, 4e-3]), np.array([h / 2, h / 2]))
    assert p[0] - p[1] == pytest.approx(6 * MU * Q * math.log(4 / 1.5) / (math.pi * h**3), rel=0.01)


def test_taylor_hood_converges_at_its_order():
    errs = []
    for n in (2, 4, 8):
        s, f, p_exact, _ = radial_flow(n)
        ub, pb = s.ubasis, s.pbasis
        x = np.asarray(ub.global_coordinates())
        w = ub.dx * x[0]
        eu = np.sqrt(((np.asarray(ub.interpolate(s.u))[0] - f(x[1]) / x[0]) ** 2 * w).sum())
        xp = np.asarray(pb.global_coordinates())
        ep = np.sqrt(((np.asarray(pb.interpolate(s.p)) - p_exact(xp[0])) ** 2 * pb.dx * xp[0]).sum())
        errs.append((eu, ep))
    e = np.array(errs)
    order = np.log2(e[:-1] / e[1:])
    assert np.all(order[:, 0] > 2.7)          # velocity L2: h^3
    assert np.all(order[:, 1] > 1.8)          # pressure L2: h^2


def test_newton_converges_with_inertia():
    # the same flow with the oil's density: inertia changes the pressure (the log law holds only
    # without it) and Newton must still reach round-off
    s0, *_ = radial_flow(2)
    s1, *_ = radial_flow(2, rho=RHO * 1e3)
    assert s1.newton > 1
    assert not np.allclose(s0.p, s1.p, rtol=1e-3)
    assert s1.flow("out") == pytest.approx(1e-7, rel=1e-10)


@pytest.fixture(scope="module")
def valve():
    return load_fluid_valve("thesis-disc:inlet")


def test_thin_gap_low_re_agrees_with_the_thin_film(valve):
    d = disc_domain(valve.params)
    x, re = 0.02e-3, 0.01
    ns = solve_point(valve, d, x, re, 2, AxiOptions())
    tf = thin_film_point(valve, x, re, {"divisions": 32})
    assert ns["dp"] == pytest.approx(tf.dp, rel=0.02)            # flow rate at a given dP
    assert ns["force"] == pytest.approx(tf.force, rel=0.02)      # pressure force
    assert ns["continuity"] < 1e-10


def test_a_point_has_every_contract_key(valve):
    p = fluid.get("axisymmetric", "disc").point(valve, 0.8e-3, 20.0, {"resolution": 2})
    d = p.as_dict()
    for key in ("lift", "reynolds", "flow", "dp", "cd", "force", "force_coefficient", "flow_force",
                "pressure_load_multiplier", "u_num"):
        assert key in d
    assert 0.05 < p.cd < 1.0 and 0.3 < p.force_coefficient < 1.2
    assert d["pressure_load_multiplier"] is None


@pytest.mark.parametrize("fid", ["orifice", "thin_film", "axisymmetric"])
@pytest.mark.parametrize("lift, re, field", [(1.5e-3, 10.0, "lift"), (0.0, 10.0, "lift"), ("1e-3", 10.0, "lift"),
                                             (0.5e-3, 0.0, "reynolds"), (0.5e-3, -3.0, "reynolds")])
def test_bad_points_name_the_field(valve, fid, lift, re, field):
    """The Python functions name their arguments (the command line its flags: tests/test_fluid_cli.py)."""
    with pytest.raises(InputError) as err:
        fluid.get(fid, "disc").point(valve, lift, re, {})
    assert err.value.field == field


def test_unknown_or_unavailable_fidelity_is_an_input_error():
    with pytest.raises(InputError, match="name"):
        fluid.get("cfd")
    with pytest.raises(InputError, match="not available|does not model"):
        fluid.get("3d", "disc")


def test_port_wider_than_the_disc_is_refused(valve):
    from dataclasses import replace

    wide = replace(valve.params, port_diameter=2.2 * valve.params.inner_radius)
    with pytest.raises(InputError) as err:
        disc_domain(wide)
    assert err.value.field == "port.diameter"
