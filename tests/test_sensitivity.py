"""valvelab sensitivity: Sobol indices against the Ishigami function's analytic values, Morris against a linear
function, failures handled in the estimators, the thesis disc pump's ranking against one-at-a-time differences,
input errors, an existing scheduler, resume after a kill.

This module is also the stand-in model the studies evaluate on dask (``OUTPUTS``, ``check``, ``evaluate``):
the Ishigami function y = sin x1 + a sin^2 x2 + b x3^4 sin x1 (a = 7, b = 0.1) and a linear function, so every
index a test checks follows from those formulas, not from the sensitivity code.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from geometry.errors import InputError
from studies.sweeps.design import spec as dspec
from studies.sweeps.design.sensitivity import run_sensitivity

ROOT = Path(__file__).resolve().parents[1]

# ----------------------------------------------------------------- the stand-in model
OUTPUTS = {"y": "float64", "lin": "float64"}
UNITS = {"y": "-", "lin": "m", "x1": "rad", "x2": "rad", "x3": "rad"}
A, B = 7.0, 0.1
LIN = (1.0, 3.0, -0.5)
_INPUTS = {"x1", "x2", "x3", "fail_above", "delay", "log"}


def check(name, value):
    if name not in _INPUTS:
        raise InputError(name, f"unknown input; expected one of {sorted(_INPUTS)}")


def evaluate(d: dict) -> dict:
    if d.get("log"):
        with open(d["log"], "a") as fh:
            fh.write(f"{d['x1']!r} {d['x2']!r} {d['x3']!r}\n")
    time.sleep(d.get("delay", 0.0))
    if d["x3"] > d.get("fail_above", math.inf):
        raise RuntimeError(f"x3 = {d['x3']} is beyond the stand-in's range")
    x1, x2, x3 = d["x1"], d["x2"], d["x3"]
    return {"y": math.sin(x1) + A * math.sin(x2) ** 2 + B * x3 ** 4 * math.sin(x1),
            "lin": LIN[0] * x1 + LIN[1] * x2 + LIN[2] * x3}


def _ishigami_indices():
    """Analytic S1 and ST of the Ishigami function (uniform inputs on [-pi, pi])."""
    pi = math.pi
    v1 = 0.5 * (1 + B * pi ** 4 / 5) ** 2
    v2 = A ** 2 / 8
    v13 = B ** 2 * pi ** 8 * (1 / 18 - 1 / 50)
    v = v1 + v2 + v13
    return np.array([v1, v2, 0.0]) / v, np.array([v1 + v13, v2, v13]) / v


MODEL = __name__
PI = math.pi
SPEC = f"""
model = "{MODEL}"
[variables]
x1 = [{-PI!r}, {PI!r}]
x2 = [{-PI!r}, {PI!r}]
x3 = [{-PI!r}, {PI!r}]
[run]
outputs = ["y"]
samples = 2048
seed = 4
"""


def _spec(text: str, command: str = "sensitivity", tmp_path: Path | None = None):
    import tomllib

    return dspec.parse_spec(tomllib.loads(text), command, text, base_dir=tmp_path)




def _by_variable(res, output="y", point=None):
    rows = [r for r in res["indices"] if r["output"] == output and (point is None or r["operating_point"] == point)]
    return {r["variable"]: r for r in rows}


# ----------------------------------------------------------------- estimators against analytic values
def test_sobol_indices_of_ishigami_within_bootstrap_intervals(client, tmp_path):
    s1, st = _ishigami_indices()
    assert np.allclose(s1, [0.3139, 0.4424, 0.0], atol=5e-5) and np.allclose(st, [0.5576, 0.4424, 0.2437], atol=5e-5)
    res = run_sensitivity(_spec(SPEC), tmp_path / "ishigami", client=client, progress=False)
    assert res["computed"] == 2048 * 5 and res["failed"] == 0 and res["workers"] == 2
    got = _by_variable(res)
    for i, name in enumerate(("x1", "x2", "x3")):
        r = got[name]
        # the analytic value lies inside the 95 % bootstrap interval, and the interval is informative
        assert abs(r["S1"] - s1[i]) <= r["S1_conf"], (name, r)
        assert abs(r["ST"] - st[i]) <= r["ST_conf"], (name, r)
        assert r["S1_conf"] < 0.06 and r["ST_conf"] < 0.08
    # the files: table and bar plot with intervals
    md = (tmp_path / "ishigami" / "indices.md").read_text()
    assert "| x1 [rad] |" in md and "95 % bootstrap" in md
    csv = pd.read_csv(tmp_path / "ishigami" / "indices.csv")
    assert list(csv["variable"]) == ["x1", "x2", "x3"] and np.allclose(csv["ST"], [got[v]["ST"] for v in ("x1", "x2", "x3")])
    assert (tmp_path / "ishigami" / "sensitivity_y.png").stat().st_size > 10_000
    # rerun: nothing recomputed, same indices
    again = run_sensitivity(_spec(SPEC), tmp_path / "ishigami", client=client, progress=False)
    assert again["computed"] == 0 and again["skipped"] == 2048 * 5
    assert [r["ST"] for r in again["indices"]] == [r["ST"] for r in res["indices"]]


def test_failed_evaluations_drop_their_saltelli_blocks(client, tmp_path):
    """Evaluations that raise are recorded and their whole blocks left out; the indices stay right."""
    text = SPEC.replace("samples = 2048", "samples = 1024") + "\n[fixed]\nfail_above = 2.9\n"
    res = run_sensitivity(_spec(text), tmp_path / "fail", client=client, progress=False)
    runs = pd.read_parquet(tmp_path / "fail" / "runs" / "results.parquet").sort_values("design_id")
    bad = runs["x3"] > 2.9
    assert bad.any() and (runs.loc[bad, "status"] == "error").all() and res["failed"] == int(bad.sum())
    blocks_with_failure = int(bad.to_numpy().reshape(-1, 5).any(axis=1).sum())   # D + 2 = 5 rows per block
    s1, st = _ishigami_indices()
    for i, name in enumerate(("x1", "x2", "x3")):
        r = _by_variable(res)[name]
        assert r["samples_dropped"] == blocks_with_failure and r["samples_used"] == 1024 - blocks_with_failure
        # a truncated domain changes the indices a little: still within twice the interval
        assert abs(r["ST"] - st[i]) <= 2 * r["ST_conf"] + 0.02


def test_morris_of_a_linear_function_is_exact(client, tmp_path):
    """mu* of y = sum a_i x_i over ranges of width 2 pi is |a_i| 2 pi exactly, sigma 0."""
    text = SPEC.replace('outputs = ["y"]', 'outputs = ["lin"]\nmethod = "morris"').replace("samples = 2048",
                                                                                         "samples = 12")
    res = run_sensitivity(_spec(text), tmp_path / "morris", client=client, progress=False)
    assert res["evaluations"] == 12 * 4
    got = _by_variable(res, "lin")
    for a, name in zip(LIN, ("x1", "x2", "x3")):
        assert got[name]["mu_star"] == pytest.approx(abs(a) * 2 * PI, rel=1e-9)
        assert got[name]["mu"] == pytest.approx(a * 2 * PI, rel=1e-9)
        assert got[name]["sigma"] == pytest.approx(0.0, abs=1e-9)


# ----------------------------------------------------------------- the thesis disc pump
DISC = """
model = "thesis-disc"
[operating]
speed_rpm = [593.0]
[variables]
"oil.air_content" = [0.005, 0.02]
load_pressure_mpa = [2.0, 3.5]
"valves.drag.viscous_coefficient" = [5.0, 20.0]
"pump.dead_volume" = [2.0e-5, 2.4e-5]
"valves.spring.stiffness" = [170.0, 260.0]
[run]
outputs = ["delivery_cc_per_rev"]
samples = 128
"""


def _oat(spec):
    """One-at-a-time differences of delivery [cc/rev] over each variable's full range (others at the centre),
    computed with the model API directly, not through the sensitivity code."""
    from lumped.run.simulate import simulate
    from lumped.model.model_file import load_model, with_values

    model = load_model("thesis-disc")
    centre = {v.name: 0.5 * (v.low + v.high) for v in spec.variables}

    def delivery(values):
        keys = {k: x for k, x in values.items() if "." in k}
        r = simulate(with_values(model, keys), 593.0, values["load_pressure_mpa"] * 1e6, rtol=1e-4, atol=1e-6)
        return r.delivery_per_rev * 1e6

    return {v.name: abs(delivery(dict(centre, **{v.name: v.high})) - delivery(dict(centre, **{v.name: v.low})))
            for v in spec.variables}


def test_disc_pump_total_indices_rank_like_one_at_a_time_differences(client, tmp_path):
    spec = _spec(DISC)
    res = run_sensitivity(spec, tmp_path / "disc", client=client, progress=False)
    assert res["failed"] == 0
    st = {k: (r["ST"], r["ST_conf"]) for k, r in _by_variable(res, "delivery_cc_per_rev").items()}
    oat = _oat(spec)
    # air content dominates both measures; drag is negligible in both
    assert max(st, key=lambda k: st[k][0]) == max(oat, key=oat.get) == "oil.air_content"
    assert st["oil.air_content"][0] > 0.8
    drag = "valves.drag.viscous_coefficient"
    assert st[drag][0] < 0.005 and oat[drag] < 1e-3 * oat["oil.air_content"]
    # every pair the Sobol indices separate (beyond both intervals) is ordered the same way by OAT
    names = list(st)
    separated = 0
    for a in names:
        for b in names:
            if st[a][0] - st[b][0] > st[a][1] + st[b][1]:
                separated += 1
                assert oat[a] > oat[b], (a, b, st, oat)
    assert separated >= 6
    # first-order ~ total: delivery is nearly additive in these inputs
    for r in _by_variable(res, "delivery_cc_per_rev").values():
        assert abs(r["ST"] - r["S1"]) < 0.05


# ----------------------------------------------------------------- input errors
@pytest.mark.parametrize("edit, field", [
    (('"oil.air_content" = [0.005, 0.02]', '"oil.air_contnt" = [0.005, 0.02]'), 'variables."oil.air_contnt"'),
    (('"oil.air_content" = [0.005, 0.02]', '"oil.air_content" = [0.02, 0.005]'), 'variables."oil.air_content".high'),
    (('"oil.air_content" = [0.005, 0.02]', '"oil.air_content" = [0.005, 0.9]'), 'variables."oil.air_content".high'),
    (('outputs = ["delivery_cc_per_rev"]', 'outputs = ["delivery_cc"]'), "run.outputs[0]"),
    (("samples = 128", "samples = 100"), "run.samples"),
    (("samples = 128", "samples = 16777216"), "run.samples"),
    (("speed_rpm = [593.0]", "speed_rpm = [593.0]\nload_pressure_mpa = [2.76]"), "operating.load_pressure_mpa"),
    (("speed_rpm = [593.0]", "speed_rpm = [5.0]"), "operating.speed_rpm[0]"),
    (('model = "thesis-disc"', 'model = "no-such-pump.toml"'), "model"),
    (("[run]", "[run]\npopulation = 10"), "run.population"),   # an optimize key (objectives alone is shared)
    (('"valves.spring.stiffness" = [170.0, 260.0]', '"valves.spring.stiffness" = {low = 1.0, high = 2.0, '
                                                   'distribution = "normal"}'), 'variables."valves.spring.stiffness".mean'),
])
def test_bad_specs_name_the_field_before_any_computation(tmp_path, edit, field):
    text = DISC.replace(*edit)
    assert text != DISC
    with pytest.raises(InputError) as exc:
        spec = _spec(text, tmp_path=tmp_path)
        run_sensitivity(spec, tmp_path / "o", progress=False)
    assert exc.value.field == field or exc.value.field.startswith(field), (exc.value.field, str(exc.value))
    assert not (tmp_path / "o").exists()   # nothing was created


def test_cli_errors_exit_2_with_one_line(cli, tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text(DISC)
    ro = tmp_path / "ro"
    ro.mkdir()
    (ro / "mine.txt").write_text("a user's file")
    rc, out, err, _ = cli("sensitivity", spec, "--out", ro, "--json")
    assert rc == 2 and "--out" in err and len(err.strip().splitlines()) == 1
    assert (ro / "mine.txt").read_text() == "a user's file"
    afile = tmp_path / "afile"
    afile.write_text("x")
    rc, out, err, _ = cli("sensitivity", spec, "--out", afile / "sub", "--json")   # cannot be created
    assert rc == 2 and "--out" in err and "Traceback" not in err
    spec.write_text(DISC.replace('"pump.dead_volume"', '"pump.dead_volumes"'))
    rc, out, err, _ = cli("sensitivity", spec, "--out", tmp_path / "o2", "--json")
    assert rc == 2 and 'variables' in err and "dead_volumes" in err and "Traceback" not in err


# ----------------------------------------------------------------- an existing scheduler; kill and resume
def _env():
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "tests"),
                                                         os.environ.get("PYTHONPATH", "")])}


def test_cli_on_an_existing_scheduler(client, tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC.replace(f'model = "{MODEL}"', 'model = "test_sensitivity"').replace("2048", "16"))
    args = [sys.executable, "-m", "studies", "sensitivity", str(spec), "--out", str(tmp_path / "o"), "--scheduler",
            client.scheduler.address, "--json", "--no-progress"]
    p = subprocess.run(args, cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=180)
    assert p.returncode == 0, p.stderr[-800:]
    res = json.loads(p.stdout)
    assert res["computed"] == 16 * 5 and res["workers"] == 2
    assert any("evaluate_batch" in k for k in client.run_on_scheduler(
        lambda dask_scheduler: [str(t) for t in dask_scheduler.task_prefixes]))


@pytest.mark.slow
def test_cli_refuses_an_unreachable_scheduler(tmp_path):
    """(slow: dask retries for the 10 s connect timeout; the sweep's test covers the same path)"""
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC.replace(f'model = "{MODEL}"', 'model = "test_sensitivity"').replace("2048", "16"))
    bad = subprocess.run([sys.executable, "-m", "studies", "sensitivity", str(spec), "--out", str(tmp_path / "o2"),
                          "--scheduler", "tcp://127.0.0.1:9", "--json"],
                         cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "--scheduler" in bad.stderr and not (tmp_path / "o2").exists()


def _parts_rows(folder: Path) -> int:
    import pyarrow.parquet as pq

    parts = list((folder / "parts").glob("*.parquet")) if (folder / "parts").is_dir() else []
    return sum(pq.read_metadata(p).num_rows for p in parts)


@pytest.mark.slow
def test_killed_study_resumes_without_recomputing(tmp_path):
    """(slow: the sweep store it resumes is kill-tested in test_sweep.py; this is the sensitivity command end to end)"""
    log = tmp_path / "evals.log"
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC.replace(f'model = "{MODEL}"', 'model = "test_sensitivity"').replace("2048", "128")
                    + f"\n[fixed]\ndelay = 0.01\nlog = '{log}'\n")
    out = tmp_path / "o"
    args = [sys.executable, "-m", "studies", "sensitivity", str(spec), "--out", str(out), "--workers", "2",
            "--batch-size", "10", "--json"]
    p = subprocess.Popen(args, cwd=tmp_path, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         start_new_session=True)
    deadline = time.time() + 120
    while _parts_rows(out / "runs") < 150 and time.time() < deadline and p.poll() is None:
        time.sleep(0.05)
    assert p.poll() is None, "finished before it could be killed: " + p.stderr.read().decode()[-500:]
    os.killpg(p.pid, signal.SIGKILL)
    p.wait()
    recorded = _parts_rows(out / "runs")
    assert 150 <= recorded < 640
    first = log.read_text().splitlines()
    rc = subprocess.run(args, cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=300)
    assert rc.returncode == 0, rc.stderr[-1000:]
    res = json.loads(rc.stdout)
    assert res["skipped"] == recorded and res["computed"] == 640 - recorded
    assert "sensitivity" in rc.stderr   # progress bar on stderr
    second = log.read_text().splitlines()[len(first):]
    assert len(second) == 640 - recorded
    done = pd.read_parquet(out / "runs" / "results.parquet")
    assert len(done) == 640 and done["status"].eq("ok").all()


