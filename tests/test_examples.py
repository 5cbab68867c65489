"""The docs run: every script of docs/examples/ asserts its headline number and must exit 0,
and every public function of ``lumped`` carries a doctested example (run by --doctest-modules).

An example that breaks (an API change, a number that drifts from the thesis or the closed
form it states) fails here; so does a public function whose example is removed.
"""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "docs" / "examples").glob("ex*.py"))


def test_there_are_at_least_eight_examples():
    assert len(EXAMPLES) >= 8, [p.name for p in EXAMPLES]


#: runs an example as ``python EXAMPLE`` would, then checks the figures it left open (the gallery shows them)
RUN_AND_CHECK = """
import json, runpy, sys
import matplotlib.pyplot as plt
import figure_checks
sys.argv = [sys.argv[1]]
runpy.run_path(sys.argv[0], run_name="__main__")
figs = [plt.figure(n) for n in plt.get_fignums()]
print("FIGURES " + json.dumps({"count": len(figs), "problems": [p for k, f in enumerate(figs)
                                                             for p in figure_checks.problems(f, f"figure {k + 1}")]}))
"""


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs_and_meets_its_headline(path, tmp_path):
    """Each example exits 0 (its asserts hold) and draws at least one figure fit for a report
    (tests/figure_checks.py: legends off the data, a unit on every axis)."""
    # each in its own process: an example may register an effect or start a dask client
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "tests")])}
    r = subprocess.run([sys.executable, "-c", RUN_AND_CHECK, str(path)], cwd=tmp_path, capture_output=True,
                       text=True, env=env, timeout=600)
    assert r.returncode == 0, f"{path.name} failed:\n{r.stdout[-1500:]}\n{r.stderr[-3000:]}"
    assert list(tmp_path.iterdir()) == [] or all(p.name.startswith("dask-") for p in tmp_path.iterdir()), \
        "an example wrote into the working folder"
    figures = json.loads(r.stdout.rsplit("FIGURES ", 1)[1])
    assert figures["count"] >= 1, f"{path.name} draws no figure for the gallery"
    assert not figures["problems"], "\n".join(figures["problems"])


def test_every_example_states_its_headline_number():
    for path in EXAMPLES:
        text = path.read_text()
        doc = text.split('"""')[1]
        assert "Headline number" in doc, f"{path.name}: the docstring does not say what it checks"
        assert "assert " in text, f"{path.name}: checks nothing"


def _public_functions():
    import lumped

    return [(name, obj) for name in lumped.__all__ if inspect.isfunction(obj := getattr(lumped, name))]


@pytest.mark.parametrize("name", [n for n, _ in _public_functions()])
def test_public_lumped_function_has_a_doctested_example(name):
    import lumped

    doc = inspect.getdoc(getattr(lumped, name)) or ""
    assert "Examples" in doc and ">>>" in doc, f"lumped.{name} has no doctested example"
