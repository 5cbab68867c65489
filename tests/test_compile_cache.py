"""The compiled solvers on numba's disk cache: a solver loaded from the cache runs the physics it was built with.

numba names a compiled function's symbol by its qualified name and a per-process counter; two
different functions of one name (the one-DOF and several-DOF flavours' closures) once shared a
symbol between a solver compiled in one process and one loaded from the cache in another, and
the modal reed then ran the one-DOF physics (step size underflow at t = 0).
"""
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_each_flavour_compiles_functions_of_its_own_names():
    """The physics mirrors and the solver's closures carry the flavour and the source digest in their names."""
    from lumped.solver import compiled

    one = compiled.function("lumped.solver.rhs", "evaluate", True).py_func.__qualname__
    many = compiled.function("lumped.solver.rhs", "evaluate", False).py_func.__qualname__
    assert one != many and compiled.source_digest() in one and compiled.source_digest() in many


RUN = """
import sys
from lumped import load_model, simulate, with_values
kind = sys.argv[1]
m = load_model("thesis-disc" if kind == "disc" else "thesis-reed")
if kind == "modal":
    m = with_values(m, {"valves.geometry": "prototype", "valves.delivery.dynamics": "modal",
                        "valves.delivery.modes": 3, "valves.delivery.port.y_center": 2.5e-3})
r = simulate(m, 595.0, 2.76e6, method="fast", revolutions=2)
print(r.delivery_per_rev)
"""


@pytest.mark.slow
def test_a_solver_loaded_from_the_cache_runs_its_own_physics(tmp_path):
    """Three processes on one fresh cache: one-DOF compiled, several-DOF compiled, several-DOF loaded: the same
    delivery from the last two (compiling both flavours costs about two minutes)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PYTHONPATH": str(ROOT)}
    out = []
    for kind in ("disc", "modal", "modal"):
        p = subprocess.run([sys.executable, "-c", RUN, kind], env=env, capture_output=True, text=True, cwd=tmp_path,
                           timeout=900)
        assert p.returncode == 0, p.stderr[-2000:]
        out.append(float(p.stdout.split()[-1]))
    assert out[2] == out[1]
