"""The modal and FE reed valve in the pump (lumped/reed/structure.py, lumped.valves.reed.reed_accelerations).

Checked against independent numbers: the FE reed's own eigenvalues and static solution (dense
linear algebra on its M, K), eq 3.21 (one mode), the reference stepper (scipy Radau on the Python
physics) and the mass balance; and the model-file keys refused where they make no sense.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.linalg import expm

from geometry.errors import InputError
from lumped import load_model, simulate, with_values
from lumped.solver.layout import BLOCK_OFFSET, POSITIONS, opening
from lumped.solver.problem import PumpProblem
from lumped.reed.structure import structure
from lumped.reed.modal_basis import fe_reed
from lumped.valves.kind import VALVE

GEOMETRY = {"valves.geometry": "prototype", "valves.fidelity": "beam"}


def _model(**delivery):
    """thesis-reed with the prototype geometry (beam fidelity) and the delivery valve's keys given."""
    return with_values(load_model("thesis-reed"), {**GEOMETRY, **{f"valves.delivery.{k}": v for k, v in delivery.items()}})


def _packed(model):
    """(A, B, g, e, q0) of the delivery valve as the pump packed them (lumped.reed.structure.tail)."""
    pr = PumpProblem.build(model, 595.0, 2.76e6)
    o = BLOCK_OFFSET[POSITIONS.index("delivery")]
    n = pr.layout.dofs[1]
    w = int(pr.p[o + VALVE.tail])
    t = pr.p[w:]
    e, g, q0 = t[:n], t[n:2 * n], t[2 * n:3 * n]
    a = t[3 * n:3 * n + n * n].reshape(n, n)
    b = t[3 * n + n * n:3 * n + 2 * n * n].reshape(n, n)
    return a, b, g, e, q0, pr


def test_the_fe_reeds_packed_frequencies_are_its_eigenvalues():
    """eig(M^-1 K) of the packed FE reed = the generalised eigenvalues of its (M, K) (scipy eigh)."""
    a, _, _, _, _, _ = _packed(_model(dynamics="fe"))
    fe = fe_reed(_model().delivery.reed, None, "beam")
    omega_fe, _ = fe.modes()
    lam = np.sort(np.linalg.eigvals(a).real)
    assert np.allclose(np.sqrt(lam[:6]), omega_fe[:6], rtol=1e-8)


@pytest.mark.parametrize("port", [None, (8e-3, 20e-3, 4e-3, 2.5e-3)])
def test_the_modal_static_opening_converges_to_the_fe_reeds(port):
    """A static pressure on the port: x = e . A^-1 g dP of the packed modal reed with N = 1..6 modes against
    the FE reed's e . K^-1 f dP (solved from its own matrices); the error shrinks with N, below 1e-3 at 6."""
    keys = {} if port is None else dict(zip(("port.s_start", "port.s_end", "port.width", "port.y_center"), port))
    a_fe, _, g_fe, e_fe, _, _ = _packed(_model(dynamics="fe", **keys))
    x_fe = e_fe @ np.linalg.solve(a_fe, g_fe)
    errors = []
    for n in range(1, 7):
        a, _, g, e, _, _ = _packed(_model(dynamics="modal", modes=n, **keys))
        errors.append(abs(e @ np.linalg.solve(a, g) / x_fe - 1.0))
    assert errors[-1] < 1e-3 and errors[-1] < errors[0], errors


