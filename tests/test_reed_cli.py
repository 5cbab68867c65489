"""`valvelab reed --fidelity analytic` and the chapter 3 tables on the command line (CONTRACT.md).

A few runs go through a real subprocess (the ``cli`` fixture); the rest call
``studies.cli.main`` in-process, which is the same code without the interpreter start-up.
"""

import json

import pytest

from studies.cli import main
from studies.tables.thesis import thesis_values

TV = thesis_values()


def run(capsys, *args):
    """main(ARGS) in-process: (rc, stdout, stderr, parsed JSON or None)."""
    try:
        rc = main([str(a) for a in args])
    except SystemExit as e:  # argparse errors
        rc = e.code
    out, err = capsys.readouterr()
    try:
        obj = json.loads(out) if "--json" in args else None
    except json.JSONDecodeError:
        obj = None
    return rc, out, err, obj


def test_reed_stepped1_analytic_json(cli):
    rc, out, err, obj = cli("reed", "stepped1", "--fidelity", "analytic", "--json")
    assert rc == 0, err
    assert obj["geometry"] == "stepped1" and obj["fidelity"] == "analytic"
    assert obj["omega_n"] == pytest.approx(TV["table_3_3"]["stepped1"]["omega_eb"], rel=1e-3)
    assert obj["kappa"] == pytest.approx(TV["table_3_9"]["eb_direct"]["kappa"], rel=1e-3)
    assert obj["gamma1"] == pytest.approx(TV["table_3_8"]["stepped1/load"]["gamma1"], rel=1e-3)
    assert obj["dofs"] is None and obj["mesh_size"] is None


def test_reed_plot_refuses_to_overwrite(cli, capsys, tmp_path):
    png = tmp_path / "shape.png"
    rc, out, err = cli("reed", "prototype", "--plot", png)
    assert rc == 0, err
    assert png.stat().st_size > 10_000 and "omega_n" in out
    before = png.read_bytes()
    rc, out, err, obj = run(capsys, "reed", "prototype", "--plot", png)
    assert rc == 2 and "--plot" in err and "--force" in err and "Traceback" not in err
    assert png.read_bytes() == before
    rc, out, err, obj = run(capsys, "reed", "uniform", "--plot", png, "--force", "--json")
    assert rc == 0 and obj["plot"] == str(png) and png.read_bytes() != before
    rc, out, err, obj = run(capsys, "reed", "uniform", "--plot", tmp_path / "shape.txt")
    assert rc == 2 and "--plot" in err


BAD = [
    ("length=0.0254\nthickness=1.35e-3\nwidth_tip=0.0159\ntip_radius=0.02\n", "reed.tip_radius"),
    ("length=0.0254\nthickness=1.35e-3\nwidth_tip=0.0159\nstep_fraction=0.3\n", "reed.width_root"),
    ("length=-0.0254\nthickness=1.35e-3\nwidth_tip=0.0159\n", "reed.length"),
    ("length=0.0254\nthickness=nan\nwidth_tip=0.0159\n", "reed.thickness"),
    ("length=0.0254\nthickness=1.35e-3\nwidth_tip=0.0159\n[[reed.grooves]]\ns_start=0.0\ns_end=0.01\n"
     "y_center=0.0\nwidth=1e-3\ndepth=2e-3\n", "reed.grooves[0].depth"),
]


def _bad_file(tmp_path, body):
    f = tmp_path / "bad.toml"
    mat = "[reed.material]\nyoungs_modulus=2.9e9\ndensity=1410.0\npoisson_ratio=0.35\n"
    head, sep, grooves = body.partition("[[reed.grooves]]")  # material before the groove array
    f.write_text("[reed]\n" + head + mat + (sep + grooves if sep else ""))
    return f


def test_bad_geometry_exits_2_in_a_subprocess(cli, tmp_path):
    body, field = BAD[-1]
    rc, out, err, obj = cli("reed", _bad_file(tmp_path, body), "--fidelity", "analytic", "--json")
    assert rc == 2 and out == "" and field in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("body,field", BAD)
def test_bad_geometry_named(capsys, tmp_path, body, field):
    rc, out, err, obj = run(capsys, "reed", _bad_file(tmp_path, body), "--json")
    assert rc == 2 and out == "" and field in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("tid,key,n", [("3.8", "case", 5), ("3.9", "method", 2), ("3.11", "case", 4),
                                       ("3.12", "F4", 3), ("3.13", "quantity", 10)])
def test_chapter_3_tables_json(capsys, tid, key, n):
    rc, out, err, obj = run(capsys, "table", tid, "--json")
    assert rc == 0, err
    assert obj["id"] == tid and len(obj["rows"]) >= n
    assert all(key in row for row in obj["rows"])
    assert any(k.startswith("thesis_") for k in obj["rows"][0])


def test_table_3_8_rows_match_thesis(capsys):
    rows = run(capsys, "table", "3.8", "--json")[3]["rows"]
    assert [r["case"] for r in rows] == ["uniform/free", "uniform/load", "stepped1/free", "stepped1/load",
                                         "stepped2/load"]
    for row in rows:
        for i in (1, 2, 3):
            assert row[f"gamma{i}"] == pytest.approx(row[f"thesis_gamma{i}"], rel=1e-3)


def test_table_text_and_figure(cli, capsys, tmp_path):
    rc, out, err = cli("table", "3.12")
    assert rc == 0 and out.startswith("Table 3.12") and "thesis_X" in out and "note:" in out
    png = tmp_path / "fig312.png"
    rc, out, err, obj = run(capsys, "table", "3.8", "--plot", png, "--json")
    assert rc == 0 and png.stat().st_size > 10_000 and obj["plot"] == str(png)
    rc, out, err, obj = run(capsys, "table", "3.9", "--plot", tmp_path / "x.png")
    assert rc == 2 and "--plot" in err


def test_user_reed_file_matches_closed_forms(capsys, tmp_path):
    """A 30 mm long, 0.8 mm thick steel reed with a 10/20 mm step at 30 % (square tip): eq 3.7 and eq 3.40."""
    from lumped.reed import euler_bernoulli as rb

    f = tmp_path / "steel.toml"
    f.write_text("[reed]\nlength = 30e-3\nthickness = 0.8e-3\nwidth_root = 10e-3\nwidth_tip = 20e-3\n"
                 "step_fraction = 0.3\ntip_radius = 0.0\n[reed.material]\nyoungs_modulus = 200e9\n"
                 "density = 7850.0\npoisson_ratio = 0.3\n")
    rc, out, err, obj = run(capsys, "reed", f, "--json")
    assert rc == 0, err
    alpha = rb.stepped_frequency_parameter(0.3, 2.0)
    assert obj["omega_n"] == pytest.approx(rb.uniform_natural_frequency(200e9, 7850.0, 0.8e-3, 30e-3, alpha), rel=1e-10)
    assert obj["kappa"] == pytest.approx(rb.stiffness_eq_3_40(200e9, 0.8e-3, 10e-3, 20e-3, 9e-3, 21e-3), rel=1e-10)
    assert obj["geometry"] == str(f)
