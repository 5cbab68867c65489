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


# --------------------------------------------------------------------------- the recipes, literally
def _copy(tmp_path, *names) -> Path:
    """A copy of the named packages and files of the repository (without caches) under tmp_path/pkg."""
    import shutil

    dst = tmp_path / "pkg"
    for name in names:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dst / name, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
        else:
            dst.mkdir(parents=True, exist_ok=True)
            shutil.copy(src, dst / name)
    return dst


def _changed(copy: Path) -> list[str]:
    """The files of the copy that differ from (or are not in) the repository."""
    out = []
    for f in sorted(copy.rglob("*")):
        if f.is_file() and "__pycache__" not in f.parts:
            rel = f.relative_to(copy)
            orig = ROOT / rel
            if not orig.is_file() or orig.read_bytes() != f.read_bytes():
                out.append(str(rel))
    return out


def _run(copy: Path, script: str, timeout: int = 600) -> str:
    env = {**os.environ, "PYTHONPATH": f"{copy}{os.pathsep}{ROOT}", "NUMBA_CACHE_DIR": str(copy / "nb"),
           "MPLBACKEND": "Agg"}
    r = subprocess.run([sys.executable, "-c", script], cwd=copy, capture_output=True, text=True, env=env,
                       timeout=timeout)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return r.stdout


def test_a_reed_preset_is_one_file(tmp_path):
    """A preset: one data file; PRESETS, load_reed, a reed valve's geometry and every command's help pick it up."""
    copy = _copy(tmp_path, "geometry")
    text = (ROOT / "geometry" / "data" / "reed_uniform.toml").read_text()
    # no [preset] table: not one of the thesis's reeds, listed after the ordered presets (an unknown table is refused)
    text = re.sub(r"(?ms)^\[preset\].*?(?=^\[reed\])", "", text.replace('name = "uniform"', 'name = "narrow"'))
    (copy / "geometry" / "data" / "reed_narrow.toml").write_text(text.replace("width_tip = 15.875e-3",
                                                                              "width_tip = 10.0e-3"))
    assert _changed(copy) == ["geometry/data/reed_narrow.toml"]
    out = _run(copy, "from geometry import PRESETS, THESIS_PRESETS, load_reed\n"
                     "from lumped import load_model, with_values\n"
                     "assert PRESETS[-1] == 'narrow' and 'narrow' not in THESIS_PRESETS, PRESETS\n"
                     "r = load_reed('narrow'); assert r.width_tip == 10.0e-3\n"
                     "m = with_values(load_model('thesis-reed'), {'valves.geometry': 'narrow', "
                     "'valves.fidelity': 'analytic'})\n"
                     "u = with_values(load_model('thesis-reed'), {'valves.geometry': 'uniform', "
                     "'valves.fidelity': 'analytic'})\n"
                     "print(m.delivery.geometry, m.delivery.stiffness / u.delivery.stiffness)\n")
    name, ratio = out.split()
    assert name == "narrow" and float(ratio) == pytest.approx(1.0, rel=0.02)   # kappa per area: width-free


CIRCLE = '''
class CircleGroove(GrooveShape):
    """A round pocket of radius ``r_outer`` centred at (``s_center``, ``y_center``)."""

    name = "circle"
    keys = ("s_center", "y_center", "r_outer")

    def s_range(self, g):
        return g.s_center - g.r_outer, g.s_center + g.r_outer

    def intervals(self, g, s):
        ds = s - g.s_center
        if abs(ds) > g.r_outer:
            return []
        half = np.sqrt(max(g.r_outer**2 - ds**2, 0.0))
        return [(g.y_center - half, g.y_center + half)]

    def contains(self, g, s, y):
        return np.hypot(np.asarray(s, dtype=float) - g.s_center, np.asarray(y, dtype=float) - g.y_center) <= g.r_outer

    def volume(self, g):
        return g.depth * np.pi * g.r_outer**2

    def kinks(self, g):
        return [g.s_center]

    def check(self, g, reed, where):
        from .errors import InputError

        th = np.linspace(0.0, 2 * np.pi, 721)
        s, y = g.s_center + g.r_outer * np.cos(th), g.y_center + g.r_outer * np.sin(th)
        if np.any(s < 0) or np.any(s > reed.length) or np.any(np.abs(y) > reed.width(s) / 2 * (1 + 1e-9)):
            raise InputError(f"{where}.r_outer", "the circle leaves the reed outline")

    def mirror(self, g):
        return replace(g, y_center=-g.y_center)

    def occ_surfaces(self, g, occ):
        return [occ.addDisk(g.s_center, g.y_center, 0.0, g.r_outer, g.r_outer)]


'''

