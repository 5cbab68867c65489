"""Property-based fuzzing of every command and input file type (hypothesis).

Each example draws a command, a few of its flags and input files, each either a
plausible value or a bad one (NaN, infinity, a negative, a unit slip, a fraction where
a count is asked, a missing or binary or unwritable path, a misspelt or missing key, a
spoiled CSV cell). Then, run in this process from a fresh folder:

- with a bad value in the draw: exit 2 and exactly one line on stderr that names a bad
  field (removing a validator lets a bad value through: the example fails);
- with plausible values only (for the commands that are cheap when they run): exit 0
  and one JSON object of finite numbers on stdout;
- always: no traceback (no exception leaves ``main``), an example time limit (no hang),
  and no file written outside the output paths of the draw.

The same is asked of model files combined with the commands' flags (a model file spoiled
in one key, naming a missing base or a base that comes back to it, with good or bad flags of
``pump``, ``synth``, ``sweep``, ``sensitivity``, ``discrepancy``, ``model``), and of the Python
API's entry points (``Settings``, ``Workflow``, ``load_model``, ``with_values``,
``reed_properties``, ``read_dataset``, the sweep, sensitivity and optimisation entry points,
``synthesize``): a bad argument raises InputError naming it before any work, good arguments
of the cheap ones return.

Deterministic (``derandomize``): the same examples in every run; the three tests take well
under a minute together.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import tempfile
import tomllib
from pathlib import Path

import tomli_w
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from geometry import PRESETS
from studies.cli import main

ROOT = Path(__file__).resolve().parents[1]
UNIFORM = tomllib.loads((ROOT / "geometry" / "data" / "reed_uniform.toml").read_text())
EXAMPLE_SECONDS = 30


class Draw:
    """One example: argv, files to write, the fields a bad value went into, the allowed outputs."""

    def __init__(self, command: str):
        self.argv = [command]
        self.files: dict[str, bytes] = {}
        self.bad: list[str] = []
        self.outputs: list[str] = []

    def flag(self, name: str, value: str, bad: bool, names: tuple[str, ...] = ()):
        self.argv += [name, value]
        if bad:
            self.bad += [name, *names]


def _num(lo, hi, log=False):
    if log:
        return st.floats(math.log10(lo), math.log10(hi)).map(lambda e: f"{10 ** e:.6g}")
    return st.floats(lo, hi).map(lambda v: f"{v:.6g}")


BAD_TEXT = st.sampled_from(["nan", "inf", "-inf", "abc", "", "1,5", "--"])


def _bad_num(lo, hi, extra=()):
    out = [f"{-abs(hi) * 10:g}", f"{hi * 1000:g}", *extra]
    if lo > 0:
        out += [f"{lo / 1000:g}", "0"]
    return st.one_of(BAD_TEXT, st.sampled_from(out))


def _bad_int(lo, hi):
    return st.one_of(BAD_TEXT, st.sampled_from([str(lo - 1), str(hi * 1000), "2.5", "1e30"]))


def _path_flag(d: Draw, data, name: str, suffix: str, bad: bool, folder: bool = False):
    """An output path: new (good), or unwritable, a folder for a file, a file for a folder, a
    missing parent folder (files only: folders are created with their parents), a user's file
    or a user's non-empty folder (bad)."""
    if not bad:
        p = f"out_{len(d.outputs)}{suffix}"
        d.outputs.append(p)
        d.flag(name, p, False)
        return
    kinds = ["proc", "existing", "dir"] + ([] if folder else ["missing_dir"])
    kind = data.draw(st.sampled_from(kinds))
    p = {"proc": f"/proc/x{suffix}", "dir": "a_folder", "missing_dir": f"nowhere/x{suffix}",
         "existing": f"mine{suffix}"}[kind]
    if kind == "existing":
        d.files[p] = b"a user's file\n"
    if kind == "dir":
        d.files["a_folder/keep.txt"] = b"x\n"
    d.flag(name, p, True)


# --------------------------------------------------------------------------- files
def _reed_file(d: Draw, data, bad: bool) -> str:
    doc = json.loads(json.dumps(UNIFORM))
    r = doc["reed"]
    if not bad:
        k = data.draw(st.floats(0.6, 1.6))
        for key in ("length", "thickness", "width_root", "width_tip"):
            r[key] = r[key] * k
        r["tip_radius"] = min(r.get("tip_radius", 0.0), r["width_tip"] / 2)
    elif data.draw(st.booleans()):       # a dimension typed in mm into a file in m
        key = data.draw(st.sampled_from(["length", "thickness", "width_tip"]))
        r[key] = r[key] * (60.0 if key == "width_tip" else 1000.0)    # a 1 m wide strip 25 mm long
        if key == "width_tip":
            r["width_root"] = r["width_tip"]
            key = "width"
        d.bad.append(key)
    else:
        key = data.draw(st.sampled_from(["length", "thickness", "width_tip", "youngs_modulus", "density",
                                         "poisson_ratio", "lenght", "-length"]))
        table = r["material"] if key in ("youngs_modulus", "density", "poisson_ratio") else r
        if key == "lenght":
            table[key] = 0.02
        elif key == "-length":
            del table["length"]
            key = "length"
        else:
            table[key] = data.draw(st.sampled_from([float("nan"), float("inf"), -1.0, 0.0, 1e300, 1e-300,
                                                    "text", True]))
        d.bad.append(key)
    d.files["reed.toml"] = tomli_w.dumps(doc).encode()
    return "reed.toml"


