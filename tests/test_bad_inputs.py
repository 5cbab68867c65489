"""Bad inputs, each refused with exit 2 and one line naming the field: the 41 first cases, then the
second round's classes (model-file base cycles, scheduler addresses, negative numbers in exponent
form, misspelt LTS keys, the argument given named, nothing written before a spec is valid, one key
spelt twice, outputs colliding with each other, with inputs or with earlier output, a load below the
tank pressure, what ``model check`` decides before running: a pump that cannot deliver, a reed resting
beyond its stop, an inlet the tank cannot open), then the Python API's entry points (InputError naming
the argument, before any work; a load below the tank pressure; a plot over an existing file) and the size limits
of the discrepancy workflow and the resumed sweep's JSON.

Every case runs the command line in this process (``studies.cli.main``), from a scratch
folder, and asserts: exit status 2, exactly one line on stderr, the field named in it,
no traceback, nothing written. The unwritable folder is ``/proc`` (nothing can be created
there, not even by root, which a read-only permission bit does not stop); the output
cases are refused before any computation, which the time limit of each case checks.
"""

from __future__ import annotations

import re
import shutil
import time
from pathlib import Path

import pytest

from studies.cli import main

ROOT = Path(__file__).resolve().parents[1]
RO = "/proc/valvelab-unwritable"         # a folder that cannot be created
PROTO = (ROOT / "geometry" / "data" / "reed_prototype.toml").read_text()
UNIFORM = (ROOT / "geometry" / "data" / "reed_uniform.toml").read_text()


def _reed(path: Path, text: str, **kv) -> str:
    for k, v in kv.items():
        text, n = re.subn(rf"(?m)^{k} = [^\n#]*", f"{k} = {v}", text, count=1)
        assert n == 1, k
    path.write_text(text)
    return str(path)


def _sweep(path: Path, fixed: str, extra: str = "") -> str:
    path.write_text('[sweep]\nsampler = "grid"\n' + extra + '[factors.speed_rpm]\nlow = 450.0\nhigh = 950.0\n'
                    'levels = 2\n[fixed]\nvalve = "disc"\nrevolutions = 2\n' + fixed)
    return str(path)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """One synthetic run (593 rpm, 2.76 MPa) and three spoiled copies."""
    base = tmp_path_factory.mktemp("data")
    code = main(["synth", str(base / "ds"), "--condition", "593:2.76", "--revolutions", "2"])
    assert code == 0
    assert len(list((base / "ds").glob("run*/trace.csv"))) == 1

    def variant(name, trace=None, toml=None):
        shutil.copytree(base / "ds", base / name)
        r = next((base / name).glob("run*"))
        if trace:
            (r / "trace.csv").write_text(trace((r / "trace.csv").read_text()))
        if toml:
            (r / "run.toml").write_text(toml((r / "run.toml").read_text()))
        return str(base / name)

    def dup(text):
        rows = text.splitlines()
        i = rows[0].split(",").index("valve_position_m")
        return "\n".join(f"{r},{r.split(',')[i]}" for r in rows) + "\n"

    def shift(text):
        rows = text.splitlines()
        out = [rows[0]]
        for r in rows[1:]:
            c = r.split(",")
            c[0] = repr(float(c[0]) + 5.0)
            out.append(",".join(c))
        return "\n".join(out) + "\n"

    return {
        "ds": str(base / "ds"),
        "dup": variant("dup", trace=dup),
        "typo": variant("typo", toml=lambda s: s + "air_contnet = 0.01\n"),
        "t5": variant("t5", trace=shift),
    }


