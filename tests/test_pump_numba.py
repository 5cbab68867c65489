"""The pump's physics must stay numba-compilable (the fast path builds on the same source)."""

import importlib

import numpy as np
import pytest

# module -> functions, callees before callers; every module-level name bound to one of them
# (``from x import f``) is rebound to the compiled version before its callers compile
CHAIN = [
    ("lumped.oil", ["density", "density_slope", "pressure_iterations", "pressure"]),
    ("lumped.orifice", ["discharge_coefficient", "discharge_slope", "laminar_slope", "orifice_flow"]),
    ("lumped.disc_valve", ["contact_state", "contact_force", "displacement_area", "valve_flow", "pressure_force",
                           "disc_acceleration"]),
    ("lumped.reed_valve", ["pressure_load_multiplier", "reed_acceleration"]),
    ("lumped.pump", ["cylinder_volume", "load_mass", "load_pressure", "needle_mass_flow", "valve_acceleration",
                     "evaluate", "rhs"]),
]


@pytest.mark.slow
def test_rhs_compiles_with_numba_and_matches_python(monkeypatch):
    numba = pytest.importorskip("numba")
    from lumped.params import pack, thesis_model

    py = {}
    compiled = {}
    for modname, names in CHAIN:
        mod = importlib.import_module(modname)
        for n in names:
            py[(modname, n)] = getattr(mod, n)
    for modname, names in CHAIN:
        mod = importlib.import_module(modname)
        for other, fn in compiled.items():          # rebind imported callees in this module
            if getattr(mod, other, None) is py.get((fn.__module__, other)):
                monkeypatch.setattr(mod, other, fn)
        for n in names:
            jf = numba.njit(py[(modname, n)])
            jf.__module__ = modname
            monkeypatch.setattr(mod, n, jf)
            compiled[n] = jf
    rhs_jit = compiled["rhs"]
    runs = []
    for valve in ("disc", "reed"):
        for circuit in ("simplified", "complete"):
            p = pack(thesis_model(valve), 600.0, 2.76e6, circuit)
            n = 10 if circuit == "complete" else 8
            y = np.zeros(n)
            y[0], y[1], y[2], y[3] = 2.17e-5 * 880.0, 3e-4, 0.1, -1e-7
            if n == 10:
                y[8] = py[("lumped.pump", "load_mass")](2.76e6, p)[0]
            mode = np.array([-1, -1, -1, -1], dtype=np.int64)
            runs.append((p, y, mode, rhs_jit(0.01, y, p, mode)))   # compiles while patched
    monkeypatch.undo()                                            # the pure-Python reference
    for p, y, mode, got in runs:
        ref = py[("lumped.pump", "rhs")](0.01, y, p, list(mode))
        assert np.array_equal(got, ref)