def _binary(d: Draw, name: str) -> str:
    d.files[name] = bytes(range(256)) * 8
    d.bad.append(name)
    return name


MODEL_TEXT = (ROOT / "lumped" / "data" / "models" / "thesis-disc.toml").read_text()


def _model_file(d: Draw, data, bad: bool, kinds=("value", "misspelt", "self_base", "cycle", "missing_base",
                                                 "binary")) -> str:
    """``model.toml``: the thesis disc pump (good: as shipped, or a plausible change on a base), or spoiled:
    one bad value, a misspelt key, a base naming itself, two files naming each other, a missing base, binary."""
    if not bad:
        if data.draw(st.booleans()):
            d.files["model.toml"] = MODEL_TEXT.encode()
        else:
            dv = data.draw(st.floats(1.8e-5, 3e-5))
            d.files["model.toml"] = f'base = "thesis-disc"\n[pump]\ndead_volume = {dv:.6g}\n'.encode()
        return "model.toml"
    kind = data.draw(st.sampled_from(kinds))
    if kind == "value":
        key, value = data.draw(st.sampled_from([("piston_diameter", "nan"), ("crank_radius", "-1.0"),
                                                ("dead_volume", "1e300"), ("air_content", "0.99"),
                                                ("bulk_modulus", "1.5"), ("spring.stiffness", "-213.0"),
                                                ("seat.stiffness", "inf"), ("density", '"heavy"'),
                                                ("displacement", "1.0")]))
        new, n = re.subn(rf"(?m)^{re.escape(key)} = [^\n#]*", f"{key} = {value}", MODEL_TEXT, count=1)
        if n == 0:        # a key the model file does not declare
            new, n = re.subn(r"(?m)^\[pump\][^\n]*$", f"[pump]\n{key} = {value}", MODEL_TEXT, count=1)
        assert n == 1
        d.files["model.toml"] = new.encode()
        d.bad.append(key)
    elif kind == "misspelt":
        d.files["model.toml"] = b'base = "thesis-disc"\n[pump]\ndead_volum = 2.2e-5\n'
        d.bad.append("dead_volum")
    elif kind == "self_base":
        d.files["model.toml"] = b'base = "model.toml"\n'
        d.bad.append("base")
    elif kind == "cycle":
        d.files["model.toml"] = b'base = "other.toml"\n'
        d.files["other.toml"] = b'base = "model.toml"\n'
        d.bad.append("base")
    elif kind == "missing_base":
        d.files["model.toml"] = b'base = "no_such_base.toml"\n'
        d.bad += ["base", "no_such_base"]
    else:
        return _binary(d, "model.toml")
    return "model.toml"


# --------------------------------------------------------------------------- commands
def draw_reed(data) -> tuple[Draw, bool]:
    d = Draw("reed")
    src = data.draw(st.sampled_from(["preset", "file", "bad_file", "missing", "binary"]))
    if src == "preset":
        d.argv.append(data.draw(st.sampled_from(PRESETS)))
    elif src in ("file", "bad_file"):
        d.argv.append(_reed_file(d, data, src == "bad_file"))
    elif src == "missing":
        d.argv.append("no_such_reed.toml")
        d.bad.append("no_such_reed.toml")
    else:
        d.argv.append(_binary(d, "reed_binary.toml"))
    if data.draw(st.booleans()):
        bad = data.draw(st.booleans())
        d.flag("--modes", data.draw(_bad_int(1, 50) if bad else st.integers(1, 4).map(str)), bad)
    if data.draw(st.booleans()):
        d.flag("--fidelity", "fancy", True)
    if data.draw(st.booleans()):
        d.flag("--mesh-size", data.draw(_bad_num(1e-7, 10.0)), True)
    if data.draw(st.integers(0, 3)) == 0:
        _path_flag(d, data, "--plot", ".png", data.draw(st.booleans()))
    return d, True