GROOVED = '''
import tomllib, numpy as np
from geometry import parse_reed
from geometry.reed_io import reed_to_toml
text = open({path!r}).read()
plain = parse_reed(tomllib.loads(text))
grooved = parse_reed(tomllib.loads(text + """
[[reed.grooves]]
kind = "circle"
s_center = 8.0e-3
y_center = 0.0
r_outer = 3.0e-3
depth = 0.6e-3
"""))
assert parse_reed(tomllib.loads(reed_to_toml(grooved))) == grooved
dm = (plain.mass - grooved.mass) / (plain.material.density * 0.6e-3 * np.pi * 3.0e-3 ** 2)
A0, _ = plain.section(8.0e-3)
A1, _ = grooved.section(8.0e-3)
chord = (A0 - A1) / 0.6e-3 / 6.0e-3            # the pocket's width across the section through its centre / 2 r
from lumped.reed.fidelities import reed_properties
from fea import beam, plate, solid
ratios = [reed_properties(grooved, "analytic").kappa / reed_properties(plain, "analytic").kappa]
ratios.append(beam.reed_properties(grooved).kappa / beam.reed_properties(plain).kappa)
for mod in (plate, solid):
    h = plain.length / 14
    ratios.append(mod.reed_properties(grooved, mesh_size=h).kappa / mod.reed_properties(plain, mesh_size=h).kappa)
print(dm, chord, *ratios)
'''


def test_a_groove_kind_is_one_file(tmp_path):
    """A new groove kind (a round pocket): a GrooveShape subclass added to GROOVE_KINDS in geometry/reed.py, one
    file; the reader, the writer, the quadrature (analytic model), the beam, the plate and the solid read it:
    its volume and its chord are the circle's, and every fidelity sees the reed softened, by similar amounts."""
    copy = _copy(tmp_path, "geometry")
    reed_py = copy / "geometry" / "reed.py"
    src = reed_py.read_text()
    src = src.replace("#: the groove kinds by name", CIRCLE.lstrip() + "#: the groove kinds by name")
    src = src.replace("(RectGroove(), HalfRingGroove())", "(RectGroove(), HalfRingGroove(), CircleGroove())")
    reed_py.write_text(src)
    assert _changed(copy) == ["geometry/reed.py"]
    out = _run(copy, GROOVED.format(path=str(ROOT / "geometry" / "data" / "reed_uniform.toml")), timeout=1200)
    dm, chord, *ratios = map(float, out.split())
    assert dm == pytest.approx(1.0, rel=1e-9) and chord == pytest.approx(1.0, rel=1e-9)
    assert all(0.5 < r < 0.995 for r in ratios), ratios
    assert max(ratios) - min(ratios) < 0.06, ratios


EFFECT = '''
# a weaker spring than measured (the relaxation of a helical spring under cyclic load), for testing the recipe
register(Effect(
    name="spring_relaxation",
    summary="a spring softer than measured: k_spr times a factor",
    parameters=(Parameter("k_spr", "N/m", prior=150.0, bounds=(10.0, 1000.0), plausible=(50.0, 400.0),
                          source="test: a relaxed spring", field="spring_stiffness"),),
    valve_types=("disc", "ball"), targets=PER_VALVE,
    apply=lambda model, values, target: set_fields(model, target, spring_stiffness=values["k_spr"]),
))
'''

EFFECT_RUN = '''
from lumped import load_model, simulate, with_values
from lumped.model.effect_library import LIBRARY
from lumped.model.effects import missing_fields
e = LIBRARY["spring_relaxation"]
assert missing_fields(e) == []
assert "`spring_relaxation`" in open("CONTRACT.md").read()
m = load_model("thesis-ball")
on = with_values(m, {"effects.spring_relaxation.inlet": True})
assert on.effects and on.effects[0].name == "spring_relaxation"
a = simulate(m, 600.0, 2.76e6, method="reference", revolutions=2)
b = simulate(on, 600.0, 2.76e6, method="reference", revolutions=2)
print(a.inlet.opening_angle, b.inlet.opening_angle)
'''


def test_an_effect_is_two_files(tmp_path):
    """An effect whose physics exists: its registration and its CONTRACT.md row, two files; the model file's
    [effects.NAME] switches it on and the pump feels it (a softer inlet spring opens the valve earlier)."""
    copy = _copy(tmp_path, "lumped", "geometry", "CONTRACT.md")
    lib = copy / "lumped" / "model" / "effect_library.py"
    src = lib.read_text()
    anchor = "# --------------------------------------------------------------------------- resolution"
    lib.write_text(src.replace(anchor, EFFECT.lstrip() + "\n\n" + anchor))
    contract = copy / "CONTRACT.md"
    row = "| `entrained_air` |"
    text = contract.read_text()
    i = text.index(row)
    contract.write_text(text[:i] + "| `spring_relaxation` | a spring softer than measured (k_spr) |\n" + text[i:])
    assert _changed(copy) == ["CONTRACT.md", "lumped/model/effect_library.py"]
    off, on = map(float, _run(copy, EFFECT_RUN).split())
    assert on < off - 1e-3                                   # rad: earlier