def test_a_free_modal_reed_follows_the_fe_reed():
    """Released from its static deflection with no flow, contact or damping, the packed modal reed's
    opening (exact solution of q'' = -A q) follows the FE reed's within 0.1 % of the amplitude over 20
    periods with 6 modes (the FE reed's mesh for both)."""
    fe_mesh = fe_reed(_model().delivery.reed, None, "beam").mesh_size

    def history(model, t):
        a, _, g, e, _, _ = _packed(model)
        q_static = np.linalg.solve(a, g)                     # under a unit pressure
        n = len(g)
        big = np.block([[np.zeros((n, n)), np.eye(n)], [-a, np.zeros((n, n))]])
        z0 = np.concatenate([q_static, np.zeros(n)])
        step = expm(big * (t[1] - t[0]))
        out, z = [], z0
        for _ in t:
            out.append(e @ z[:n])
            z = step @ z
        return np.array(out)

    undamped = {"damping.internal": 0.0, "mesh_size": fe_mesh}
    base = with_values(_model(), {"effects.fluid_damping": False})
    modal = with_values(base, {**{f"valves.delivery.{k}": v for k, v in undamped.items()},
                               "valves.delivery.dynamics": "modal", "valves.delivery.modes": 6})
    fe = with_values(base, {**{f"valves.delivery.{k}": v for k, v in undamped.items()},
                            "valves.delivery.dynamics": "fe"})
    omega1 = structure(modal.delivery, 876.0).frequencies[0]
    t = np.linspace(0.0, 20 * 2 * math.pi / omega1, 4001)
    xm, xf = history(modal, t), history(fe, t)
    assert np.max(np.abs(xm - xf)) < 1e-3 * np.max(np.abs(xf))


def test_one_mode_of_the_modal_reed_is_eq_3_21():
    """With one mode the modal reed is eq 3.21 with its integrals over the first mode shape: the same
    delivery within 0.05 % and valve timing within 0.1 deg (the static shape eq 3.21 takes its gammas
    from differs ~1 % in stiffness)."""
    one = simulate(_model(), 595.0, 2.76e6, revolutions=3)
    modal = simulate(_model(dynamics="modal", modes=1), 595.0, 2.76e6, revolutions=3)
    assert modal.delivery_per_rev == pytest.approx(one.delivery_per_rev, rel=5e-4)
    assert abs(modal.delivery.opening_angle - one.delivery.opening_angle) < math.radians(0.1)
    assert modal.dynamics == {"delivery": {"kind": "modal", "modes": 1}} and one.dynamics == {}


@pytest.mark.parametrize("speed, load", [(595.0, 2.76e6), (893.0, 4.5e6)])
def test_the_modal_reed_on_both_steppers(speed, load):
    """Three modes, an off-axis port: fast vs reference within 0.02 % and 0.1 deg; mass balance to 1e-9."""
    m = _model(dynamics="modal", modes=3, **{"port.s_start": 8e-3, "port.s_end": 20e-3, "port.width": 4e-3,
                                           "port.y_center": 2.5e-3})
    r = simulate(m, speed, load, method="reference", revolutions=3)
    f = simulate(m, speed, load, method="fast", revolutions=3)
    assert f.delivery_per_rev == pytest.approx(r.delivery_per_rev, rel=2e-4)
    for a, b in zip((f.inlet.opening_angle, f.delivery.opening_angle, f.delivery.closing_angle),
                    (r.inlet.opening_angle, r.delivery.opening_angle, r.delivery.closing_angle)):
        assert abs(a - b) < math.radians(0.1)
    assert f.mass_balance_error < 1e-9 and r.mass_balance_error < 1e-9


def test_the_opening_is_the_footprints_lift():
    """x = e . q: with one mode and the whole face the tip deflection (e = tip), under an off-axis port a
    torsion-free beam lifts the footprint by the width-mean deflection there."""
    _, _, _, e, _, pr = _packed(_model(dynamics="modal", modes=1))
    s = structure(pr.model.delivery, 876.0)
    assert e[0] == pytest.approx(s.tip[0], rel=1e-12)
    y = np.zeros(pr.layout.n_states)
    y[pr.layout.positions(1)] = 1e-4
    assert opening(y, pr.p, BLOCK_OFFSET[1])[0] == pytest.approx(1e-4 * e[0])