def draw_lts(data) -> tuple[Draw, bool]:
    d = Draw("lts")
    d.argv.append(data.draw(st.sampled_from(["disc_inlet", "disc_delivery", "reed"])))
    for flag, lo, hi in (("--points", 3, 10001),):
        if data.draw(st.booleans()):
            bad = data.draw(st.booleans())
            d.flag(flag, data.draw(_bad_int(lo, hi) if bad else st.integers(3, 41).map(str)), bad)
    for flag, lo, hi, valid in (("--x-max-mm", 1e-3, 100.0, _num(0.2, 3.0)), ("--air-gap-mm", 0.0, 1e4, _num(80, 95)),
                                ("--n-fluid", 1.0, 4.0, _num(1.3, 1.6))):
        if data.draw(st.booleans()):
            bad = data.draw(st.booleans())
            d.flag(flag, data.draw(_bad_num(lo, hi) if bad else valid), bad)
    if data.draw(st.integers(0, 3)) == 0:
        _path_flag(d, data, "--plot", ".png", data.draw(st.booleans()))
    return d, True


def draw_table(data) -> tuple[Draw, bool]:
    d = Draw("table")
    if data.draw(st.booleans()):
        d.argv.append(data.draw(st.sampled_from(["2.3", "3.8", "3.12", "3.13", "5.2", "B.2"])))
    else:
        d.argv.append(data.draw(st.sampled_from(["9.9", "abc", "5.4x", ""])))
        d.bad.append("table")
    return d, True


PUMP_NUMBERS = {   # flag: (valid strategy, bad strategy)
    "--speed-rpm": (_num(300, 1200), _bad_num(10.0, 20000.0, extra=("1e6", "5"))),
    "--load-pressure-mpa": (_num(1.0, 5.0), _bad_num(0.01, 100.0, extra=("2760000", "1e-9"))),
    "--air-content": (_num(0.0, 0.03), _bad_num(0.0, 0.49, extra=("0.99", "0.5"))),
    "--revolutions": (st.integers(2, 3).map(str), _bad_int(2, 100_000)),
    "--rtol": (_num(1e-4, 1e-2, log=True), _bad_num(1e-14, 0.1)),
    "--dead-volume-m3": (_num(1e-5, 5e-5), _bad_num(1e-9, 1.0, extra=("1.0",))),
}


def draw_pump(data) -> tuple[Draw, bool]:
    d = Draw("pump")
    d.argv += ["--valve", data.draw(st.sampled_from(["disc", "reed"]))]
    flags = data.draw(st.lists(st.sampled_from(sorted(PUMP_NUMBERS)), min_size=1, max_size=3, unique=True))
    forced = data.draw(st.sampled_from(flags))      # a pump run is never cheap enough: one value is bad
    for f in flags:
        bad = f == forced or data.draw(st.booleans())
        good, wrong = PUMP_NUMBERS[f]
        d.flag(f, data.draw(wrong if bad else good), bad)
    extra = data.draw(st.sampled_from(["none", "circuit", "method", "trace", "fidelity"]))
    if extra == "circuit":
        d.flag("--circuit", "complex", True)
    elif extra == "method":
        d.flag("--method", "slow", True)
    elif extra == "trace":
        _path_flag(d, data, "--trace", ".csv", True)
    elif extra == "fidelity":
        d.flag("--reed-fidelity", "fancy", True)
    return d, False


def draw_synth(data) -> tuple[Draw, bool]:
    d = Draw("synth")
    d.argv.append("dataset_out")
    d.outputs.append("dataset_out")
    numbers = {"--sample-rate-hz": _bad_num(1e3, 1e7), "--seed": _bad_int(0, 2**32 - 1),
               "--workers": _bad_int(1, 256), "--revolutions": _bad_int(1, 1000),
               "--noise-um": _bad_num(0.0, 1e4), "--scale-error": _bad_num(-0.2, 0.2)}
    f = data.draw(st.sampled_from(sorted(numbers) + ["--condition", "--effect", "--valve"]))
    if f == "--condition":
        d.flag(f, data.draw(st.sampled_from(["593:2760000", "593", "abc:2", "1e6:2.76", "593:2.76:both:x"])), True)
    elif f == "--effect":
        d.flag(f, data.draw(st.sampled_from(["warp_drive", "seat_compliance:k_seat=-5",
                                             "seat_compliance:nope=1", "seat_compliance:k_seat=nan"])), True)
    elif f == "--valve":
        d.flag(f, "gate", True)
    else:
        d.flag(f, data.draw(numbers[f]), True)
    return d, False


