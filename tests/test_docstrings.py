"""The documentation standard of the model packages, read from the source (no import of what it checks).

- Every name a package exports (``__all__`` of lumped and geometry) has a docstring whose first line is a
  complete sentence: the API pages (docs/conf.py) show that line alone.
- Every public function of a model module documents its arguments and result in numpydoc sections
  (``Parameters`` where it takes any, ``Returns``/``Yields`` unless annotated ``-> None``).
"""

from __future__ import annotations

import ast
import importlib
import inspect
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: the packages whose exports (``__all__``) the API pages list with their first docstring line
PACKAGES = ("lumped", "geometry")

#: the model modules: physics, with units, equations and references in numpydoc
MODEL_MODULES = (
    *sorted(str(p.relative_to(ROOT)) for d in ("lumped/fluid", "lumped/reed", "lumped/valves")
            for p in (ROOT / d).glob("*.py") if p.name != "__init__.py"),
    "lumped/model/pump.py", "lumped/solver/rhs.py", "lumped/solver/jacobian.py", "lumped/solver/switching.py",
    "fea/beam.py", "fea/plate.py", "fea/solid.py", "fea/reed_stress.py", "fea/seat_stop.py",
    "geometry/reed.py", "geometry/seat_stop.py", "geometry/disc.py",
)


def _first_line(obj) -> str:
    """The line the API pages show (docs/conf.py)."""
    return (obj.__doc__ or "").strip().split("\n")[0]


@pytest.mark.parametrize("package", PACKAGES)
def test_exported_first_lines_are_sentences(package):
    mod = importlib.import_module(package)
    cut = []
    for name in mod.__all__:
        obj = getattr(mod, name)
        if not (callable(obj) or inspect.isclass(obj)) or isinstance(obj, (dict, tuple, list)):
            continue
        line = _first_line(obj)
        if not line.endswith((".", ".)")):
            cut.append(f"{package}.{name}: {line!r}")
    assert not cut, "first docstring lines that are not a complete sentence:\n" + "\n".join(cut)


def _missing_sections(path: Path, label: str) -> list[str]:
    """'label:line name: no Parameters' / '...: no Returns' of each public function lacking the section."""
    tree = ast.parse(path.read_text())
    out = []
    for node in tree.body:
        if not isinstance(node, ast.FunctionDef) or node.name.startswith("_"):
            continue
        doc = ast.get_docstring(node) or ""
        args = [a for a in node.args.posonlyargs + node.args.args + node.args.kwonlyargs]
        if node.args.vararg or node.args.kwarg or args:
            if "\nParameters\n----------" not in doc:
                out.append(f"{label}:{node.lineno} {node.name}: no Parameters")
        returns_none = isinstance(node.returns, ast.Constant) and node.returns.value is None
        if not returns_none and "\nReturns\n-------" not in doc and "\nYields\n------" not in doc:
            out.append(f"{label}:{node.lineno} {node.name}: no Returns")
    return out


def test_model_functions_have_numpydoc_sections():
    missing = [m for rel in MODEL_MODULES for m in _missing_sections(ROOT / rel, rel)]
    assert not missing, "\n".join(missing)


def test_the_check_sees_a_missing_section(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text('def f(x):\n    """The force.\n\n    Parameters\n    ----------\n    x : float\n"""\n'
                   '    return x\n\n\ndef g(y, out) -> None:\n    """Into out."""\n')
    found = [m.split(" ", 1)[1] for m in _missing_sections(bad, "bad.py")]
    assert found == ["f: no Returns", "g: no Parameters"]
