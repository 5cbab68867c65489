"""Meshes from the one reed description (fea.mesh): areas, volumes, pockets, loads, grading, VTU."""

import math

import meshio
import numpy as np
import pytest

from fea.mesh import face_mesh, is_symmetric, line_mesh, solid_mesh, write_vtu
from fea.solid import _scalar_basis, pressure_load
from geometry import PRESETS, InputError, load_reed



def _areas(mesh):
    p, t = mesh.p, mesh.t
    x, y = p[0, t], p[1, t]
    n = t.shape[0]
    return 0.5 * sum(x[i] * y[(i + 1) % n] - x[(i + 1) % n] * y[i] for i in range(n))


def _groove_area(reed):
    area = 0.0
    for g in reed.grooves:
        area += g.width * (g.s_end - g.s_start) if g.kind == "rect" else math.pi / 2 * (g.r_outer**2 - g.r_inner**2)
    return area


@pytest.mark.parametrize("name", PRESETS)
@pytest.mark.parametrize("quad", [False, True])
def test_face_mesh_covers_the_outline_and_its_grooves(name, quad):
    reed = load_reed(name)
    fm = face_mesh(reed, 1e-3, quad=quad)
    a = np.abs(_areas(fm.mesh))  # (skfem sorts triangle vertices; orientation is irrelevant there)
    assert np.all(a > 1e-14)
    # polygonal tip arcs lose at most the chord segments: < 0.1 % of the face
    assert a.sum() == pytest.approx(reed.face_area, rel=1e-3)
    assert a[fm.depth > 0].sum() == pytest.approx(_groove_area(reed), rel=2e-3)
    # the tip point (L, 0) and the centre line are nodes
    p = fm.mesh.p
    assert np.min(np.hypot(p[0] - reed.length, p[1])) < 1e-12
    assert np.sum(np.abs(p[1]) < 1e-12) >= 10


def test_mesh_is_graded_toward_the_clamp_and_reproducible():
    reed = load_reed("stepped1")
    a, b = face_mesh(reed, 1e-3), face_mesh(reed, 1e-3)
    assert np.array_equal(a.mesh.p, b.mesh.p) and np.array_equal(a.mesh.t, b.mesh.t)
    p = a.mesh.p
    clamp = np.sort(p[1][p[0] < 1e-12])
    assert np.max(np.diff(clamp)) < 0.25e-3  # 0.15 x 1 mm at the clamp, not 1 mm


@pytest.mark.parametrize("name", ["stepped2", "prototype"])
@pytest.mark.parametrize("half", [False, True])
def test_solid_volume_and_pressure_resultant(name, half):
    """Volume = h A_face - pocket volume; the pressure on the wetted face sums to p A_face along z."""
    reed = load_reed(name)
    sm = solid_mesh(reed, 1.5e-3, half=half)
    basis = _scalar_basis(sm.mesh)
    vol = basis.dx.sum()
    factor = 0.5 if half else 1.0
    assert vol == pytest.approx(factor * reed.mass / reed.material.density, rel=2e-3)
    f = pressure_load(sm, basis, pressure=1.0)
    assert f[2::3].sum() == pytest.approx(factor * reed.face_area, rel=2e-3)
    # pocket walls cancel, except where a groove runs out through the unloaded clamp or step face
    def opens(g):
        at_step = abs(g.s_start - reed.step_location) < 1e-12 and abs(g.y_center) - g.width / 2 >= reed.width_root / 2
        return g.kind == "rect" and (g.s_start == 0.0 or at_step)

    open_area = sum(g.width * g.depth for g in reed.grooves if opens(g))
    assert f[0::3].sum() == pytest.approx(factor * open_area, abs=1e-9 * reed.face_area)
    if reed.grooves:  # pockets: no material below the groove depth inside a groove
        x = sm.mesh.p
        inside = reed.groove_depth(x[0], x[1]) > 0
        assert np.all(x[2][inside] >= reed.grooves[0].depth - 1e-12) or np.any(~inside)


def test_line_mesh_has_nodes_on_breakpoints():
    reed = load_reed("prototype")
    m = line_mesh(reed, 1e-3)
    for b in reed.breakpoints():
        assert np.min(np.abs(m.p[0] - b)) < 1e-15
    assert np.max(np.diff(np.sort(m.p[0]))) <= 1e-3 + 1e-15


def test_symmetry_detection():
    assert all(is_symmetric(load_reed(n)) for n in PRESETS)
    from dataclasses import replace

    proto = load_reed("prototype")
    assert not is_symmetric(replace(proto, grooves=proto.grooves[:1]))


def test_vtu_export(tmp_path):
    sm = solid_mesh(load_reed("stepped1"), 2e-3)
    path = tmp_path / "reed.vtu"
    write_vtu(path, sm.mesh, {"z": sm.mesh.p[2]})
    m = meshio.read(path)
    assert m.points.shape[0] == sm.mesh.p.shape[1] and "z" in m.point_data


@pytest.mark.parametrize("size", [0.0, -1e-3, float("nan"), 1.0])
def test_bad_mesh_size_is_an_input_error(size):
    with pytest.raises(InputError, match="--mesh-size"):
        face_mesh(load_reed("uniform"), size)
