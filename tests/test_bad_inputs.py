"""The 41 bad inputs of issue 14, each refused with exit 2 and one line naming the field.

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