def test_the_modal_participation_sums_to_the_opening():
    """The trace's per-mode signals e_i q_i [m] add up to the opening (a conservation identity of x = e . q), and
    the first mode carries most of it while the valve is open."""
    r = simulate(_model(dynamics="modal", modes=3), 595.0, 2.76e6, revolutions=2, trace=True, trace_points=720)
    s = r.trace.signals
    parts = [s[f"delivery_mode{i}_position"] for i in (1, 2, 3)]
    assert np.max(np.abs(sum(parts) - s["delivery_position"])) <= 1e-12 * np.max(s["delivery_position"])
    is_open = s["delivery_position"] > 0.5 * np.max(s["delivery_position"])
    assert np.all(np.abs(parts[0][is_open]) > 0.8 * s["delivery_position"][is_open])
    assert "inlet_mode1_position" not in s          # the one-mode inlet has no modal signals


@pytest.mark.slow
@pytest.mark.parametrize("speed, load", [(595.0, 2.76e6), (893.0, 2.76e6)])
def test_the_modal_reed_converges_to_the_fe_reed_in_the_pump(speed, load):
    """The prototype reed at both positions: N = 3 and 6 modes against the whole FE reed on the reference
    stepper, delivery within 0.01 % and timing within 0.05 deg; one mode (eq 3.21) within 0.1 %."""
    fe = simulate(with_values(load_model("thesis-reed"), {**GEOMETRY, "valves.dynamics": "fe"}), speed, load,
                  method="reference", revolutions=3)
    for n in (3, 6):
        m = simulate(with_values(load_model("thesis-reed"), {**GEOMETRY, "valves.dynamics": "modal",
                                                             "valves.modes": n}), speed, load, method="reference",
                     revolutions=3)
        assert m.delivery_per_rev == pytest.approx(fe.delivery_per_rev, rel=1e-4)
        assert abs(m.delivery.closing_angle - fe.delivery.closing_angle) < math.radians(0.05)
    one = simulate(_model(), speed, load, method="reference", revolutions=3)
    assert one.delivery_per_rev == pytest.approx(fe.delivery_per_rev, rel=1e-3)


@pytest.mark.parametrize("keys, field", [
    ({"modes": 0, "dynamics": "modal"}, "valves.delivery.modes"),
    ({"modes": 7, "dynamics": "modal"}, "valves.delivery.modes"),
    ({"modes": 3}, "valves.delivery.modes"),
    ({"dynamics": "modal"}, "valves.delivery.modes"),
    ({"dynamics": "modal", "modes": 2, "port.s_start": 0.02, "port.s_end": 0.03, "port.width": 0.005},
     "valves.delivery.port.s_end"),
    ({"dynamics": "modal", "modes": 2, "port.s_start": 0.005}, "valves.delivery.port.s_end"),
    ({"dynamics": "spectral"}, "valves.delivery.dynamics"),
])
def test_bad_dynamics_keys_are_refused_naming_the_key(keys, field):
    with pytest.raises(InputError) as exc:
        _model(**keys)
    assert exc.value.field == field


def test_modal_needs_a_geometry_and_fe_the_reference_stepper():
    with pytest.raises(InputError) as exc:
        with_values(load_model("thesis-reed"), {"valves.delivery.dynamics": "modal", "valves.delivery.modes": 2})
    assert exc.value.field == "valves.delivery.dynamics"
    with pytest.raises(InputError) as exc:
        simulate(_model(dynamics="fe"), 595.0, 2.76e6, method="fast")
    assert exc.value.field == "valves.delivery.dynamics"


