"""Meshes scaled to the part: default sizes from the reed's own dimensions, the same relative
accuracy from a 5 mm strip to a 10 m plate, and DOF/memory estimates that refuse (exit 2,
naming --mesh-size) what the machine cannot hold instead of running out of memory."""

import time
from dataclasses import replace

import numpy as np
import pytest

from fea import beam, plate, solid
from fea.mesh import face_mesh, grading_length, reference_length
from fea.resources import memory_limit
from geometry import THESIS_PRESETS, InputError, load_reed, parse_reed

STEEL = {"youngs_modulus": 200e9, "density": 7850.0, "poisson_ratio": 0.3}


def _scaled(reed, c):
    """The reed with every length times c (omega scales as 1/c, kappa = p/w as 1/c)."""
    return replace(reed, length=reed.length * c, thickness=reed.thickness * c, width_root=reed.width_root * c,
                   width_tip=reed.width_tip * c, tip_radius=reed.tip_radius * c)


def _plate_file(tmp_path, name, L, W, h, density=8000.0):
    import tomli_w

    p = tmp_path / f"{name}.toml"
    p.write_text(tomli_w.dumps({"reed": {"name": name, "length": L, "thickness": h, "width_tip": W,
                                         "material": {**STEEL, "density": density}}}))
    return p


def test_thesis_reeds_keep_their_sizes():
    for name in THESIS_PRESETS:
        r = load_reed(name)
        assert (beam.default_mesh_size(r), plate.default_mesh_size(r), solid.default_mesh_size(r)) == (
            1.27e-4, 2e-3, 1e-3)
        assert grading_length(r) == 3e-3 and solid.default_layers(r) == 1


@pytest.mark.parametrize("c", [0.2, 400.0])
def test_a_scaled_reed_gets_the_same_relative_mesh_and_accuracy(c):
    """stepped #2 shrunk to 5 mm or grown to 10 m: sizes and grading scale with it, and omega, kappa
    scale exactly as 1/c (the same discretisation relative to the part)."""
    base = load_reed("stepped2")
    big = _scaled(base, c)
    assert reference_length(big) == pytest.approx(c * reference_length(base))
    for mod in (beam, plate):
        a, b = mod.solve(base), mod.solve(big)
        assert b.mesh_size == pytest.approx(c * a.mesh_size, rel=1e-5)
        assert b.dofs == a.dofs
        # gmsh places a few nodes differently at other scales (1e-5 here), far below the 0.5 %
        # discretisation error of this mesh
        assert b.omega_n * c == pytest.approx(a.omega_n, rel=1e-4)
        assert b.kappa * c == pytest.approx(a.kappa, rel=1e-4)
    fa, fb = face_mesh(base, 1e-3, quad=True, half=True), face_mesh(big, c * 1e-3, quad=True, half=True)
    assert fb.mesh.t.shape[1] == pytest.approx(fa.mesh.t.shape[1], rel=0.05)


def test_fv16_plate_runs_at_the_default_mesh(cli, tmp_path):
    """The 10 m x 10 m x 0.05 m plate was refused as 'too fine'; it runs and gives six modes."""
    f = _plate_file(tmp_path, "fv16", 10.0, 10.0, 0.05)
    t0 = time.perf_counter()
    rc, out, err, obj = cli("reed", f, "--fidelity", "plate", "--modes", "6", "--json")
    assert rc == 0, err
    assert time.perf_counter() - t0 < 120
    assert obj["mesh_size"] == pytest.approx(10.0 / 12.7, rel=1e-5)
    # thin-plate theory: f1 = 3.4710 / (2 pi a^2) sqrt(D / rho h) = 0.41793 Hz
    assert obj["frequencies"][0] / (2 * np.pi) == pytest.approx(0.41793, rel=2e-4)
    assert len(obj["frequencies"]) == len(obj["mode_kinds"]) == 6


@pytest.mark.parametrize("dims", [(5e-3, 1e-3, 0.05e-3), (100e-3, 10e-3, 0.5e-3)],
                         ids=["strip_5x1x0.05mm", "plate_100x10x0.5mm"])
def test_small_and_slender_parts_run_with_defaults_plate_and_beam(dims):
    """Length, width, thickness: the plate at its default mesh lies between E-B and the
    cylindrical-bending limit 1 / sqrt(1 - nu^2), as for the thesis reeds."""
    L, W, h = dims
    reed = parse_reed({"reed": {"length": L, "width_tip": W, "thickness": h, "material": STEEL}})
    b, p = beam.solve(reed), plate.solve(reed)
    assert b.mesh_size == pytest.approx(L / 200)
    assert b.omega_n < p.omega_n < b.omega_n / np.sqrt(1 - 0.3**2)
    assert p.labels[0] == "bending 1"


def test_memory_estimate_refuses_with_one_line(cli, tmp_path, monkeypatch):
    """A limit below the FV16 solid's estimate (VALVELAB_MEMORY_LIMIT stands for a small machine)."""
    f = _plate_file(tmp_path, "fv16", 10.0, 10.0, 0.05)
    monkeypatch.setenv("VALVELAB_MEMORY_LIMIT", "200M")
    rc, out, err = cli("reed", f, "--fidelity", "solid")
    assert rc == 2 and out == "" and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert "--mesh-size" in err and "DOFs" in err and "GB" in err and "VALVELAB_MEMORY_LIMIT" in err


@pytest.mark.parametrize("fid", ["beam", "plate", "solid"])
def test_an_absurd_mesh_is_refused_before_meshing(fid):
    """1e-5 m elements on a 10 m plate: refused from the geometry alone, in well under a second."""
    reed = parse_reed({"reed": {"length": 10.0, "width_tip": 10.0, "thickness": 0.05, "material": STEEL}})
    mod = {"beam": beam, "plate": plate, "solid": solid}[fid]
    size = 1e-8 if fid == "beam" else 1e-5
    t0 = time.perf_counter()
    with pytest.raises(InputError) as exc:
        mod.solve(reed, size)
    assert time.perf_counter() - t0 < 2.0
    assert exc.value.field == "--mesh-size" and "DOFs" in exc.value.message
    assert memory_limit() > 0
