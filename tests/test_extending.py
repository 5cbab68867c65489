"""docs/extending.md as written: every registered kind passes its conformance check, the mistakes a newcomer
makes are reported where they are made (naming the field, never a crash), and each recipe works in the number
of files the doc states, followed literally on a copy of the packages.

The default run checks each registered kind (quick: the pump with the kind at both positions, one
operating point) and the five planted mistakes of a kind and an effect; the recipes of a reed preset (one
file), a groove kind (one file) and an effect without new physics (two files) run on a copy in a fresh
process. The slow ones: every kind's check at its defaults (three operating points, the mixed pumps), a new
kind by the recipe's three files (a copy of the ball valve under a new name), and an effect with new physics
(four files).
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
    """The doc states the files an extension takes (each recipe is followed literally below): a kind 3, an effect
    2 (4 with new physics), a reed preset 1, a reed shape feature 1-2."""
    text = (ROOT / "docs" / "extending.md").read_text()
    assert "## A valve kind (three files)" in text
    assert "## An effect (two files; four with new physics)" in text
    assert "## A reed preset (one file)" in text
    assert "## A reed shape feature (one or two files)" in text
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


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(KINDS))
def test_every_registered_kind_passes_its_conformance_check_at_its_defaults(kind):
    """The check as a newcomer runs it: three operating points, the mixed pumps, every effect on both steppers."""
    report = check_valve_kind(kind)
    assert report.passed, str(report)
    assert sum("fast vs reference" in c for c in report.checks) >= 5


# --------------------------------------------------------------------------- the planted mistakes
def _sticky(packed: bool):
    """A ball valve with one more parameter its acceleration reads, declared with or without packed=True."""
    from dataclasses import dataclass

    from geometry.declare import param
    from lumped.valves import kind as V
    from lumped.valves.ball import BallValve, ball_acceleration

    @dataclass(frozen=True)
    class Sticky(BallValve):
        stick: float = param("stick.force", "N", "test: a constant force toward the seat", bounds=(0.0, 10.0),
                             default=0.0, packed=packed)

    block = V.kind_block(Sticky)

    def sticky_acceleration(x, u, f, p, o, contact, regime):
        return ball_acceleration(x, u, f, p, o, contact, regime) - p[o + block.stick] / p[o + block.moving_mass]

    return Sticky, block, sticky_acceleration


def test_a_field_the_acceleration_reads_without_packed_is_refused_naming_it():
    """Mistake 1: the field is declared without packed=True; register refuses it naming the field, instead of a
    numba TypingError in every later run."""
    from lumped.valves import kind as V

    cls, block, accel = _sticky(packed=False)
    with pytest.raises(V.KindError, match=r"Sticky\.stick.*packed=True") as err:
        V.register(V.ValveKind(name="sticky", params=cls, acceleration=accel, block=block, default_model="thesis-ball"))
    assert err.value.field == "Sticky.stick" and "sticky" not in KINDS
    cls, block, accel = _sticky(packed=True)            # declared packed: the contract holds
    V.check_kind(V.ValveKind(name="sticky", params=cls, acceleration=accel, block=block, default_model="thesis-ball"))


def test_a_kind_without_its_default_model_is_refused_naming_it():
    """Mistake 4: no default_model (or one that does not exist) is refused at registration, naming the field."""
    from lumped.valves import kind as V

    cls, block, accel = _sticky(packed=True)
    for default, why in (("", "missing"), ("thesis-sticky", "neither a shipped model")):
        with pytest.raises(V.KindError, match=why) as err:
            V.register(V.ValveKind(name="sticky", params=cls, acceleration=accel, block=block, default_model=default))
        assert err.value.field == "sticky.default_model"
    with pytest.raises(V.KindError, match="registered twice"):
        V.register(V.KINDS["ball"])


def test_an_effect_claiming_a_kind_without_its_field_names_both():
    """Mistake 3: an effect whose field the kind it claims does not declare is refused when registered, naming
    the effect, the kind and the field (a bare KeyError or TypeError later, before)."""
    from lumped.model.effect_library import set_fields
    from lumped.model.effects import PER_VALVE, Effect, Library, Parameter, missing_fields

    film = Effect(name="ball_film", summary="a squeeze film on the ball", valve_types=("ball",), targets=PER_VALVE,
                  parameters=(Parameter("C2", "N m^2 s", prior=1e-6, bounds=(1e-9, 1e-3), plausible=(1e-9, 1e-3),
                                        source="test", field="squeeze_c2"),),
                  apply=lambda m, v, t: set_fields(m, t, squeeze_c2=v["C2"]))
    with pytest.raises(ValueError, match=r"'ball_film'.*'ball'.*BallValve.*'squeeze_c2'"):
        Library().register(film)
    assert missing_fields(film, [KINDS["disc"]]) == []          # the disc declares it


def test_the_conformance_check_reports_every_check_never_crashes(monkeypatch):
    """Mistakes 2 and 5: a check that raises (the Jacobian's, with an AttributeError) is a report line naming the
    check; describe() and validity() are exercised, a broken one named."""
    from lumped import conformance
    from lumped.valves.ball import BallValve

    def broken(*args, **kwargs):
        raise AttributeError("'ValveBlock' object has no attribute 'stick'")

    monkeypatch.setattr(conformance, "compare_jacobian", broken)
    monkeypatch.setattr(conformance, "_compare", lambda *a: None)        # the steppers are not what is tested
    monkeypatch.setattr(conformance, "_check_effects", lambda *a: None)
    monkeypatch.setattr(BallValve, "describe", lambda self: {"ball": object()})
    report = check_valve_kind("ball", points=1, quick=True)
    assert not report.passed
    assert any(f.startswith("ball pump, simplified circuit: Jacobian: AttributeError") for f in report.failures)
    assert any(f.startswith("reports: TypeError") for f in report.failures), report.failures
    monkeypatch.setattr(BallValve, "describe", lambda self: {})
    monkeypatch.setattr(BallValve, "validity", lambda self, oil=None: None)
    report = check_valve_kind("ball", points=1, quick=True)
    assert any("validity() returned NoneType" in f for f in report.failures), report.failures


def test_a_jacobian_mismatch_names_the_entry_and_its_likely_cause(monkeypatch):
    """A kind whose acceleration reads the flow but does not say so (Common.flow_in_acceleration): the Jacobian
    check names the worst entry by state names and points at the flag (the Python physics, with the ball's
    acceleration given a force proportional to its orifice flow)."""
    import dataclasses

    from lumped.conformance import compare_jacobian, likely_cause
    from lumped.model.model_file import load_model
    from lumped.solver import jacobian as J
    from lumped.solver.problem import PumpProblem
    from lumped.valves import kind as V
    from lumped.valves.ball import BallValve, ball_acceleration

    def reads_the_flow(x, u, f, p, o, contact, regime):
        return ball_acceleration(x, u, f, p, o, contact, regime) + 1e7 * f.q_o / p[o + V.VALVE.moving_mass]

    monkeypatch.setattr(V, "_accel_ball", reads_the_flow)
    common = BallValve.common
    monkeypatch.setattr(BallValve, "common", lambda self, oil=None: dataclasses.replace(
        common(self, oil), flow_in_acceleration=False))
    from lumped.solver.layout import _valve_block

    _valve_block.cache_clear()          # the packed blocks are cached by (valve, oil): pack the patched common()
    try:
        problem = PumpProblem.build(load_model("thesis-ball"), 650.0, 2.8e6, "simplified")
    finally:
        _valve_block.cache_clear()      # and leave no block of it behind
    c = compare_jacobian(problem, 7, J.pump_jacobian)
    assert c.worst_j > 1.0
    assert c.where().startswith(("d(inlet.u)/", "d(delivery.u)/")), c.where()
    assert c.contact.startswith("inlet ") and "delivery" in c.contact
    assert "flow_in_acceleration" in likely_cause(c, KINDS["ball"])


def test_the_generated_dispatch_says_what_it_is():
    """A numba error in a kind's function points at the generated dispatch by a name that says what it is."""
    import inspect

    from lumped.valves import kind as V

    name = V.valve_acceleration.__code__.co_filename
    assert "generated dispatch" in name and all(k in name for k in KINDS)
    assert "_accel_ball(" in inspect.getsource(V.valve_acceleration)


def test_the_flow_area_law_checks_growth_not_sign():
    """Merritt's conical poppet, A_o = pi x sin(a) (d - x sin(a) cos(a)), has a negative x^2 term: accepted while
    the area grows over the lift, refused (naming area_curvature) where it would shrink before the stop."""
    import dataclasses
    import math

    from lumped.model.model_file import load_model

    c = load_model("thesis-ball").inlet.common(None)
    a, d = math.radians(45.0), 12.0e-3
    poppet = dataclasses.replace(c, area_per_opening=math.pi * d * math.sin(a),
                                 area_curvature=-math.pi * math.sin(a) ** 2 * math.cos(a), stop_gap=1.2e-3)
    assert poppet.area_curvature < 0
    with pytest.raises(ValueError, match="area_curvature.*grow"):
        dataclasses.replace(poppet, stop_gap=d / (2 * math.sin(a) * math.cos(a)) * 1.01)    # past dA/dx = 0
