"""The layers stay visible: geometry <- lumped, instruments <- fea <- studies, and inside lumped
plugins <- fluid <- validity, reed <- valves <- model <- solver <- run <- conformance.

The test reads every module's imports (module level and inside functions, since a deferred
import is still a dependency; ``if TYPE_CHECKING:`` blocks excepted) and fails on an import
from a lower layer to a higher one and on any import cycle between modules. A package's
``__init__`` importing its own submodules is its public face, not a cycle; a submodule that
imports its package's ``__init__`` back is.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYER = {"geometry": 0, "lumped": 1, "instruments": 1, "fea": 2, "studies": 3}
#: lumped's own layers, lowest first: the subpackage (or root module) a lumped module belongs to.
#: A module may import from its own sub-layer and the ones below, never from one above.
SUBLAYER = {"lumped.plugins": 0, "lumped.fluid": 1, "lumped.validity": 2, "lumped.reed": 2, "lumped.valves": 3,
            "lumped.model": 4, "lumped.solver": 5, "lumped.run": 6, "lumped.conformance": 7, "lumped": 8}


def _modules() -> dict[str, Path]:
    out = {}
    for top in LAYER:
        for p in (ROOT / top).rglob("*.py"):
            parts = p.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            out[name] = p
    return out


MODULES = _modules()


def _type_checking_lines(tree: ast.AST) -> set[int]:
    lines: set[int] = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.If) and "TYPE_CHECKING" in ast.unparse(n.test):
            for m in n.body:
                lines.update(range(m.lineno, (m.end_lineno or m.lineno) + 1))
    return lines


def _owner(name: str) -> str | None:
    """The module a dotted import name lands in (``lumped.model.pump.simulate`` -> ``lumped.model.pump``)."""
    while name and name not in MODULES:
        if "." not in name:
            return None
        name = name.rsplit(".", 1)[0]
    return name


def imports(mod: str) -> set[str]:
    """The valvelab modules ``mod`` imports (resolved, relative imports included)."""
    path = MODULES[mod]
    tree = ast.parse(path.read_text())
    skip = _type_checking_lines(tree)
    package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
    found: set[str] = set()
    for n in ast.walk(tree):
        if getattr(n, "lineno", 0) in skip:
            continue
        if isinstance(n, ast.Import):
            names = [a.name for a in n.names]
        elif isinstance(n, ast.ImportFrom):
            if n.level:
                base = package.split(".")
                base = base[: len(base) - (n.level - 1)]
                stem = ".".join(base + ([n.module] if n.module else []))
            else:
                stem = n.module or ""
            # ``from pkg import sub`` imports the submodule; ``from mod import name`` the module
            names = [f"{stem}.{a.name}" if f"{stem}.{a.name}" in MODULES else stem for a in n.names]
        else:
            continue
        for name in names:
            owner = _owner(name)
            if owner and owner != mod:
                found.add(owner)
    return found


GRAPH = {m: imports(m) for m in MODULES}


def test_no_import_from_a_lower_layer_to_a_higher_one():
    upward = [f"{a} -> {b}" for a, bs in GRAPH.items() for b in bs
              if LAYER[b.split(".")[0]] > LAYER[a.split(".")[0]]
              or (b.split(".")[0] != a.split(".")[0] and LAYER[b.split(".")[0]] == LAYER[a.split(".")[0]])]
    assert not upward, "imports against the layers:\n" + "\n".join(sorted(upward))


def sublayer(mod: str) -> tuple[str, int]:
    """The lumped sub-layer of a lumped module (its subpackage or root module)."""
    parts = mod.split(".")
    for n in (2, 1):
        key = ".".join(parts[:n])
        if key in SUBLAYER:
            return key, SUBLAYER[key]
    raise KeyError(f"{mod} belongs to no lumped sub-layer: add its package to SUBLAYER")


def test_lumped_sublayers():
    """Inside lumped, the subpackages are layers too: reed and valve physics never reach up to the
    model file, the solver or the run."""
    mods = [m for m in GRAPH if m.split(".")[0] == "lumped"]
    upward = []
    for a in mods:
        la = sublayer(a)
        for b in GRAPH[a]:
            if b.split(".")[0] == "lumped":
                lb = sublayer(b)
                if lb[1] > la[1] or (lb[1] == la[1] and lb[0] != la[0]):
                    upward.append(f"{a} ({la[0]}) -> {b} ({lb[0]})")
    assert not upward, "imports against lumped's sub-layers:\n" + "\n".join(sorted(upward))


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    comps: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return comps


def test_no_import_cycle():
    comps = _cycles(GRAPH)
    detail = ["  " + ", ".join(c) + "\n    " + "; ".join(
        f"{a} -> {sorted(b for b in GRAPH[a] if b in c)}" for a in c) for c in comps]
    assert not comps, "import cycles:\n" + "\n".join(detail)


def test_the_walker_sees_a_cycle_and_an_upward_import():
    """The checks can fail: a made-up graph with both faults is caught."""
    assert _cycles({"a": {"b"}, "b": {"a"}, "c": set()}) == [["a", "b"]]
    assert "studies" in {m.split(".")[0] for m in imports("studies.cli")} | {"studies"}
    assert "lumped.run.simulate" in GRAPH["lumped"] or any(m.startswith("lumped.") for m in GRAPH["lumped"])