def draw_sweep(data) -> tuple[Draw, bool]:
    d = Draw("sweep")
    doc = {"sweep": {"sampler": "grid"},
           "factors": {"speed_rpm": {"low": 450.0, "high": 950.0, "levels": 2}},
           "fixed": {"valve": "disc", "load_pressure": 2.76e6, "revolutions": 2}}
    key = data.draw(st.sampled_from(["load_pressure", "air_content", "revolutions", "levels", "samples",
                                     "unknown", "speed_high", "binary"]))
    if key == "binary":
        d.argv.append(_binary(d, "sweep.toml"))
        return d, False
    value = data.draw(st.sampled_from([float("nan"), -1.0, 2.76, 0.99, 1e300, "text", 2.5]))
    if key == "levels":
        doc["factors"]["speed_rpm"]["levels"] = data.draw(st.sampled_from([1, 0, 2.5, 10**9]))
    elif key == "samples":
        doc["sweep"] = {"sampler": "sobol", "samples": data.draw(st.sampled_from([0, -4, 10**11, 2.5]))}
        del doc["factors"]["speed_rpm"]["levels"]
    elif key == "unknown":
        doc["fixed"]["load_presure"] = 2.76e6
        key = "load_presure"
    elif key == "speed_high":
        doc["factors"]["speed_rpm"]["high"] = data.draw(st.sampled_from([1e6, float("nan"), -5.0]))
        key = "speed_rpm"
    elif key == "revolutions":
        doc["fixed"]["revolutions"] = data.draw(st.sampled_from([0, -1, 2.5, 10**9, "two"]))
    else:
        doc["fixed"][key] = value if not (key == "air_content" and value == 2.5) else 0.99
        if key == "load_pressure" and isinstance(value, float) and 1e4 <= value <= 1e8:
            doc["fixed"][key] = 2.76
    d.bad.append(key)
    d.files["sweep.toml"] = tomli_w.dumps(doc).encode()
    d.argv.append("sweep.toml")
    d.argv += ["--out", "sweep_out", "--no-progress"]
    d.outputs.append("sweep_out")
    return d, False


def _run_files(d: Draw, data):
    """A measured run with one spoiled value (run.toml or trace.csv)."""
    toml = {"valve_type": "disc", "measured_valve": "delivery", "speed_rpm": 600.0, "load_pressure_pa": 2.79e6}
    n = 200
    period = 60.0 / 600.0
    rows = [(i * period / n, 1e-3 * max(0.0, math.sin(2 * math.pi * i / n))) for i in range(n)]
    key = data.draw(st.sampled_from(["speed_rpm", "load_pressure_pa", "air_content", "valve_type", "extra_key",
                                     "cell", "duplicate", "start"]))
    header = "time_s,valve_position_m"
    if key in ("speed_rpm", "load_pressure_pa", "air_content"):
        toml[key] = data.draw(st.sampled_from([float("nan"), -1.0, 2.79, 1e9, 0.99, "text"]))
        if key == "speed_rpm" and toml[key] == 2.79:
            toml[key] = 1e9
        if key == "air_content" and toml[key] == 2.79:
            toml[key] = 0.99
    elif key == "valve_type":
        toml[key] = "gate"
    elif key == "extra_key":
        toml["air_contnet"] = 0.01
        key = "air_contnet"
    text_rows = [f"{t:.9g},{x:.9g}" for t, x in rows]
    if key == "cell":
        i = data.draw(st.integers(0, n - 1))
        text_rows[i] = f"{rows[i][0]:.9g},{data.draw(st.sampled_from(['nan', '', 'x', '1e300']))}"
        key = "valve_position_m"
    elif key == "duplicate":
        header += ",valve_position_m"
        text_rows = [f"{r},{r.split(',')[1]}" for r in text_rows]
        key = "valve_position_m"
    elif key == "start":
        text_rows = [f"{t + 5.0:.9g},{x:.9g}" for t, x in rows]
        key = "time_s"
    d.bad.append(key)
    d.files["data/run1/run.toml"] = tomli_w.dumps(toml).encode()
    d.files["data/run1/trace.csv"] = ("\n".join([header, *text_rows]) + "\n").encode()


def draw_discrepancy(data) -> tuple[Draw, bool]:
    d = Draw("discrepancy")
    _run_files(d, data)
    d.argv += ["data", "--no-report"]
    return d, False


def draw_model(data) -> tuple[Draw, bool]:
    d = Draw("model")
    action = data.draw(st.sampled_from(["show", "check"]))
    d.argv.append(action)
    src = data.draw(st.sampled_from(["shipped", "bad_file", "binary", "missing"]))
    if src == "shipped":
        d.argv.append(data.draw(st.sampled_from(["thesis-disc", "thesis-reed"])))
    elif src == "binary":
        d.argv.append(_binary(d, "model.toml"))
    elif src == "missing":
        d.argv.append("no_model.toml")
        d.bad.append("no_model.toml")
    else:
        d.argv.append(_model_file(d, data, True, kinds=("value",)))
    if action == "check":
        d.argv.append("--no-fea")
    return d, True


