"""docs/extending.md as written: every registered kind passes its conformance check, and a new kind
added by the recipe's three files works in every command.

The default run checks each registered kind (quick: the pump with the kind at both positions, one
operating point); the slow one follows the recipe literally in a fresh process: a copy of the ball
valve under a new name, as its own module (file 1), imported before any model is read (file 2's one
line) with its own model file (file 3), checked in full.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from lumped import check_valve_kind
from lumped.valves.kind import KINDS

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_registered_kind_passes_its_conformance_check(kind):
    report = check_valve_kind(kind, points=1, quick=True)
    assert report.passed, str(report)
    assert any("fast vs reference" in c for c in report.checks) and any("Jacobian" in c for c in report.checks)


def test_the_conformance_check_catches_a_broken_kind(monkeypatch):
    """A kind that declares a derived quantity and does not give it fails the check naming it; one whose
    shared quantities are wrong cannot even be built (Common checks itself)."""
    import dataclasses

    from lumped.valves.ball import BallValve
    from lumped.model.model_file import load_model

    given = BallValve.packed_extra
    monkeypatch.setattr(BallValve, "packed_extra", lambda self, oil=None: {
        k: v for k, v in given(self, oil).items() if k != "seat_area"})
    report = check_valve_kind("ball", points=1, quick=True)
    assert not report.passed and any("seat_area" in f for f in report.failures)
    with pytest.raises(ValueError, match="area_2"):
        dataclasses.replace(load_model("thesis-ball").inlet.common(None), area_2=-1.0)


def test_a_kind_registered_late_reaches_the_reference_physics():
    """The generated dispatch is rebuilt when a kind registers (after lumped.solver.layout and lumped.solver.jacobian imported
    it by name): those modules must call the new one, or the reference path gets nan for the new kind."""
    import lumped.solver.jacobian
    import lumped.solver.layout
    import lumped.valves.kind as valve

    valve._build_dispatch()                     # what a late register() does
    for mod in (lumped.solver.layout, lumped.solver.jacobian):
        assert mod.valve_acceleration is valve.valve_acceleration, mod.__name__
        assert mod.valve_accelerations is valve.valve_accelerations, mod.__name__


def test_extending_counts_its_files():
    """The doc states the files an extension takes: a kind 3, an effect 2, a reed shape 1."""
    text = (ROOT / "docs" / "extending.md").read_text()
    assert "## A valve kind (three files)" in text
    assert "## An effect (two files)" in text
    assert "## A reed shape (one file)" in text
    assert "check_valve_kind" in text and "packed=True" in text


def test_every_effect_is_in_the_contract():
    """An effect's second file is its row in CONTRACT.md's effect table."""
    from lumped.model.effect_library import LIBRARY

    contract = (ROOT / "CONTRACT.md").read_text()
    missing = [n for n in LIBRARY.names() if f"`{n}`" not in contract]
    assert not missing, f"effects missing from CONTRACT.md: {missing}"


@pytest.mark.slow
def test_a_new_kind_by_the_recipe_in_three_files(tmp_path):
    # file 1: the kind's module (the ball's, renamed)
    src = (ROOT / "lumped" / "valves" / "ball.py").read_text()
    src = re.sub(r'name="ball"', 'name="ball2"', src)
    src = src.replace("class BallValve", "class Ball2Valve").replace("BallValve", "Ball2Valve")
    model_file = tmp_path / "thesis-ball2.toml"
    src = src.replace('default_model="thesis-ball"', f'default_model={str(model_file)!r}')
    (tmp_path / "ball2_valve.py").write_text(src)
    # file 3: its model file (the ball's, with the new kind)
    toml = (ROOT / "lumped" / "data" / "models" / "thesis-ball.toml").read_text()
    model_file.write_text(toml.replace('kind = "ball"', 'kind = "ball2"').replace('name = "thesis-ball"',
                                                                                 'name = "thesis-ball2"'))
    # file 2: one import line before any model is read; then the conformance check
    script = tmp_path / "run.py"
    script.write_text("import lumped\nimport ball2_valve  # noqa: F401\nfrom lumped import check_valve_kind\n"
                      "r = check_valve_kind('ball2', points=2)\nprint(r)\nraise SystemExit(0 if r.passed else 1)\n")
    env = {**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{ROOT}", "NUMBA_CACHE_DIR": str(tmp_path / "nb")}
    r = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, env=env,
                       timeout=1800)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "valve kind 'ball2': passed" in r.stdout
