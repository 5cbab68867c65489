"""Bad inputs, third round: the classes of hostile input that got through the first two rounds.

Refused (exit 2, one line on stderr naming the field, no traceback, nothing written, before any work):
an unknown table in any TOML file (a reed file's ``[other]``, a misplaced ``[valves.middle]``); a load below
the tank pressure in ``model check`` and in a study's operating points; a modal reed meshed coarser than a
quarter of its length; an expression whose work has no bound (``"9 ** 9 ** 9 ** 9"`` in ``[derived]``); a
flag named as given (``pump --model ''``); negative counts in a comma list reaching their range check; numbers
whose differences overflow; an output folder inside a dataset or a run folder; a trace.csv link that leads
nowhere; a stated delivery uncertainty as large as the delivery; pressures written in kPa; a sweep whose
valve contradicts its model; the demo's model checked before the demo is written; contradicting flags;
a model file's description that is not a string.

Warned (exit 0, ``implausible_input`` in the JSON ``warnings`` and one line on stderr naming the key): values
inside the hard bounds but outside what real designs use (a 2 m reed, a reed wider than long under beam
theory, a reed stiffness typed in MPa/m, an oil of 150 kg/m^3, Cd_inf above 1, a 50 mm lift, metres given to a
mm flag, valve positions 1000 times too small).

Not a bug (exit 1, one line, no "please report"): a disk that refuses the write.

The Python API: the functions a user calls refuse wrong types and values with InputError naming the argument.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
from pathlib import Path

import pytest

from studies.cli import main

ROOT = Path(__file__).resolve().parents[1]
UNIFORM = (ROOT / "geometry" / "data" / "reed_uniform.toml").read_text()
BENCH = ROOT / "tests" / "data" / "bench-pump.toml"

STUDY = """model = "thesis-disc"
[operating]
speed_rpm = [593.0]
load_pressure_mpa = [{load}]
[variables]
"oil.air_content" = [0.005, 0.02]
{derived}[run]
outputs = ["delivery_cc_per_rev"]
objectives = ["max delivery_cc_per_rev"]
samples = 4
"""


def _reed(path: Path, **kv) -> str:
    text = UNIFORM
    for k, v in kv.items():
        text, n = re.subn(rf"(?m)^{k} = [^\n#]*", f"{k} = {v}", text, count=1)
        assert n == 1, k
    path.write_text(text)
    return str(path)


def _run(argv, capsys):
    capsys.readouterr()
    t0 = time.perf_counter()
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    lines = [ln for ln in out.err.replace("\r", "\n").splitlines() if ln.strip() and "rev/s" not in ln]
    return code, out.out, lines, time.perf_counter() - t0


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """One synthetic run (593 rpm, 2.76 MPa, 2 revolutions) and copies spoiled one way each."""
    base = tmp_path_factory.mktemp("data3")
    assert main(["synth", str(base / "ds"), "--condition", "593:2.76", "--revolutions", "2"]) == 0

    def variant(name, edit):
        shutil.copytree(base / "ds", base / name)
        run = next((base / name).glob("run*"))
        edit(run)
        return str(base / name)

    def dangling(run):
        (run / "trace.csv").unlink()
        (run / "trace.csv").symlink_to(run / "moved.csv")

    def loop(run):
        (run / "trace.csv").unlink()
        (run / "trace.csv").symlink_to(run / "trace.csv")

    def u_equal(run):
        text = (run / "run.toml").read_text()
        d = re.search(r"delivery_cc_per_rev = (\S+)", text).group(1)
        (run / "run.toml").write_text(re.sub(r"delivery_uncertainty_cc = \S+", f"delivery_uncertainty_cc = {d}", text))

    def scaled(col, factor):
        def edit(run):
            rows = (run / "trace.csv").read_text().splitlines()
            i = rows[0].split(",").index(col)
            out = [rows[0]]
            for r in rows[1:]:
                c = r.split(",")
                c[i] = repr(float(c[i]) * factor)
                out.append(",".join(c))
            (run / "trace.csv").write_text("\n".join(out) + "\n")
        return edit

    return {"ds": str(base / "ds"), "run": str(next((base / "ds").glob("run*"))),
            "dangling": variant("dangling", dangling), "loop": variant("loop", loop),
            "u_equal": variant("u_equal", u_equal), "kpa": variant("kpa", scaled("cylinder_pressure_pa", 1e-3)),
            "tiny": variant("tiny", scaled("valve_position_m", 1e-3))}


def _cases(tmp: Path, data: dict) -> list[tuple]:
    """(name, argv, the field named, strings the line must not hold)."""
    (tmp / "other.toml").write_text(UNIFORM + "\n[other]\nx = 1\n")
    (tmp / "preset.toml").write_text(re.sub(r"(?m)^\[preset\][^\n]*", "[preset]\nfoo = 2", UNIFORM, count=1))
    (tmp / "low.toml").write_text('base = "thesis-disc"\n[operating]\nload_pressure = 0.05e6\n')
    (tmp / "modal.toml").write_text('base = "thesis-reed"\n[valves.delivery]\ngeometry = "prototype"\n'
                                    'dynamics = "modal"\nmodes = 2\nmesh_size = 1.0\n')
    (tmp / "middle.toml").write_text('base = "thesis-disc"\n[valves.middle]\nkind = "disc"\n')
    (tmp / "described.toml").write_text('base = "thesis-disc"\ndescription = ["a", "b"]\n')
    (tmp / "sens_low.toml").write_text(STUDY.format(load="0.05", derived=""))
    bomb = '[derived]\n"valves.inlet.spring.stiffness" = "9 ** 9 ** 9 ** 9"\n'
    (tmp / "sens_bomb.toml").write_text(STUDY.format(load="2.76", derived=bomb))
    (tmp / "opt_bomb.toml").write_text(STUDY.format(load="2.76", derived=bomb))
    (tmp / "sweep_mixed.toml").write_text('[sweep]\nsampler = "grid"\n[factors.speed_rpm]\nlow = 450.0\n'
                                          'high = 950.0\nlevels = 2\n[fixed]\nvalve = "disc"\nmodel = "thesis-reed"\n'
                                          'revolutions = 2\nload_pressure = 2.76e6\n')
    (tmp / "sweep_ok.toml").write_text('[sweep]\nsampler = "grid"\n[factors.speed_rpm]\nlow = 450.0\nhigh = 950.0\n'
                                       'levels = 2\n[fixed]\nvalve = "disc"\nrevolutions = 2\nload_pressure = 2.76e6\n')
    pump = ["--speed-rpm", "593", "--load-pressure-mpa", "2.76"]
    return [
        ("a reed file's unknown table", ["reed", str(tmp / "other.toml")], "other", ()),
        ("a reed file's unknown [preset] key", ["reed", str(tmp / "preset.toml")], "preset.foo", ()),
        ("model check: a load below the tank pressure", ["model", "check", str(tmp / "low.toml"), "--no-fea"],
         "operating.load_pressure", ()),
        ("sensitivity: a load below the tank pressure", ["sensitivity", str(tmp / "sens_low.toml"), "--out",
                                                         str(tmp / "s1")], "operating.load_pressure_mpa", ()),
        ("model check: a modal reed meshed at 1 m", ["model", "check", str(tmp / "modal.toml"), "--no-fea"],
         "valves.delivery.mesh_size", ("--mesh-size",)),
        ("model file: [valves.middle]", ["model", "check", str(tmp / "middle.toml"), "--no-fea"], "valves.middle",
         ("valves.inlet.middle",)),
        ("model file: a description that is a list", ["model", "check", str(tmp / "described.toml"), "--no-fea"],
         "description", ()),
        ("pump --model ''", ["pump", "--model", ""] + pump, "--model", ("spec",)),
        ("sensitivity: 9 ** 9 ** 9 ** 9", ["sensitivity", str(tmp / "sens_bomb.toml"), "--out", str(tmp / "s2")],
         'derived."valves.inlet.spring.stiffness"', ()),
        ("optimize: 9 ** 9 ** 9 ** 9", ["optimize", str(tmp / "opt_bomb.toml"), "--out", str(tmp / "s3")],
         'derived."valves.inlet.spring.stiffness"', ()),
        ("sweep: valve disc with model thesis-reed", ["sweep", str(tmp / "sweep_mixed.toml"), "--out",
                                                      str(tmp / "s4")], "fixed.valve", ()),
        ("gci --cells negative", ["gci", "6.063,5.972,5.863", "--cells", "-18000,-8000,-4500"], "--cells",
         ("expected one argument",)),
        ("gci values overflowing", ["gci", "1e308,-1e308,1e308", "--cells", "18000,8000,4500"], "values",
         ("the model failed",)),
        ("discrepancy --demo --model thesis-reed", ["discrepancy", str(tmp / "demo"), "--demo", "--model",
                                                    "thesis-reed"], "--model", ()),
        ("discrepancy --report inside a run folder", ["discrepancy", data["ds"], "--report",
                                                      str(Path(data["run"]) / "rep")], "--report", ()),
        ("sweep --out inside a run folder", ["sweep", str(tmp / "sweep_ok.toml"), "--out",
                                             str(Path(data["run"]) / "sw")], "--out", ()),
        ("discrepancy --report and --no-report", ["discrepancy", data["ds"], "--report", str(tmp / "r"),
                                                  "--no-report"], "--report", ()),
        ("trace.csv a dangling link", ["discrepancy", data["dangling"], "--no-report"], "trace.csv", ()),
        ("trace.csv a link loop", ["discrepancy", data["loop"], "--no-report"], "trace.csv", ()),
        ("delivery_uncertainty_cc equal to the delivery", ["discrepancy", data["u_equal"], "--no-report"],
         "delivery_uncertainty_cc", ()),
        ("cylinder pressures in kPa", ["discrepancy", data["kpa"], "--no-report"], "cylinder_pressure_pa", ()),
    ]


N_CASES = 21


def test_the_third_round_has_its_cases(tmp_path, dataset):
    assert len(_cases(tmp_path, dataset)) == N_CASES


@pytest.mark.parametrize("index", range(N_CASES))
def test_third_round_refused_with_the_field_named(index, tmp_path, dataset, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name, argv, field, absent = _cases(tmp_path, dataset)[index]
    before = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")}
    before_data = {p: p.stat().st_mtime_ns for p in Path(dataset["ds"]).rglob("*")}
    code, _, lines, elapsed = _run(argv, capsys)
    assert code == 2, f"{name}: exit {code}, stderr {lines}"
    assert len(lines) == 1, f"{name}: {lines}"
    assert "Traceback" not in lines[0]
    assert field in lines[0], f"{name}: {lines[0]!r} does not name {field}"
    for s in absent:
        assert s not in lines[0], f"{name}: {lines[0]!r} holds {s!r}"
    assert elapsed < 30, f"{name}: refused only after {elapsed:.1f} s"
    assert {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")} == before, f"{name} wrote files"
    assert {p: p.stat().st_mtime_ns for p in Path(dataset["ds"]).rglob("*")} == before_data, f"{name} changed ds"


# --------------------------------------------------------------------------- implausible but possible: warned
def _warned(tmp: Path) -> list[tuple]:
    """(name, argv, the key the warning names)."""
    (tmp / "kappa.toml").write_text('base = "thesis-reed"\n[valves.delivery]\nstructure.stiffness = 7.709\n')
    (tmp / "oil.toml").write_text('base = "thesis-disc"\n[oil]\ndensity = 150.0\n')
    (tmp / "cd.toml").write_text('base = "thesis-disc"\n[valves.delivery]\ndischarge.cd_inf = 1.8\n')
    (tmp / "gap.toml").write_text('base = "thesis-disc"\n[valves.delivery]\nstop.gap = 0.05\n')
    check = ["model", "check"]
    return [
        ("a 2 m reed", ["reed", _reed(tmp / "long.toml", length="2.0")], "reed.length"),
        ("a reed 200 mm wide and 25 mm long as a beam", ["reed", _reed(tmp / "wide.toml", width_root="0.2",
                                                                       width_tip="0.2")], "reed.width_root"),
        ("a reed stiffness in MPa/m", check + [str(tmp / "kappa.toml"), "--no-fea"],
         "valves.delivery.structure.stiffness"),
        ("oil.density = 150", check + [str(tmp / "oil.toml"), "--no-fea"], "oil.density"),
        ("discharge.cd_inf = 1.8", check + [str(tmp / "cd.toml"), "--no-fea"], "valves.delivery.discharge.cd_inf"),
        ("stop.gap = 0.05", check + [str(tmp / "gap.toml"), "--no-fea"], "valves.delivery.stop.gap"),
        ("lts --air-gap-mm in metres", ["lts", "disc_inlet", "--air-gap-mm", "0.09067"], "--air-gap-mm"),
    ]


@pytest.mark.parametrize("index", range(7))
def test_implausible_values_are_warned(index, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name, argv, key = _warned(tmp_path)[index]
    code, out, lines, _ = _run(argv + ["--json"], capsys)
    assert code == 0, f"{name}: exit {code}, {lines}"
    said = [ln for ln in lines if "warning: implausible_input" in ln]
    assert len(said) == 1 and key in said[0], f"{name}: {lines}"
    warnings = json.loads(out)["warnings"]
    assert [w["code"] for w in warnings] == ["implausible_input"] and key in warnings[0]["message"], name


@pytest.mark.parametrize("model", ["thesis-disc", "thesis-reed", "thesis-ball", str(BENCH)])
def test_shipped_and_test_models_are_not_implausible(model):
    from lumped import load_model
    from lumped.model.plausible import input_warnings

    assert input_warnings(load_model(model)) == []


def test_positions_1000_times_too_small_are_warned(dataset):
    from studies.discrepancy.measured import implausible, read_dataset

    assert implausible(read_dataset(dataset["ds"])) == []
    said = implausible(read_dataset(dataset["tiny"]))
    assert len(said) == 1 and said[0]["code"] == "implausible_input" and "delivery valve moves at most" in \
        said[0]["message"]


def test_a_full_disk_is_one_line_not_a_bug(tmp_path, capsys, monkeypatch):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full on this system")
    monkeypatch.chdir(tmp_path)
    code, _, lines, _ = _run(["pump", "--valve", "disc", "--speed-rpm", "593", "--load-pressure-mpa", "2.76",
                              "--revolutions", "2", "--trace", "/dev/full", "--force"], capsys)
    assert code == 1 and len(lines) == 1, lines
    assert "could not write" in lines[0] and "No space left" in lines[0] and "report" not in lines[0], lines


# --------------------------------------------------------------------------- the Python API
def _api(tmp: Path, data: dict) -> list[tuple]:
    from fea.convergence import gci
    from lumped import load_model, simulate, with_values
    from studies.discrepancy import synthesize
    from studies.discrepancy.measured import read_run
    from studies.discrepancy.pump_sim import simulate as pump_sim
    from studies.discrepancy.synth import Condition

    m = load_model("thesis-disc")
    plain = simulate(m, 593, 2.76e6, revolutions=2)
    traced = simulate(m, 593, 2.76e6, revolutions=2, trace=True)
    return [
        ("PumpResult.plot without a trace", lambda: plain.plot(tmp / "x.png"), "trace"),
        ("PumpResult.plot to a .txt", lambda: traced.plot(tmp / "x.txt"), "path"),
        ("gci of a string", lambda: gci("abc", sizes=(1.0, 2.0, 3.0)), "values"),
        ("gci of strings", lambda: gci(["a", "b", "c"], sizes=(1.0, 2.0, 3.0)), "values[0]"),
        ("gci with neither sizes nor cells", lambda: gci((1.0, 1.1, 1.2)), "sizes"),
        ("gci with cells and no dim", lambda: gci((1.0, 1.1, 1.2), cells=(300, 200, 100)), "dim"),
        ("read_run(None)", lambda: read_run(None), "folder"),
        ("synthesize(valve_type='Disc')", lambda: synthesize(pump_sim, "Disc", [Condition(593.0, 2.76e6)]),
         "valve_type"),
        ("with_values with an empty key", lambda: with_values(m, {"": 1.0}), "values"),
        ("simulate(trace='yes')", lambda: simulate(m, 593, 2.76e6, trace="yes"), "trace"),
        ("load_model('')", lambda: load_model(""), "spec"),
    ]


def test_python_api_refuses_naming_the_argument(tmp_path, dataset):
    from geometry.errors import InputError

    for name, call, arg in _api(tmp_path, dataset):
        with pytest.raises(InputError) as exc:
            call()
        assert exc.value.field == arg, f"{name}: {exc.value}"
    assert list(tmp_path.iterdir()) == []


def test_with_values_changes_a_valves_kind():
    """A kind changed by key path takes that kind's shipped valve, as ``kind = "reed"`` in a model file does."""
    from lumped import load_model, with_values
    from lumped.model.model_file import parse_model

    changed = with_values(load_model("thesis-disc"), {"valves.inlet.kind": "reed"})
    assert changed.kinds == ("reed", "disc")
    as_file = parse_model({"base": "thesis-disc", "valves": {"inlet": {"kind": "reed"}}})
    assert changed.inlet == as_file.inlet