def test_a_valve_that_never_reseats_has_no_timing():
    """With the squeeze film the disc is held off its seat all revolution (the raw simulation's open interval is
    the whole revolution and it never lands on the seat): its opening and closing angles are missing, not 0 deg."""
    from lumped.run.simulate import simulate
    from lumped.model.model_file import load_model, with_values
    from studies.sweeps.design.evaluate import evaluate

    model = with_values(load_model("thesis-disc"), {"effects.squeeze_film": True})
    raw = simulate(model, 593.0, 2.76e6, rtol=1e-4, atol=1e-6)
    for v in (raw.inlet, raw.delivery):
        assert v.seat_impact_velocity == 0.0                      # never lands on its seat...
        assert v.opening_angle is None and v.closing_angle is None    # ...so no timing (not 0 deg)
    point = {"model": "thesis-disc", "speed_rpm": 593.0, "load_pressure": 2.76e6, "rtol": 1e-4, "atol": 1e-6}
    on = evaluate(dict(point, **{"effects.squeeze_film": True}))
    off = evaluate(dict(point, **{"effects.squeeze_film": False}))
    for pos in ("inlet", "delivery"):
        assert on[f"{pos}_opening_angle_rad"] is None and on[f"{pos}_closing_angle_rad"] is None
        assert 0.0 < off[f"{pos}_opening_angle_rad"] < 2 * math.pi and off[f"{pos}_closing_angle_rad"] > 0.0