def draw_expensive(data) -> tuple[Draw, bool]:
    """validate, modes, check, seat, sweep-plot: only their refusals are fuzzed (a run takes minutes)."""
    cmd = data.draw(st.sampled_from(["validate", "modes", "check", "seat", "sweep-plot"]))
    d = Draw(cmd)
    if cmd == "validate":
        if data.draw(st.booleans()):
            d.flag("--jobs", data.draw(_bad_int(1, 256)), True)
        else:
            _path_flag(d, data, "--out", "", True, folder=True)
    elif cmd == "modes":
        d.flag("--modes", data.draw(_bad_int(1, 50)), True)
    elif cmd == "check":
        d.argv.append("uniform")
        if data.draw(st.booleans()):
            d.flag("--tolerance-pct", data.draw(_bad_num(0.0, 100.0, extra=("0", "-3"))), True)
        else:
            d.flag("--mesh-size", data.draw(_bad_num(1e-7, 10.0)), True)
    elif cmd == "seat":
        flag, lo, hi = data.draw(st.sampled_from([("--x-stop-mm", 1e-3, 1e4), ("--reverse-pressure-mpa", 1e-4, 100.0),
                                                  ("--mesh-size", 1e-7, 1.0)]))
        extra = ("1000", "20") if flag == "--x-stop-mm" else ()     # more than 0.3 of the reed's 25 mm
        d.flag(flag, data.draw(_bad_num(lo, hi, extra=extra)), True)
    else:
        d.argv.append("not_a_sweep")
        d.bad.append("not_a_sweep")
    return d, False


CLUSTER_BAD = {"--scheduler": st.sampled_from(["notanaddress", "localhost", "tcp://host:99999", "host:port"]),
               "--workers": st.sampled_from(["0", "-1", "2.5", "nan"]),
               "--batch-size": st.sampled_from(["0", "-5", "1e30"])}


def _good_run(d: Draw):
    """A plausible measured run (600 rpm, 2.79 MPa, 200 samples of a half sine)."""
    n, period = 200, 0.1
    rows = [f"{i * period / n:.9g},{1e-3 * max(0.0, math.sin(2 * math.pi * i / n)):.9g}" for i in range(n)]
    d.files["data/run1/run.toml"] = tomli_w.dumps({"valve_type": "disc", "measured_valve": "delivery",
                                                   "speed_rpm": 600.0, "load_pressure_pa": 2.79e6}).encode()
    d.files["data/run1/trace.csv"] = ("time_s,valve_position_m\n" + "\n".join(rows) + "\n").encode()


def draw_model_with_flags(data) -> tuple[Draw, bool]:
    """A model file, good or spoiled, given to a command with its flags (one value is bad where a run would cost)."""
    cmd = data.draw(st.sampled_from(["pump", "synth", "sweep", "sensitivity", "discrepancy", "model"]))
    d = Draw(cmd)
    model = _model_file(d, data, data.draw(st.booleans()))
    if cmd == "model":
        d.argv += [data.draw(st.sampled_from(["show", "check"])), model]
        if d.argv[1] == "check":
            d.argv.append("--no-fea")
        return d, True
    flags: list[tuple[str, object]] = []       # (flag, strategy of a bad value)
    if cmd == "pump":
        d.argv += ["--model", model]
        for f in data.draw(st.lists(st.sampled_from(sorted(PUMP_NUMBERS)), max_size=2, unique=True)):
            bad = data.draw(st.booleans())
            d.flag(f, data.draw(PUMP_NUMBERS[f][1] if bad else PUMP_NUMBERS[f][0]), bad)
        flags = [("--valve", st.just("reed")), ("--rtol", PUMP_NUMBERS["--rtol"][1]),
                 ("--method", st.just("slow"))]
    elif cmd == "synth":
        d.argv += ["dataset_out", "--model", model]
        d.outputs.append("dataset_out")
        flags = [("--seed", _bad_int(0, 2**32 - 1)), ("--revolutions", _bad_int(1, 1000)),
                 ("--condition", st.sampled_from(["593:2760000", "abc:2"])), ("--valve", st.just("disc"))]
    elif cmd == "sweep":
        where = data.draw(st.sampled_from(["sweep", "fixed"]))
        doc = {"sweep": {"sampler": "grid"}, "factors": {"speed_rpm": {"low": 450.0, "high": 950.0, "levels": 2}},
               "fixed": {"load_pressure": 2.76e6, "revolutions": 2}}
        doc[where]["model"] = model
        d.files["sweep.toml"] = tomli_w.dumps(doc).encode()
        d.argv += ["sweep.toml", "--out", "sweep_out", "--no-progress"]
        d.outputs.append("sweep_out")
        flags = list(CLUSTER_BAD.items())
    elif cmd == "sensitivity":
        d.files["sens.toml"] = (f'model = "{model}"\n[operating]\nspeed_rpm = [593.0]\nload_pressure_mpa = [2.76]\n'
                                '[variables]\n"oil.air_content" = [0.005, 0.02]\n[run]\n'
                                'outputs = ["delivery_cc_per_rev"]\nsamples = 4\n').encode()
        d.argv += ["sens.toml", "--out", "sens_out", "--no-progress"]
        d.outputs.append("sens_out")
        flags = list(CLUSTER_BAD.items())
    else:
        _good_run(d)
        d.argv += ["data", "--no-report", "--model", model]
        flags = [("--workers", _bad_int(1, 256)), ("--max-rounds", _bad_int(0, 20)),
                 ("--min-improvement-pct", _bad_num(0.0, 99.9, extra=("150", "0")))]
    if not d.bad or data.draw(st.booleans()):    # a run would cost seconds: something is bad
        f, strategy = data.draw(st.sampled_from(flags))
        d.flag(f, data.draw(strategy), True)
    return d, False


