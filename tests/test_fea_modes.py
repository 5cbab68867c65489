"""Every mode: names by nodal pattern (fea.modes), `reed --modes`, `check --modes`, `modes --fidelity`."""

import numpy as np
import pytest

from fea import beam, plate
from fea.modes import describe_mode, face_grid
from geometry import load_reed
from lumped.reed import euler_bernoulli as rb


def _field(reed, fn):
    s, eta, wts, W, _ = face_grid(reed)
    S, E = np.meshgrid(s / reed.length, eta, indexing="ij")
    return fn(S, E), (s, eta, wts, W)


@pytest.mark.parametrize("fn,label", [
    (lambda s, e: s**2, "bending 1"),
    (lambda s, e: np.cosh(4.694 * s) - np.cos(4.694 * s) - 1.0185 * (np.sinh(4.694 * s) - np.sin(4.694 * s)),
     "bending 2"),
    (lambda s, e: s * e, "torsion 1"),
    (lambda s, e: np.sin(4.0 * s) * e, "torsion 2"),
    (lambda s, e: s**2 * (1.5 * e**2 - 0.5), "plate (0,2)"),
    (lambda s, e: s**2 * (1 + 0.9 * e), "bending-torsion 1,1"),
    (lambda s, e: np.sin(5 * s) * (2.5 * e**3 - 1.5 * e), "plate (1,3)"),
])
def test_nodal_pattern_names(fn, label):
    """Fields with a known pattern: P0 (bending), P1 (torsion), P2.. (plate), mixtures; nodal lines
    across the reed counted along s."""
    reed = load_reed("uniform")
    w, (s, eta, wts, W) = _field(reed, fn)
    assert describe_mode(w, s, eta, wts, W)[1] == label


def test_plate_modes_of_the_thesis_reed_follow_beam_and_torsion_theory():
    """Uniform reed: bending 1, torsion 1, bending 2, torsion 2; the bending pair near E-B
    (ratio 6.27 of cos a cosh a = -1), torsion 2 / torsion 1 near 3 (St Venant, clamped-free)."""
    r = plate.modes(load_reed("uniform"), 4)
    assert r.labels == ["bending 1", "torsion 1", "bending 2", "torsion 2"]
    assert r.kinds == ["bending", "torsion", "bending", "torsion"]
    assert r.omega[2] / r.omega[0] == pytest.approx((4.6941 / 1.8751) ** 2, rel=0.03)
    assert r.omega[3] / r.omega[1] == pytest.approx(3.0, rel=0.2)
    freqs, kinds = r.first(3)
    assert kinds == ["bending 1", "torsion 1", "bending 2"] and freqs[0] == pytest.approx(r.omega_n)


def test_beam_and_analytic_modes_agree_and_are_labelled_bending():
    reed = load_reed("prototype")
    a, b = rb.modes(reed, 5), beam.modes(reed, 5)
    assert a.labels == b.labels == [f"bending {k}" for k in range(1, 6)]
    assert b.omega == pytest.approx(a.omega, rel=5e-4)


def test_cli_reed_modes_json(cli):
    rc, out, err, obj = cli("reed", "stepped2", "--fidelity", "plate", "--modes", "5", "--json")
    assert rc == 0, err
    assert len(obj["frequencies"]) == 5 and obj["mode_kinds"][:2] == ["bending 1", "torsion 1"]
    assert obj["frequencies"] == sorted(obj["frequencies"]) and obj["frequencies"][0] == obj["omega_n"]
    rc, out, err, obj = cli("reed", "stepped2", "--modes", "3", "--json")   # analytic
    assert rc == 0 and obj["mode_kinds"] == ["bending 1", "bending 2", "bending 3"]
    assert obj["dofs"] is None and obj["frequencies"][0] == pytest.approx(obj["omega_n"], rel=1e-9)
    rc, out, err = cli("reed", "stepped2", "--modes", "0")
    assert rc == 2 and "--modes" in err and len(err.strip().splitlines()) == 1


def test_check_compares_modes_by_name():
    from studies.validation.reed_check import multi_fidelity_check

    c = multi_fidelity_check(load_reed("stepped1"), ("analytic", "plate"), mesh_size=3e-3, progress=False, modes=3)
    rows = {r["fidelity"]: r for r in c["rows"]}
    assert c["reference"] == "plate" and c["modes"]["count"] == 3
    assert rows["plate"]["mode_kinds"] == ["bending 1", "torsion 1", "bending 2"]
    dev = rows["analytic"]["mode_deviation_pct"]
    assert dev["bending 3"] is None                           # not among the plate's first three
    w = dict(zip(rows["analytic"]["mode_kinds"], rows["analytic"]["frequencies"]))
    p = dict(zip(rows["plate"]["mode_kinds"], rows["plate"]["frequencies"]))
    assert dev["bending 2"] == pytest.approx((w["bending 2"] - p["bending 2"]) / p["bending 2"] * 100)
    assert "torsion 1" not in dev


@pytest.mark.parametrize("fidelity", ["analytic", "beam", "plate"])
def test_cli_modes_every_fidelity_honours_mesh_size(cli, tmp_path, fidelity):
    out = tmp_path / f"m_{fidelity}"
    rc, stdout, err, obj = cli("modes", "stepped1", "--fidelity", fidelity, "--modes", "4", "--mesh-size", "3e-3",
                               "--out", out, "--json")
    assert rc == 0, err
    names = {p.name for p in out.iterdir()}
    assert {"stepped1_" + fidelity + "_mode_shapes.png", "mode_shapes.png"} <= names
    assert (f"stepped1_{fidelity}_modes.vtu" in names) == (fidelity != "analytic")
    ms = obj["modes"]["stepped1"]
    assert [m["label"] for m in ms][0] == "bending 1" and len(ms) == 4
    assert all(m["omega"] > 0 for m in ms) and obj["fidelity"] == fidelity


def test_cli_modes_solid(cli, tmp_path):
    import meshio

    rc, stdout, err, obj = cli("modes", "uniform", "--modes", "3", "--mesh-size", "3e-3", "--out", tmp_path / "s",
                               "--json")
    assert rc == 0, err
    ms = obj["modes"]["uniform"]
    assert [m["label"] for m in ms] == ["bending 1", "torsion 1", "bending 2"]
    m = meshio.read(tmp_path / "s" / "uniform_solid_modes.vtu")
    assert any("torsion_1" in k for k in m.point_data)


def test_cli_modes_bad_mesh_size_is_one_line(cli, tmp_path):
    rc, out, err = cli("modes", "stepped1", "--fidelity", "beam", "--mesh-size", "1.0", "--out", tmp_path / "x")
    assert rc == 2 and "--mesh-size" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()