def _cases(tmp: Path, data: dict) -> list[tuple[str, list[str], str]]:
    """(name, argv, the field the one stderr line must name)."""
    (tmp / "existing_file.csv").write_text("x\n1\n")
    (tmp / "volts.csv").write_text("volts\n1.0\n2.0\n")
    (tmp / "binary.toml").write_bytes(bytes(range(256)) * 4)
    big = tmp / "big_sweep.toml"
    big.write_text('[sweep]\nsampler = "sobol"\nsamples = 100000000000\n[factors.speed_rpm]\nlow = 450.0\n'
                   'high = 950.0\n[fixed]\nvalve = "disc"\nload_pressure = 2.76e6\n')
    (tmp / "sw").mkdir()
    (tmp / "sw" / ".valvelab-output").write_text("")
    pump = ["pump", "--valve", "disc", "--speed-rpm", "593", "--load-pressure-mpa", "2.76"]
    reed_pump = ["pump", "--valve", "reed", "--speed-rpm", "595", "--load-pressure-mpa", "2.76"]
    return [
        # tracebacks (19)
        ("reed --plot unwritable", ["reed", "prototype", "--plot", f"{RO}/x.png"], "--plot"),
        ("table --plot unwritable", ["table", "3.8", "--plot", f"{RO}/x.png"], "--plot"),
        ("lts --plot unwritable", ["lts", "disc_inlet", "--plot", f"{RO}/x.png"], "--plot"),
        ("lts --out unwritable", ["lts", "disc_inlet", "--voltages", str(tmp / "volts.csv"), "--out", f"{RO}/o.csv"],
         "--out"),
        ("sweep-plot --output unwritable", ["sweep-plot", str(tmp / "sw"), "--output", "/proc/x.png"], "--output"),
        ("pump --trace unwritable", pump + ["--trace", "/proc/t.csv"], "--trace"),
        ("validate unwritable", ["validate", "--out", f"{RO}/v"], "--out"),
        ("modes unwritable", ["modes", "--out", f"{RO}/m"], "--out"),
        ("sweep --out unwritable", ["sweep", _sweep(tmp / "ok.toml", "load_pressure = 2.76e6\n"), "--out", f"{RO}/s"],
         "--out"),
        ("synth in an unwritable folder", ["synth", f"{RO}/syn", "--condition", "593:2.76"], "OUT"),
        ("discrepancy --report is a file", ["discrepancy", data["ds"], "--report", str(tmp / "existing_file.csv")],
         "--report"),
        ("reed length 1e300", ["reed", _reed(tmp / "l.toml", UNIFORM, length="1e300")], "reed.length"),
        ("reed thickness 1e-300", ["reed", _reed(tmp / "t.toml", UNIFORM, thickness="1e-300")], "reed.thickness"),
        ("pump --reed-geometry length 1e300", reed_pump + ["--reed-geometry", str(tmp / "l.toml")], "reed.length"),
        ("sweep on a binary file", ["sweep", str(tmp / "binary.toml")], "binary.toml"),
        ("sweep samples 1e11", ["sweep", str(big)], "sweep.samples"),
        ("synth --sample-rate-hz nan", ["synth", str(tmp / "o1"), "--sample-rate-hz", "nan"], "--sample-rate-hz"),
        ("synth --sample-rate-hz inf", ["synth", str(tmp / "o2"), "--sample-rate-hz", "inf"], "--sample-rate-hz"),
        ("synth --seed -1", ["synth", str(tmp / "o3"), "--seed", "-1"], "--seed"),
        # silent nonsense (9)
        ("pump --speed-rpm 1e6", ["pump", "--valve", "disc", "--speed-rpm", "1e6", "--load-pressure-mpa", "2.76"],
         "--speed-rpm"),
        ("Pa typed as MPa", ["pump", "--valve", "disc", "--speed-rpm", "593", "--load-pressure-mpa", "2760000"],
         "--load-pressure-mpa"),
        ("load 1e-9 MPa", ["pump", "--valve", "disc", "--speed-rpm", "593", "--load-pressure-mpa", "1e-9"],
         "--load-pressure-mpa"),
        ("pump --air-content 0.99", pump + ["--air-content", "0.99"], "--air-content"),
        ("pump --dead-volume-m3 1", pump + ["--dead-volume-m3", "1.0", "--method", "fast"], "--dead-volume-m3"),
        ("reed E 1e308", ["reed", _reed(tmp / "e.toml", UNIFORM, youngs_modulus="1e308")],
         "reed.material.youngs_modulus"),
        ("trace.csv with two valve_position_m", ["discrepancy", data["dup"], "--no-report"], "valve_position_m"),
        ("run.toml air_contnet", ["discrepancy", data["typo"], "--no-report"], "air_contnet"),
        ("sweep load_pressure 2.76", ["sweep", _sweep(tmp / "lp.toml", "load_pressure = 2.76\n")],
         "fixed.load_pressure"),
        # implausible values (8)
        ("reed 25 m long", ["reed", _reed(tmp / "l25.toml", PROTO, length="25.4")], "reed.length"),
        ("reed 0.5 m thick", ["reed", _reed(tmp / "h5.toml", UNIFORM, thickness="0.5")], "reed.thickness"),
        ("reed 1 m wide", ["reed", _reed(tmp / "w1.toml", UNIFORM, width_root="1.0", width_tip="1.0")],
         "reed.width"),
        ("pump --speed-rpm 1e-3", ["pump", "--valve", "disc", "--speed-rpm", "1e-3", "--load-pressure-mpa", "2.76"],
         "--speed-rpm"),
        ("sweep air_content 0.99", ["sweep", _sweep(tmp / "air.toml", "load_pressure = 2.76e6\nair_content = 0.99\n")],
         "fixed.air_content"),
        ("synth --workers 0", ["synth", str(tmp / "o4"), "--workers", "0"], "--workers"),
        ("seat --x-stop-mm 1000", ["seat", "--x-stop-mm", "1000"], "--x-stop-mm"),
        ("trace starting at t = 5 s", ["discrepancy", data["t5"], "--no-report"], "time_s"),
        # misleading messages (3)
        ("pump --reed-fidelity fancy", reed_pump + ["--reed-fidelity", "fancy"], "--reed-fidelity"),
        ("synth --revolutions 0", ["synth", str(tmp / "o5"), "--revolutions", "0"], "--revolutions"),
        ("reed E 1e308 --json", ["reed", str(tmp / "e.toml"), "--json"], "youngs_modulus"),
        # hangs (2)
        ("synth --revolutions 100000", ["synth", str(tmp / "o6"), "--revolutions", "100000"], "--revolutions"),
        ("lts --points 1e8", ["lts", "disc_inlet", "--points", "100000000"], "--points"),
    ]