def test_the_command_line_reports_the_dynamics(tmp_path, capsys):
    from studies.cli import main

    f = tmp_path / "modal.toml"
    f.write_text('base = "thesis-reed"\n[valves]\ngeometry = "prototype"\n[valves.delivery]\ndynamics = "modal"\n'
                 "modes = 2\n")
    assert main(["pump", "--model", str(f), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["dynamics"] == {"delivery": {"kind": "modal", "modes": 2}}
    f.write_text('base = "thesis-reed"\n[valves]\ngeometry = "prototype"\n[valves.delivery]\ndynamics = "fe"\n')
    assert main(["pump", "--model", str(f), "--json"]) == 2
    assert "valves.delivery.dynamics" in capsys.readouterr().err


def test_the_opening_is_the_first_packed_coordinate():
    """The modal reed's packed coordinates z = S q put the opening first (weights (1, 0, ..)): S T = I, and the
    packed matrices are the modal ones in those coordinates (the eigenvalues of A are the modal omega^2)."""
    from lumped.reed.structure import coordinates

    m = _model(dynamics="modal", modes=3)
    a, _, g, e, _, pr = _packed(m)
    s = structure(pr.model.delivery, 876.0)
    assert np.allclose(e, [1.0, 0.0, 0.0])
    sm, tm = coordinates(s.opening)
    assert np.allclose(sm @ tm, np.eye(3), atol=1e-14)
    lam = np.sort(np.linalg.eigvals(a).real)
    a_modal = np.linalg.solve(s.mass, s.stiffness)
    assert np.allclose(lam, np.sort(np.linalg.eigvals(a_modal).real), rtol=1e-10)
    # the static opening under a unit pressure is a property of the reed, not of its coordinates
    assert e @ np.linalg.solve(a, g) == pytest.approx(s.opening @ np.linalg.solve(s.stiffness, s.load), rel=1e-10)


def test_the_validation_chains_check_of_the_prototype_reed(tmp_path):
    """validate's part (quick: the six-mode reed the reference, saying so): eq 3.21 within 0.1 % delivery and
    0.5 deg of six modes at the fastest case of Table 5.6, the numerics far below; its Markdown and CSV."""
    from studies.validation import reed_dynamics as rd

    r = rd.prototype_adequacy(quick=True, progress=False)
    assert r["reference"] == "modal6" and r["quick"] and "cheaper" in r["note"]
    assert [row["model"] for row in r["rows"]] == ["one-mode", "modal1", "modal2", "modal3", "modal6"]
    s = r["summary"]
    assert s["one_mode_enough"] and s["one_mode_worst_delivery_pct"] < 0.1
    assert s["numerical_pct"] < 0.1 * s["one_mode_worst_delivery_pct"]
    files = rd.write_adequacy(r, tmp_path / "reed_dynamics")
    text = (tmp_path / "reed_dynamics.md").read_text()
    assert "adequate for the prototype reed" in text and len(files) == 2
    assert json.dumps(r)                              # plain JSON types only


def test_the_study_tables_follow_its_runs(tmp_path):
    """The study's machinery on one reed, one case, three models (eq 3.21, one and two modes; two the reference):
    every table row is a run, the verdict follows the numbers, and the files are written."""
    from studies.validation import reed_dynamics as rd
    from studies.validation.chain import cases

    case = rd.ReedCase("prototype", _model().delivery.reed, "beam", {}, "test")
    op = cases(valve="reed")[0]
    models = rd.variants(case, modes=(1, 2), fe=False)
    by_label, _ = rd.run_point(case, op, revolutions=2, method="fast", models=models)
    rd._against(by_label, "modal2")
    assert by_label["modal2"]["delivery_vs_reference_pct"] == 0.0
    # one mode of the modal reed is eq 3.21 with its integrals over the first mode (within 0.05 %)
    assert abs(by_label["modal1"]["delivery_cc"] / by_label["one-mode"]["delivery_cc"] - 1.0) < 5e-4
    summary = rd._summary(case, list(by_label.values()), reference="modal2")
    assert summary["modes_needed"] == (1 if rd._within(rd._worst(list(by_label.values()), "modal1")) else None)
    study = {"reeds": [summary], "rows": list(by_label.values()), "numerics": [], "traces": {},
             "tolerances": {"delivery_pct": 0.1, "angle_deg": 0.5, "method": "fast", "fast_rtol": rd.FAST_RTOL}}
    md = rd.markdown(study)
    assert md.count("| eq 3.21 (one mode) |") == 2 and "| modal1 |" in md
    files = rd.write_outputs(study, tmp_path)
    assert json.loads((tmp_path / "reed_dynamics.json").read_text())["reeds"][0]["reed"] == "prototype"
    assert len(files) == 3


def test_check_flags_of_the_pump_study_need_it(capsys):
    from studies.cli import main

    assert main(["check", "prototype", "--markdown"]) == 2
    err = capsys.readouterr().err
    assert "--markdown" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("keys, field", [
    ('dynamics = "modal"\nmodes = 0\n', "valves.delivery.modes"),
    ('dynamics = "modal"\nmodes = 7\n', "valves.delivery.modes"),
    ('dynamics = "modal"\nmodes = 2\nport.s_start = 0.02\nport.s_end = 0.03\nport.width = 0.005\n',
     "valves.delivery.port.s_end"),
    ('dynamics = "fe"\n', "valves.delivery.dynamics"),
])
def test_bad_dynamics_keys_exit_2_on_the_command_line(tmp_path, capsys, keys, field):
    """Before any simulation: exit 2, one line on stderr naming the key (the default method is the fast one)."""
    from studies.cli import main

    f = tmp_path / "bad.toml"
    f.write_text('base = "thesis-reed"\n[valves]\ngeometry = "prototype"\n[valves.delivery]\n' + keys)
    assert main(["pump", "--model", str(f), "--json"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and field in captured.err and len(captured.err.strip().splitlines()) == 1


def test_check_dynamics_quick_runs_one_reed_at_one_case(monkeypatch, capsys):
    """--quick is what its help says: this reed, the first case of Table 5.6, every model (no derived reeds, no
    fast-stepper check); the plan is said with its estimate before anything runs."""
    from studies.cli import main
    from studies.validation import reed_dynamics as rd
    from studies.validation.chain import cases

    seen = {}

    class Stop(Exception):
        pass

    def fake(reeds, ops, **kw):
        seen.update(reeds=reeds, ops=ops, **kw)
        raise Stop

    monkeypatch.setattr(rd, "dynamics_study", fake)
    assert main(["check", "prototype", "--dynamics", "--quick"]) == 1        # Stop: the CLI's internal error
    assert [r.name for r in seen["reeds"]] == ["prototype"] and seen["ops"] == cases(valve="reed")[:1]
    assert seen["numerics"] is False
    err = capsys.readouterr().err.splitlines()[0]
    n_runs = len(rd.variants(seen["reeds"][0]))
    assert err.startswith(f"valvelab check: {n_runs} pump runs of 3 revolutions and 1 solid FEA")
    assert "low speed inlet, 595 rpm, 2.76 MPa" in err
    estimate = rd.estimate_seconds(seen["reeds"], seen["ops"], 3, numerics=False)
    assert estimate < 60 and f"about {estimate:.0f} s" in err
    # the full study: every reed at every case, its count and estimate from the same per-run costs
    assert main(["check", "prototype", "--dynamics"]) == 1
    assert len(seen["reeds"]) == 6 and len(seen["ops"]) == 6 and seen["numerics"] is True
    runs = sum(len(rd.variants(r)) for r in seen["reeds"]) * 6 + 6
    assert f"{runs} pump runs" in capsys.readouterr().err


def test_the_study_progress_total_is_its_steps(capsys, monkeypatch):
    """The progress count's total, known from the start, is the number of steps it counts (runs and the FEA)."""
    from studies.validation import reed_dynamics as rd
    from studies.validation.chain import cases

    monkeypatch.setattr(rd, "variants", lambda case, modes=rd.MODES, fe=True: [("one-mode", {"dynamics": "one-mode"})])
    against = rd._against
    monkeypatch.setattr(rd, "_against", lambda by_label, reference: against(by_label, "one-mode"))
    case = rd.ReedCase("prototype", _model().delivery.reed, "beam", {}, "test")
    ops = cases(valve="reed")[:2]
    study = rd.dynamics_study([case], ops, revolutions=2, traces=False, numerics=False)
    total = rd.runs_count([case], ops, numerics=False)
    assert total == 3 and len(study["rows"]) == 2 and study["numerics"] == []
    steps = [x for x in capsys.readouterr().err.split("\r") if x.startswith("reed dynamics:")]
    assert [s.split()[2] for s in steps] == [f"{k}/{total}" for k in range(1, total + 1)]