DRAWS = [draw_reed, draw_reed, draw_lts, draw_table, draw_pump, draw_synth, draw_sweep, draw_discrepancy,
         draw_model, draw_expensive]


def _alarm(signum, frame):
    raise TimeoutError(f"an example ran longer than {EXAMPLE_SECONDS} s (a hang)")


def _tree(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def _run(d: Draw, cheap: bool) -> None:
    """Run one drawn command line in a fresh folder and check the contract (see the module docstring)."""
    d.argv.append("--json")
    event(f"{d.argv[0]}: {'refusal' if d.bad else 'run'}")
    import contextlib
    import io

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, content in d.files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_bytes(content)
        before = _tree(tmp)
        cwd = os.getcwd()
        out, err = io.StringIO(), io.StringIO()
        old = signal.signal(signal.SIGALRM, _alarm)
        signal.alarm(EXAMPLE_SECONDS)
        try:
            os.chdir(tmp)
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    code = main(list(d.argv))
                except SystemExit as exc:
                    code = exc.code
        finally:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, old)
            os.chdir(cwd)
        lines = [ln for ln in err.getvalue().splitlines() if ln.strip() and "it/s]" not in ln]
        new = _tree(tmp) - before
        stray = {p for p in new if not any(p == o or p.startswith(o.rstrip("/") + "/") for o in d.outputs)}
        assert not stray, f"{d.argv}: wrote {sorted(stray)}"
        if d.bad:
            assert code == 2, f"{d.argv}: exit {code} with bad {d.bad}; stderr {err.getvalue()[-400:]!r}"
            assert len(lines) == 1, f"{d.argv}: {lines}"
            assert any(b in lines[0] for b in d.bad), f"{d.argv}: {lines[0]!r} names none of {d.bad}"
        else:
            assert cheap
            assert code == 0, f"{d.argv}: exit {code}; stderr {err.getvalue()[-400:]!r}"
            obj = json.loads(out.getvalue())
            assert isinstance(obj, dict)
            json.dumps(obj, allow_nan=False)
        assert "Traceback" not in err.getvalue()