N_CASES = 41


def test_there_are_41_cases(tmp_path, dataset):
    assert len(_cases(tmp_path, dataset)) == N_CASES


@pytest.mark.parametrize("index", range(N_CASES))
def test_refused_with_the_field_named(index, tmp_path, dataset, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name, argv, field = _cases(tmp_path, dataset)[index]
    before = {p for p in tmp_path.rglob("*")}
    capsys.readouterr()
    t0 = time.perf_counter()
    try:
        code = main(argv)
    except SystemExit as exc:            # argparse's refusal of a flag
        code = exc.code
    elapsed = time.perf_counter() - t0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2, f"{name}: exit {code}, stderr {err!r}"
    assert len(lines) == 1, f"{name}: {lines}"
    assert "Traceback" not in err
    assert field in lines[0], f"{name}: {lines[0]!r} does not name {field}"
    # refused before any computation: no pump run, FEA or sweep
    assert elapsed < 20, f"{name}: took {elapsed:.1f} s"
    assert {p for p in tmp_path.rglob("*")} == before, f"{name} wrote files"


# --------------------------------------------------------------------------- second round
SENS = """model = "{model}"
[operating]
speed_rpm = [593.0]
load_pressure_mpa = [2.76]
[variables]
{variables}
[run]
outputs = ["{output}"]
objectives = ["max delivery_cc_per_rev"]
samples = 4
"""


def _spec(path: Path, model="thesis-disc", variables='"oil.air_content" = [0.005, 0.02]',
          output="delivery_cc_per_rev") -> str:
    path.write_text(SENS.format(model=model, variables=variables, output=output))
    return str(path)


@pytest.fixture(scope="module")
def cycle_dataset(dataset, tmp_path_factory):
    """The synthetic run with run.toml naming a model file whose base chain comes back to it."""
    base = tmp_path_factory.mktemp("cyc")
    shutil.copytree(dataset["ds"], base / "cyc")
    r = next((base / "cyc").glob("run*"))
    (r / "run.toml").write_text((r / "run.toml").read_text() + 'model = "a.toml"\n')
    (r / "a.toml").write_text('base = "b.toml"\n')
    (r / "b.toml").write_text('base = "a.toml"\n')
    return str(base / "cyc")


def _cases_two(tmp: Path, data: dict, cyc: str) -> list[tuple]:
    """(name, argv, the field named, strings the line must also hold, strings it must not hold)."""
    (tmp / "self.toml").write_text('base = "self.toml"\n')
    (tmp / "a.toml").write_text('base = "b.toml"\n')
    (tmp / "b.toml").write_text('base = "a.toml"\n')
    (tmp / "model.toml").write_text('base = "thesis-disc"\n')
    (tmp / "volts.csv").write_text("volts\n1.0\n2.0\n")
    (tmp / "lts.toml").write_text("[lts]\nair_gap = 90.67e-3\nwindow_thicknes = 12.14e-3\n")
    (tmp / "reed.toml").write_text(UNIFORM)
    (tmp / "sw2").mkdir()
    (tmp / "sw2" / ".valvelab-output").write_text("written by valvelab sweep; files here may be replaced\n")
    (tmp / "sw2" / "results.parquet").write_bytes(b"PAR1 the sweep's results")
    (tmp / "specs").mkdir()
    spec_in_folder = _sweep(tmp / "specs" / "s.toml", "load_pressure = 2.76e6\n")
    ok = _sweep(tmp / "ok.toml", "load_pressure = 2.76e6\n")
    cycle_sweep = tmp / "cyc_sweep.toml"
    cycle_sweep.write_text('[sweep]\nmodel = "a.toml"\nsampler = "grid"\n[factors.speed_rpm]\nlow = 450.0\n'
                           'high = 950.0\nlevels = 2\n')
    dup_sweep = tmp / "dup_sweep.toml"
    dup_sweep.write_text('[sweep]\nsampler = "grid"\n[factors."valves.inlet.spring.stiffness"]\nlow = 150.0\n'
                         'high = 300.0\nlevels = 2\n[factors.valves.inlet.spring.stiffness]\nlow = 100.0\n'
                         'high = 300.0\nlevels = 2\n[fixed]\nvalve = "disc"\n')
    alias_sweep = tmp / "alias_sweep.toml"
    alias_sweep.write_text('[sweep]\nsampler = "grid"\n[factors.inlet.spring_stiffness]\nlow = 150.0\nhigh = 300.0\n'
                           'levels = 2\n[fixed]\nvalve = "disc"\n"valves.inlet.spring.stiffness" = 200.0\n')
    (tmp / "no_delivery.toml").write_text('base = "thesis-disc"\n[pump]\ndead_volume = 1e-3\n')
    (tmp / "reed_beyond_stop.toml").write_text('base = "thesis-reed"\n[valves.delivery]\nseat.preload = 5e-3\n')
    (tmp / "stiff_inlet.toml").write_text('base = "thesis-disc"\n[valves.inlet]\nspring.stiffness = 5000.0\n')
    dup_model = tmp / "dup_model.toml"
    dup_model.write_text('base = "thesis-disc"\n[valves.inlet]\n"spring.stiffness" = 300.0\nspring.stiffness = 250.0\n')
    key = '"valves.inlet.spring.stiffness"'
    pump = ["pump", "--valve", "disc", "--speed-rpm", "593", "--load-pressure-mpa", "2.76"]
    chain = "a.toml -> b.toml -> a.toml"
    return [
        # a model file's base naming itself or coming back through another file
        ("base names its own file", ["model", "check", str(tmp / "self.toml"), "--no-fea"], "base",
         ("self.toml -> self.toml",), ()),
        ("two files naming each other", ["pump", "--model", str(tmp / "a.toml"), "--speed-rpm", "593",
                                         "--load-pressure-mpa", "2.76"], "base", (chain,), ()),
        ("base cycle through run.toml's model", ["discrepancy", cyc, "--no-report"], "base", (chain,), ()),
        ("base cycle through a sweep spec's model", ["sweep", str(cycle_sweep), "--out", str(tmp / "s1")], "base",
         (chain,), ()),
        ("base cycle through a sensitivity spec's model", ["sensitivity", _spec(tmp / "c.toml", model="a.toml"),
                                                            "--out", str(tmp / "s2")], "base", (chain,), ()),
        # scheduler addresses
        ("sweep --scheduler notanaddress", ["sweep", ok, "--scheduler", "notanaddress"], "--scheduler",
         ("host:port",), ()),
        ("sensitivity --scheduler notanaddress", ["sensitivity", _spec(tmp / "s.toml"), "--scheduler", "notanaddress"],
         "--scheduler", ("host:port",), ()),
        ("optimize --scheduler localhost", ["optimize", _spec(tmp / "o.toml"), "--scheduler", "localhost"],
         "--scheduler", ("tcp://host:port", "no port"), ()),
        # negative numbers in exponent form reach the range check
        ("reed --mesh-size -1e-4", ["reed", "prototype", "--fidelity", "solid", "--mesh-size", "-1e-4"], "--mesh-size",
         ("expected a number", "-0.0001"), ("expected one argument",)),
        ("pump --speed-rpm -5.93e2", ["pump", "--valve", "disc", "--speed-rpm", "-5.93e2"], "--speed-rpm",
         ("expected a number", "-593"), ("expected one argument",)),
        # the unknown key and its closest match; the argument actually given
        ("lts setup window_thicknes", ["lts", str(tmp / "lts.toml")], "lts.window_thicknes",
         ("did you mean window_thickness",), ("missing",)),
        ("sweep-plot on a missing folder", ["sweep-plot", str(tmp / "nowhere")], "nowhere", (), ("--output",)),
        # refused by validation: nothing written in --out (the harness checks)
        ("sensitivity of the reed stress on disc valves", ["sensitivity", _spec(tmp / "r.toml",
                                                           output="reed_stress_mpa"), "--out", str(tmp / "s3")],
         "run.outputs", ("reed",), ()),
        # one variable spelt twice
        ("sensitivity: a quoted and a dotted key", ["sensitivity", _spec(
            tmp / "d1.toml", variables=f"{key} = [150.0, 300.0]\nvalves.inlet.spring.stiffness = [100.0, 300.0]")],
         f"variables.{key}", ("variables.valves.inlet.spring.stiffness",), ()),
        ("optimize: a key and a table", ["optimize", _spec(
            tmp / "d2.toml", variables=f"{key} = [150.0, 300.0]\n[variables.valves.inlet.spring.stiffness]\n"
                                       "low = 100.0\nhigh = 300.0")],
         f"variables.{key}", ("variables.valves.inlet.spring.stiffness",), ()),
        ("sweep: a quoted and a dotted factor", ["sweep", str(dup_sweep)], f"factors.{key}",
         ("factors.valves.inlet.spring.stiffness",), ()),
        ("sweep: a first-version name and its key path", ["sweep", str(alias_sweep)], "inlet.spring_stiffness",
         ("valves.inlet.spring.stiffness",), ()),
        ("model file: a quoted and a dotted key", ["model", "check", str(dup_model), "--no-fea"],
         'valves.inlet."spring.stiffness"', ("valves.inlet.spring.stiffness",), ()),
        # outputs colliding with each other, with an input or with earlier output
        ("pump --trace and --plot one file", pump + ["--trace", "x.csv", "--plot", "x.csv"], "--plot", ("--trace",),
         ()),
        ("pump --trace over its --model", pump[:1] + ["--model", str(tmp / "model.toml"), "--speed-rpm", "593",
                                                      "--trace", str(tmp / "model.toml"), "--force"],
         "--trace", ("--model",), ()),
        ("lts --out and --plot one file", ["lts", "disc_inlet", "--voltages", str(tmp / "volts.csv"), "--out", "p.png",
                                           "--plot", "p.png"], "--out", ("--plot",), ()),
        ("reed --plot over its geometry", ["reed", str(tmp / "reed.toml"), "--plot", str(tmp / "reed.toml"), "--force"],
         "--plot", ("GEOMETRY",), ()),
        ("synth into the dataset it wrote", ["synth", data["ds"], "--condition", "593:2.76", "--revolutions", "2"],
         "OUT", ("already holds", "--force"), ()),
        ("discrepancy --report into its dataset", ["discrepancy", data["ds"], "--report", data["ds"]], "--report",
         ("DATASET",), ()),
        ("sweep --out into a dataset", ["sweep", ok, "--out", data["ds"]], "--out", ("dataset",), ()),
        ("sweep --out into its spec's folder", ["sweep", spec_in_folder, "--out", str(tmp / "specs"), "--force"],
         "--out", ("SPEC",), ()),
        ("sweep-plot --output over the sweep's results", ["sweep-plot", str(tmp / "sw2"), "--output",
                                                          str(tmp / "sw2" / "results.parquet")], "--output",
         ("already exists",), ()),
        # the pump core: a load below the tank pressure; what model check can decide before running
        ("pump load below the tank pressure", pump[:5] + ["--load-pressure-mpa", "0.05"], "--load-pressure-mpa",
         ("below the tank pressure",), ("the model failed",)),
        ("model check: a pump that cannot deliver", ["model", "check", str(tmp / "no_delivery.toml"), "--no-fea"],
         "operating.load_pressure", ("cannot deliver against 2.76 MPa", "at most"), ()),
        ("model check: a reed resting beyond its stop", ["model", "check", str(tmp / "reed_beyond_stop.toml"),
                                                         "--no-fea"], "valves.delivery.seat.preload",
         ("beyond its 1.90 mm stop",), ()),
        ("model check: an inlet the tank pressure cannot open", ["model", "check", str(tmp / "stiff_inlet.toml"),
                                                                 "--no-fea"], "valves.inlet", ("cannot fill",), ()),
    ]


N_CASES_TWO = 31


def test_the_second_round_has_its_cases(tmp_path, dataset, cycle_dataset):
    assert len(_cases_two(tmp_path, dataset, cycle_dataset)) == N_CASES_TWO


@pytest.mark.parametrize("index", range(N_CASES_TWO))
def test_second_round_refused_with_the_field_named(index, tmp_path, dataset, cycle_dataset, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name, argv, field, also, absent = _cases_two(tmp_path, dataset, cycle_dataset)[index]
    before = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")}
    before_data = {p: p.stat().st_mtime_ns for p in Path(dataset["ds"]).rglob("*")}
    capsys.readouterr()
    t0 = time.perf_counter()
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    elapsed = time.perf_counter() - t0
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2, f"{name}: exit {code}, stderr {err!r}"
    assert len(lines) == 1, f"{name}: {lines}"
    assert "Traceback" not in err and "RecursionError" not in err
    assert field in lines[0], f"{name}: {lines[0]!r} does not name {field}"
    for s in also:
        assert s in lines[0], f"{name}: {lines[0]!r} lacks {s!r}"
    for s in absent:
        assert s not in lines[0], f"{name}: {lines[0]!r} holds {s!r}"
    assert elapsed < 20, f"{name}: took {elapsed:.1f} s"
    # nothing written, nothing replaced (the user's files and the earlier dataset alike)
    assert {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")} == before, f"{name} wrote files"
    assert {p: p.stat().st_mtime_ns for p in Path(dataset["ds"]).rglob("*")} == before_data, f"{name} changed ds"


# --------------------------------------------------------------------------- the Python API
def _api_cases(tmp: Path, data: dict) -> list[tuple]:
    """(name, call, the argument the InputError must name): every public entry point refuses bad types
    and values before any work."""
    from geometry.errors import InputError  # noqa: F401
    from lumped import load_model, reed_properties, with_values
    from studies.discrepancy import Settings, Workflow, read_dataset, synthesize
    from studies.discrepancy.pump_sim import LIBRARY, simulate
    from studies.discrepancy.synth import Condition, Noise
    from studies.sweeps import load_spec, run_sweep
    from studies.sweeps.design import spec as design_spec
    from studies.sweeps.design.optimize import run_optimize
    from studies.sweeps.design.sensitivity import run_sensitivity

    (tmp / "a.toml").write_text('base = "b.toml"\n')
    (tmp / "b.toml").write_text('base = "a.toml"\n')
    sweep_spec = load_spec(_sweep(tmp / "ok.toml", "load_pressure = 2.76e6\n"))
    sens = design_spec.load_spec(_spec(tmp / "sens.toml"), "sensitivity")
    opt = design_spec.load_spec(_spec(tmp / "opt.toml"), "optimize")
    runs = read_dataset(data["ds"])
    cond = [Condition(593.0, 2.76e6)]
    (tmp / "valves.png").write_bytes(b"the user's figure")
    from lumped import simulate as pump
    return [
        ("Settings(workers=-1)", lambda: Settings(workers=-1), "workers"),
        ("Settings(max_rounds=-2)", lambda: Settings(max_rounds=-2), "max_rounds"),
        ("Settings(min_rel_improvement=nan)", lambda: Settings(min_rel_improvement=float("nan")),
         "min_rel_improvement"),
        ("Settings(max_rounds='3')", lambda: Settings(max_rounds="3"), "max_rounds"),
        ("Settings(holdout='run1')", lambda: Settings(holdout="run1"), "holdout"),
        ("Settings(scale_bounds reversed)", lambda: Settings(scale_bounds=(1.05, 0.95)), "scale_bounds"),
        ("Settings(min_abs_improvement=inf)", lambda: Settings(min_abs_improvement=float("inf")),
         "min_abs_improvement"),
        ("Workflow(runs, sim, None)", lambda: Workflow(runs, simulate, None), "library"),
        ("Workflow(runs, None, LIBRARY)", lambda: Workflow(runs, None, LIBRARY), "simulator"),
        ("Workflow(runs, sim, LIBRARY, settings={})", lambda: Workflow(runs, simulate, LIBRARY, {}), "settings"),
        ("Workflow(42, ...)", lambda: Workflow(42, simulate, LIBRARY), "runs"),
        ("Workflow(a missing folder, ...)", lambda: Workflow(str(tmp / "nowhere"), simulate, LIBRARY), "nowhere"),
        ("reed_properties(42)", lambda: reed_properties(42), "reed"),
        ("reed_properties('prototype', 'fancy')", lambda: reed_properties("prototype", "fancy"), "fidelity"),
        ("reed_properties('prototype', mesh_size=-1)", lambda: reed_properties("prototype", mesh_size=-1.0),
         "mesh_size"),
        ("load_model(None)", lambda: load_model(None), "spec"),
        ("load_model(a base cycle)", lambda: load_model(tmp / "a.toml"), "base"),
        ("with_values(model, [...])", lambda: with_values(load_model("thesis-disc"), ["pump.dead_volume"]), "values"),
        ("run_sweep(out=None)", lambda: run_sweep(sweep_spec, None), "out"),
        ("run_sweep(scheduler='localhost')", lambda: run_sweep(sweep_spec, tmp / "o", scheduler="localhost"),
         "scheduler"),
        ("run_sweep(n_workers=0)", lambda: run_sweep(sweep_spec, tmp / "o", n_workers=0), "n_workers"),
        ("run_sweep(force='yes')", lambda: run_sweep(sweep_spec, tmp / "o", force="yes"), "force"),
        ("run_sweep(fmt='xlsx')", lambda: run_sweep(sweep_spec, tmp / "o", fmt="xlsx"), "fmt"),
        ("run_sweep(a dict spec)", lambda: run_sweep({"sweep": {}}, tmp / "o"), "spec"),
        ("sweeps.load_spec(None)", lambda: load_spec(None), "path"),
        ("design load_spec(command='optimise')", lambda: design_spec.load_spec(tmp / "sens.toml", "optimise"),
         "command"),
        ("run_sensitivity(an optimize spec)", lambda: run_sensitivity(opt, tmp / "o"), "spec"),
        ("run_sensitivity(workers=0)", lambda: run_sensitivity(sens, tmp / "o", workers=0), "workers"),
        ("run_optimize(scheduler='localhost')", lambda: run_optimize(opt, tmp / "o", scheduler="localhost"),
         "scheduler"),
        ("run_optimize(progress=None)", lambda: run_optimize(opt, tmp / "o", progress=None), "progress"),
        ("synthesize(simulator=None)", lambda: synthesize(None, "disc", cond), "simulator"),
        ("synthesize(load in MPa)", lambda: synthesize(simulate, "disc", [Condition(593.0, 2.76)]),
         "conditions[0].load_pressure_pa"),
        ("synthesize(seed=-1)", lambda: synthesize(simulate, "disc", cond, seed=-1), "seed"),
        ("synthesize(1e9 samples)", lambda: synthesize(simulate, "disc", cond,
                                                       noise=Noise(sample_rate_hz=1e7, revolutions=1000)),
         "noise.revolutions"),
        ("read_dataset(None)", lambda: read_dataset(None), "path"),
        ("simulate(load below the tank pressure)", lambda: pump("thesis-disc", 593, 0.05e6), "load_pressure"),
        ("PumpResult.plot over an existing file", lambda: pump("thesis-disc", 593, 2.76e6, revolutions=2, trace=True)
         .plot(tmp / "valves.png"), "path"),
    ]


N_API = 37


def test_the_api_cases(tmp_path, dataset):
    assert len(_api_cases(tmp_path, dataset)) == N_API


@pytest.mark.parametrize("index", range(N_API))
def test_python_api_refuses_naming_the_argument(index, tmp_path, dataset, monkeypatch):
    from geometry.errors import InputError

    monkeypatch.chdir(tmp_path)
    name, call, field = _api_cases(tmp_path, dataset)[index]
    before = {p for p in tmp_path.rglob("*")}
    t0 = time.perf_counter()
    with pytest.raises(InputError) as exc:
        call()
    assert field in exc.value.field or field in str(exc.value), f"{name}: {exc.value} does not name {field}"
    assert time.perf_counter() - t0 < 20, f"{name}: refused only after work"
    assert {p for p in tmp_path.rglob("*")} == before, f"{name} wrote files"


def test_python_api_accepts_what_it_documents(dataset):
    """A preset name for reed_properties, a dataset folder for Workflow: the same as the objects."""
    from geometry import load_reed
    from lumped import reed_properties
    from studies.discrepancy import Settings, Workflow, read_dataset
    from studies.discrepancy.pump_sim import LIBRARY, simulate

    by_name = reed_properties("prototype", "analytic")
    by_object = reed_properties(load_reed("prototype"), "analytic")
    for q in ("omega_n", "kappa", "gamma1", "gamma2", "gamma3", "h_eff"):
        assert getattr(by_name, q) == getattr(by_object, q), q
    # Table 3.13 / section 3.8.1: the prototype reed's analytic kappa is within 6 % of the thesis's 6.353e6 Pa/m
    assert by_name.kappa == pytest.approx(6.353e6, rel=0.06)
    wf = Workflow(dataset["ds"], simulate, LIBRARY, Settings(max_rounds=0))
    assert [r.name for r in wf.runs] == [r.name for r in read_dataset(dataset["ds"])]
    # Settings keeps what it was given, normalised (a list of names becomes a tuple)
    assert Settings(holdout=["run01"], workers=2.0).holdout == ("run01",)


def test_a_long_trace_is_averaged_down_with_a_note(capsys):
    """Long traces of known signals are averaged to at most MAX_TRACE_SAMPLES before any simulation, each
    block's mean at its mean crank angle, and a note plus a line on stderr say so: one revolution of a ramp
    in 1,000,000 samples (a linear signal's block mean is its value at the block's centre), and 100
    revolutions of a sine in 1,000 samples each (blocks gather the revolutions' samples at one crank angle,
    so they stay exact; blocks of consecutive samples would span 3.6 deg and miss by ~1e-4 relative)."""
    import numpy as np

    from studies.discrepancy import Workflow
    from studies.discrepancy.measured import Run, Trace
    from studies.discrepancy.pump_sim import LIBRARY
    from studies.discrepancy.workflow import MAX_TRACE_SAMPLES

    def run_of(t, x, rpm):
        return Run(name="long", valve_type="disc", speed_rpm=rpm, load_pressure_pa=2.76e6, measured_valve="delivery",
                   trace=Trace.measured(t, {"delivery": x}, None, None, rpm))

    def never(cond, effects):
        raise AssertionError("no simulation before the size is settled")

    n, rpm, period = 1_000_000, 600.0, 0.1
    t = np.arange(n) * (period / n)
    t0 = time.perf_counter()
    wf = Workflow([run_of(t, 1e-3 * t / period, rpm)], never, LIBRARY)
    assert time.perf_counter() - t0 < 10
    tr = wf.runs[0].trace
    assert len(tr.time) <= MAX_TRACE_SAMPLES and len(tr.time) == n // 100
    assert np.allclose(tr.positions["delivery"], 1e-3 * tr.time / period, rtol=0, atol=1e-15)
    assert any("blocks of 100" in s for s in wf.notes)
    assert "blocks of 100" in capsys.readouterr().err

    per_rev, revs = 1000, 100
    t = np.arange(per_rev * revs) * (period / per_rev)
    theta = 2 * np.pi * t / period
    wf = Workflow([run_of(t, 1e-3 * np.sin(theta), rpm)], never, LIBRARY)
    tr = wf.runs[0].trace
    assert len(tr.time) == per_rev * revs // 10 and np.all(tr.time < period) and np.all(np.diff(tr.time) >= 0)
    assert np.max(np.abs(tr.positions["delivery"] - 1e-3 * np.sin(2 * np.pi * tr.time / period))) < 1e-12


def test_a_study_with_nothing_computed_gives_way_to_the_corrected_spec(tmp_path):
    """A refused or stopped study that computed nothing does not hold its folder against the corrected spec;
    one that computed something does (unless --force)."""
    from geometry.errors import InputError
    from studies.sweeps.design import runner, spec as design_spec

    first = design_spec.load_spec(_spec(tmp_path / "a.toml"), "sensitivity")
    second = design_spec.load_spec(_spec(tmp_path / "b.toml", variables='"oil.air_content" = [0.005, 0.03]'),
                                   "sensitivity")
    assert first.digest != second.digest
    out = tmp_path / "study"
    runner.prepare_study(out, first, False, ("runs", "calibration"))
    runner.prepare_study(out, second, False, ("runs", "calibration"))     # nothing computed: replaced
    (out / "runs").mkdir()
    with pytest.raises(InputError) as exc:
        runner.prepare_study(out, first, False, ("runs", "calibration"))
    assert exc.value.field == "--out" and "different" in exc.value.message
