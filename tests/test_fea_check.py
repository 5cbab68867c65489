"""The multi-fidelity check (studies.validation.reed_check, valvelab check) and the FEA fidelities of valvelab reed."""

import json

import pytest

from geometry import load_reed, parse_reed
from studies.validation.reed_check import multi_fidelity_check

# a reed unlike the presets: narrower, thinner, a half-round tip on a short step, and one
# off-centre groove (no mirror symmetry: the solid runs the full model)
OTHER = """
[reed]
name = "other"
length = 20.0e-3
thickness = 1.0e-3
width_root = 6.0e-3
width_tip = 10.0e-3
step_fraction = 0.25
tip_radius = 5.0e-3

[reed.material]
youngs_modulus = 3.1e9
density = 1420.0
poisson_ratio = 0.35

[[reed.grooves]]
s_start = 6.0e-3
s_end = 14.0e-3
y_center = 2.0e-3
width = 1.5e-3
depth = 0.3e-3
"""


@pytest.fixture(scope="module")
def other_check():
    import tomllib

    reed = parse_reed(tomllib.loads(OTHER), "other")
    return multi_fidelity_check(reed, ("analytic", "beam", "plate", "solid"), mesh_size=1.5e-3, progress=False)


def test_other_shape_runs_through_every_fidelity(other_check):
    c = other_check
    ran = [r["fidelity"] for r in c["rows"]]
    assert ran == ["analytic", "beam", "plate", "solid"]
    assert c["reference"] == "solid"
    rows = {r["fidelity"]: r for r in c["rows"]}
    assert all(v == 0.0 for v in rows["solid"]["deviation_pct"].values())
    # the three theories agree on this slender reed within a few percent
    for fid in ("beam", "plate"):
        assert abs(rows[fid]["deviation_pct"]["omega_n"]) < 5
        assert abs(rows[fid]["deviation_pct"]["kappa"]) < 8
        assert abs(rows[fid]["deviation_pct"]["gamma1"]) < 1


def test_flags_and_selection_follow_the_tolerance(other_check):
    c = other_check
    for r in c["rows"]:
        assert r["flags"] == [q for q, d in r["deviation_pct"].items() if abs(d) > c["tolerance_pct"]]
    sel = c["selected"]
    eb = next(r for r in c["rows"] if r["fidelity"] in ("analytic", "beam"))
    assert sel["fidelity"] == (eb["fidelity"] if not eb["flags"] else "solid")
    assert sel["properties"].fidelity == sel["fidelity"]


def test_tight_tolerance_selects_the_reference():
    reed = load_reed("stepped1")
    c = multi_fidelity_check(reed, ("beam", "plate"), tolerance_pct=0.01, progress=False)
    assert c["reference"] == "plate"
    assert "beam.kappa" in c["flagged"]
    assert c["selected"]["fidelity"] == "plate"


def test_cli_check_json_and_text(cli, tmp_path):
    f = tmp_path / "other.toml"
    f.write_text(OTHER)
    rc, out, err, obj = cli("check", f, "--fidelities", "beam,plate", "--json")
    assert rc == 0, err
    assert [r["fidelity"] for r in obj["rows"]] == ["beam", "plate"]
    assert obj["selected"]["properties"]["omega_n"] > 0
    assert "check other" in err  # progress on stderr
    rc, out, err = cli("check", "stepped1", "--fidelities", "beam,plate")
    assert rc == 0 and "feeds the pump model" in out


@pytest.mark.parametrize("args,field", [
    (("check", "stepped1", "--fidelities", "beam,fem"), "--fidelities"),
    (("check", "stepped1", "--tolerance-pct", "-1"), "--tolerance-pct"),
    (("check", "stepped1", "--mesh-size", "0"), "--mesh-size"),
    (("check", "nope.toml"), "nope.toml"),
    (("reed", "stepped1", "--fidelity", "plate", "--mesh-size", "1.0"), "--mesh-size"),
])
def test_cli_bad_input_is_one_line(cli, args, field):
    rc, out, err = cli(*args)
    assert rc == 2 and field in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_cli_reed_fidelities_follow_the_contract(cli):
    rc, out, err, obj = cli("reed", "stepped1", "--fidelity", "beam", "--json")
    assert rc == 0, err
    assert set(obj) >= {"geometry", "fidelity", "omega_n", "kappa", "gamma1", "gamma2", "gamma3", "dofs", "mesh_size"}
    assert obj["fidelity"] == "beam" and obj["dofs"] > 0
    assert obj["kappa"] == pytest.approx(7.345e6, rel=1e-4)
    rc, out, err, obj = cli("reed", "stepped1", "--fidelity", "plate", "--mesh-size", "3e-3", "--json")
    assert rc == 0, err
    assert obj["mesh_size"] == 3e-3 and obj["omega_n"] == pytest.approx(2437, rel=0.01)


def test_cli_check_writes_shapes_and_vtu(cli, tmp_path):
    out_dir = tmp_path / "out"
    rc, out, err, obj = cli("check", "stepped1", "--fidelities", "beam,solid", "--mesh-size", "2.5e-3",
                            "--out", out_dir, "--json")
    assert rc == 0, err
    names = {p.name for p in out_dir.iterdir()}
    assert {"shapes.png", "solid_modes.vtu"} <= names
    import meshio

    m = meshio.read(out_dir / "solid_modes.vtu")
    assert any("torsion" in k for k in m.point_data) and any("bending" in k for k in m.point_data)
    # a folder valvelab did not make is refused
    user = tmp_path / "mine"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    rc, out, err = cli("check", "stepped1", "--fidelities", "beam", "--out", user)
    assert rc == 2 and "--out" in err
    json.dumps(obj)