FUZZ = dict(deadline=None, derandomize=True, database=None,
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@settings(max_examples=400, **FUZZ)
@given(st.data())
def test_every_command_refuses_bad_input_and_runs_good_input(data):
    maker = data.draw(st.sampled_from(DRAWS))
    _run(*maker(data))


@settings(max_examples=250, **FUZZ)
@given(st.data())
def test_model_files_with_the_commands_flags(data):
    _run(*draw_model_with_flags(data))


# --------------------------------------------------------------------------- the Python API
NAN = float("nan")


def _arg(data, bad_names: list, name: str, good, bad, *, force_bad: bool = False, names=()):
    """One argument: a good value or (bad) one of ``bad``, recording the names a refusal may give."""
    if force_bad or data.draw(st.booleans()):
        bad_names += [name, *names]
        return data.draw(st.sampled_from(bad))
    return data.draw(good) if isinstance(good, st.SearchStrategy) else good


SETTINGS_ARGS = {   # field: (good, bad)
    "workers": (st.integers(1, 4), [-1, 0, 2.5, "3", None, True, 10**6, NAN]),
    "max_rounds": (st.integers(0, 5), [-2, "3", 1.5, 100, None]),
    "min_rel_improvement": (st.floats(0.05, 0.9), [NAN, float("inf"), -0.1, 0.0, 1.5, "0.3"]),
    "min_abs_improvement": (st.one_of(st.none(), st.floats(0.5, 5.0)), [0.0, -1.0, NAN, "1"]),
    "holdout": (st.sampled_from([None, ("run01",)]), ["run01", (1,), ("",), 3]),
    "scale_bounds": (st.just((0.9, 1.1)), [(1.1, 0.9), (0.0, 1.0), ("a", "b"), (0.9,), None]),
    "n_grid": (st.integers(2, 10), [1, 0, 2.5, "6"]),
    "nuisance_range": (st.floats(0.05, 0.3), [0.0, 1.5, NAN]),
    "scales": (st.just(None), [None.__class__, "20um", 3]),
}


def _api_call(data, tmp: Path):
    """(entry point name, a call, the names a refusal may give (empty: it must succeed), cheap)."""
    from lumped import load_model, reed_properties, with_values
    from studies.discrepancy import Settings, Workflow, read_dataset, synthesize
    from studies.discrepancy.pump_sim import LIBRARY, simulate
    from studies.discrepancy.synth import Condition, Noise
    from studies.sweeps import load_spec, run_sweep
    from studies.sweeps.design import spec as design_spec
    from studies.sweeps.design.optimize import run_optimize
    from studies.sweeps.design.sensitivity import run_sensitivity

    (tmp / "sweep.toml").write_text(tomli_w.dumps({
        "sweep": {"sampler": "grid"}, "factors": {"speed_rpm": {"low": 450.0, "high": 950.0, "levels": 2}},
        "fixed": {"valve": "disc", "load_pressure": 2.76e6, "revolutions": 2}}))
    sens_text = ('model = "thesis-disc"\n[operating]\nspeed_rpm = [593.0]\nload_pressure_mpa = [2.76]\n[variables]\n'
                 '"oil.air_content" = [0.005, 0.02]\n[run]\noutputs = ["delivery_cc_per_rev"]\n'
                 'objectives = ["max delivery_cc_per_rev"]\nsamples = 4\n')
    (tmp / "sens.toml").write_text(sens_text)
    (tmp / "cycle.toml").write_text('base = "cycle.toml"\n')
    (tmp / "binary.toml").write_bytes(bytes(range(256)) * 8)
    d = Draw("api")
    _good_run(d)
    for name, content in d.files.items():
        (tmp / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp / name).write_bytes(content)
    bad: list = []
    entry = data.draw(st.sampled_from(["Settings", "load_model", "with_values", "reed_properties", "read_dataset",
                                       "sweeps.load_spec", "design.load_spec", "run_sweep", "run_sensitivity",
                                       "run_optimize", "synthesize", "Workflow"]))
    if entry == "Settings":
        kw = {}
        for f in data.draw(st.lists(st.sampled_from(sorted(SETTINGS_ARGS)), min_size=1, max_size=3, unique=True)):
            good, wrong = SETTINGS_ARGS[f]
            v = _arg(data, bad, f, good, wrong)
            if f == "scales" and v is None:
                continue
            kw[f] = v
        return entry, lambda: Settings(**kw), bad, True
    if entry == "load_model":
        spec = _arg(data, bad, "spec", st.sampled_from(["thesis-disc", "thesis-reed", "disc"]),
                    [None, 3, "", ["thesis-disc"], b"thesis-disc", str(tmp / "cycle.toml"), "no_model.toml",
                     str(tmp / "binary.toml")], names=("--model", "base", "no_model", "binary"))
        return entry, lambda: load_model(spec), bad, True
    if entry == "with_values":
        model = _arg(data, bad, "model", st.just(None), [None, "thesis-disc", 3])
        values = _arg(data, bad, "values", st.sampled_from([{"pump.dead_volume": 2.2e-5}, {"oil.air_content": 0.01},
                                                            {"valves.spring.stiffness": 250.0}, {}]),
                      [None, ["pump.dead_volume"], {"pump.dead_volum": 1e-5}, {"pump.dead_volume": -1.0},
                       {"pump.dead_volume": NAN}], names=("pump.dead_volum", "pump.dead_volume"))
        return entry, lambda: with_values(load_model("thesis-disc") if model is None else model, values), bad, True
    if entry == "reed_properties":
        reed = _arg(data, bad, "reed", st.sampled_from(["uniform", "stepped1", "prototype"]),
                    [None, 3, "no_reed.toml", str(tmp / "binary.toml")], names=("no_reed", "binary"))
        fid = _arg(data, bad, "fidelity", st.just("analytic"), ["fancy", None, ["analytic"], 3])
        mesh = _arg(data, bad, "mesh_size", st.just(None), [-1.0, NAN, "1e-3", 0.0])
        return entry, lambda: reed_properties(reed, fid, mesh), bad, True
    if entry == "read_dataset":
        path = _arg(data, bad, "path", st.sampled_from([str(tmp / "data"), tmp / "data", str(tmp / "data/run1")]),
                    [None, 3, str(tmp / "nowhere"), str(tmp / "sweep.toml")], names=("nowhere", "sweep.toml"))
        return entry, lambda: read_dataset(path), bad, True
    if entry == "sweeps.load_spec":
        path = _arg(data, bad, "path", st.just(str(tmp / "sweep.toml")),
                    [None, 3, "missing.toml", str(tmp / "binary.toml")], names=("missing", "binary"))
        return entry, lambda: load_spec(path), bad, True
    if entry == "design.load_spec":
        path = _arg(data, bad, "path", st.just(tmp / "sens.toml"), [None, 3, str(tmp / "binary.toml")],
                    names=("binary",))
        cmd = _arg(data, bad, "command", st.sampled_from(["sensitivity", "optimize"]), ["optimise", None, 3, ""])
        return entry, lambda: design_spec.load_spec(path, cmd), bad, True
    out = tmp / "study_out"
    if entry in ("run_sweep", "run_sensitivity", "run_optimize"):
        if entry == "run_sweep":
            good_spec = load_spec(tmp / "sweep.toml")
            wrong_specs = [None, {"sweep": {}}, str(tmp / "sweep.toml")]
        else:
            cmd = entry.split("_")[1]
            good_spec = design_spec.load_spec(tmp / "sens.toml", cmd)
            other = "optimize" if cmd == "sensitivity" else "sensitivity"
            wrong_specs = [None, design_spec.load_spec(tmp / "sens.toml", other), str(tmp / "sens.toml")]
        args = ["spec", "out", "scheduler", "force", "progress",
                "n_workers" if entry == "run_sweep" else "workers", "batch_size"]
        forced = data.draw(st.sampled_from(args))        # a run would start a cluster: one argument is bad
        wrong = {"spec": wrong_specs, "out": [None, 3, "", b"out"],
                 "scheduler": ["localhost", "notanaddress", "tcp://host:99999", 8786],
                 "force": ["yes", 1, None], "progress": ["no", 0, None],
                 "n_workers": [0, -1, 2.5, "2", 10**6], "workers": [0, -1, 2.5, "2", 10**6],
                 "batch_size": [0, -3, "10", 2.5]}
        good = {"spec": st.just(good_spec), "out": st.just(out), "scheduler": st.just(None),
                "force": st.booleans(), "progress": st.just(False), "n_workers": st.just(None),
                "workers": st.just(None), "batch_size": st.just(None)}
        kw = {a: _arg(data, bad, a, good[a], wrong[a], force_bad=a == forced) for a in args}
        fn = {"run_sweep": run_sweep, "run_sensitivity": run_sensitivity, "run_optimize": run_optimize}[entry]
        return entry, lambda: fn(kw.pop("spec"), kw.pop("out"), **kw), bad, False
    cond = [Condition(593.0, 2.76e6)]
    if entry == "synthesize":
        args = ["simulator", "valve_type", "conditions", "truth", "noise", "seed", "workers"]
        forced = data.draw(st.sampled_from(args))
        wrong = {"simulator": [None, "pump_sim", 3], "valve_type": [None, 3, ""],
                 "conditions": [[], None, [(593.0, 2.76e6)], [Condition(593.0, 2.76)], [Condition(1e6, 2.76e6)],
                                [Condition(593.0, 2.76e6, "gate")]],
                 "truth": [None, ["seat_compliance"]], "noise": [None, Noise(revolutions=0),
                                                                 Noise(sample_rate_hz=NAN),
                                                                 Noise(sample_rate_hz=1e7, revolutions=1000)],
                 "seed": [-1, 2.5, "0", 2**40], "workers": [0, "2", None]}
        good = {"simulator": st.just(simulate), "valve_type": st.just("disc"), "conditions": st.just(cond),
                "truth": st.just(()), "noise": st.just(Noise()), "seed": st.integers(0, 9), "workers": st.just(1)}
        kw = {a: _arg(data, bad, a, good[a], wrong[a], force_bad=a == forced) for a in args}
        return entry, lambda: synthesize(**kw), bad, False
    runs = read_dataset(tmp / "data")
    args = ["runs", "simulator", "library", "settings", "progress"]
    forced = data.draw(st.sampled_from(args))
    wrong = {"runs": [42, None, str(tmp / "nowhere"), [1, 2]], "simulator": [None, 3], "library": [None, "LIBRARY"],
             "settings": [{}, None, "fast"], "progress": ["yes", None]}
    good = {"runs": st.sampled_from([runs, str(tmp / "data")]), "simulator": st.just(simulate),
            "library": st.just(LIBRARY), "settings": st.just(Settings()), "progress": st.just(False)}
    kw = {a: _arg(data, bad, a, good[a], wrong[a], force_bad=a == forced,
                  names=("nowhere",) if a == "runs" else ()) for a in args}
    return entry, lambda: Workflow(**kw), bad, False


@settings(max_examples=250, **FUZZ)
@given(st.data())
def test_python_api_refuses_bad_arguments_before_any_work(data):
    from geometry.errors import InputError

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cwd = os.getcwd()
        old = signal.signal(signal.SIGALRM, _alarm)
        signal.alarm(EXAMPLE_SECONDS)
        try:
            os.chdir(tmp)
            entry, call, bad, cheap = _api_call(data, tmp)
            event(f"{entry}: {'refusal' if bad else 'call'}")
            before = _tree(tmp)
            if bad:
                try:
                    call()
                except InputError as exc:
                    text = f"{exc.field}: {exc.message}"
                    assert any(b in text for b in bad), f"{entry}: {text!r} names none of {bad}"
                else:
                    raise AssertionError(f"{entry}: accepted bad {bad}")
            else:
                assert cheap, entry
                call()
            assert _tree(tmp) == before, f"{entry}: wrote {sorted(_tree(tmp) - before)}"
        finally:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, old)
            os.chdir(cwd)
