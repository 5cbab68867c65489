"""The house rules on size, checked on the source: no function over 60 lines and no parameter list over 8
outside the compiled kernels that docs/extending.md ('Long kernels') lists with the reason.

A function that grows past a limit fails here with its place named: split it, or (a compiled kernel) list it
in docs/extending.md and below.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("lumped", "fea", "geometry", "instruments", "studies")
MAX_LINES, MAX_PARAMS = 60, 8

#: (module, function) allowed over 60 lines: docs/extending.md 'Long kernels'
LONG = {("lumped/solver/rodas.py", "solve"), ("lumped/solver/rhs.py", "evaluate"),
        ("lumped/fluid/orifice.py", "orifice_flow"), ("fea/fluid/reynolds.py", "solve_film")}
#: (module, function) allowed over 8 parameters: the compiled kernels of docs/extending.md 'Long kernels'
MANY = {("lumped/solver/rosenbrock.py", "rosenbrock_step"), ("lumped/solver/rosenbrock.py", "rosenbrock5_step"),
        ("lumped/solver/steppers.py", "_jac"), ("lumped/solver/rodas.py", "jacobian"),
        ("lumped/solver/rodas.py", "fd_jacobian"), ("lumped/solver/rodas.py", "_locate_event"),
        ("lumped/solver/rodas.py", "_keep_start"), ("lumped/solver/jacobian.py", "pump_jacobian"),
        ("lumped/valves/reed.py", "reed_accelerations"), ("lumped/valves/reed.py", "reed_accelerations_jacobian"),
        ("lumped/valves/kind.py", "valve_accelerations"), ("lumped/valves/kind.py", "valve_accelerations_jacobian"),
        ("lumped/solver/layout.py", "multi_rates"), ("lumped/solver/layout.py", "valve_rates"),
        ("lumped/fluid/orifice.py", "orifice_flow"), ("lumped/valves/disc.py", "pressure_force"),
        ("lumped/fluid/oil.py", "pressure_iterations")}


def _functions():
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    yield rel, node


def _n_params(node) -> int:
    a = node.args
    n = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)
    return n - 1 if a.args and a.args[0].arg in ("self", "cls") else n


def test_no_long_function_outside_the_listed_kernels():
    long = [(rel, f.name, f.end_lineno - f.lineno + 1) for rel, f in _functions()
            if f.end_lineno - f.lineno + 1 > MAX_LINES and (rel, f.name) not in LONG]
    assert not long, f"functions over {MAX_LINES} lines (split them, or list a compiled kernel): {long}"


def test_no_long_parameter_list_outside_the_compiled_kernels():
    many = [(rel, f.name, _n_params(f)) for rel, f in _functions()
            if _n_params(f) > MAX_PARAMS and (rel, f.name) not in MANY]
    assert not many, f"functions with more than {MAX_PARAMS} parameters (take a record instead): {many}"


def test_the_allowed_kernels_are_listed_in_the_docs():
    doc = (ROOT / "docs" / "extending.md").read_text(encoding="utf-8")
    missing = sorted(name for _, name in LONG | MANY if f"{name}`" not in doc)
    assert not missing, f"kernels allowed here but not listed with why in docs/extending.md: {missing}"
