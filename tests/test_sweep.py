"""Sweep machinery: spec checks, samplers, a real dask LocalCluster, resume after a kill, main effects.

This module is also the cheap stand-in model the sweeps evaluate (``OUTPUTS``, ``check``,
``evaluate`` below): y = 3 x1 + x2^2 (+ 10 for kind "b"), so every number a test checks
follows from that formula, not from the sweep code.
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
from studies.sweeps import sweep

ROOT = Path(__file__).resolve().parents[1]

# ----------------------------------------------------------------- the stand-in model
OUTPUTS = {"y": "float64", "n_evals": "int64"}
MAIN_RESPONSES = ["y"]
_INPUTS = {"x1", "x2", "kind", "delay", "log", "fail_above"}


def check(name, value):
    if name not in _INPUTS:
        raise InputError(name, f"unknown input; expected one of {sorted(_INPUTS)}")
    if name == "delay" and value < 0:
        raise InputError(name, "must be >= 0")


def evaluate(d: dict) -> dict:
    if d.get("log"):
        with open(d["log"], "a") as fh:  # O_APPEND: one short line per write is atomic
            fh.write(f"{d['x1']!r}\n")
    time.sleep(d.get("delay", 0.0))
    if d["x1"] > d.get("fail_above", math.inf):
        raise RuntimeError(f"x1 = {d['x1']} is beyond the stand-in's range")
    return {"y": 3.0 * d["x1"] + d.get("x2", 0.0) ** 2 + (10.0 if d.get("kind") == "b" else 0.0), "n_evals": 1}


def _truth(df):
    kind = df["kind"] if "kind" in df else "a"
    return 3.0 * df["x1"] + df.get("x2", 0.0) ** 2 + np.where(kind == "b", 10.0, 0.0)


MODEL = __name__  # how workers import this module (the sweep names a model by module)


def spec_of(text: str) -> sweep.SweepSpec:
    import tomllib

    return sweep.parse_spec(tomllib.loads(text), text)


GRID = f"""
[sweep]
model = "{MODEL}"
sampler = "grid"
[factors.x1]
low = 0.0
high = 1.0
levels = 5
[factors.x2]
values = [1.0, 2.0, 3.0]
[factors.kind]
values = ["a", "b"]
"""


# ----------------------------------------------------------------- spec and samplers


@pytest.mark.parametrize(
    "text, field",
    [
        ("[sweep]\nsampler='lhs'\n[factors.x1]\nlow=0\nhigh=1\n", "sweep.samples"),
        ("[sweep]\nsampler='halton'\nsamples=4\n[factors.x1]\nlow=0\nhigh=1\n", "sweep.sampler"),
        ("[sweep]\nsampler='lhs'\nsamples=4\n[factors.x1]\nlow=1\nhigh=1\n", "factors.x1.high"),
        ("[sweep]\nsampler='lhs'\nsamples=4\n[factors.x1]\nlow=0\n", "factors.x1.high"),
        ("[sweep]\nsampler='lhs'\nsamples=4\n[factors.x1]\nlow=0\nhigh=1\nstep=2\n", "factors.x1.step"),
        ("[sweep]\nsampler='grid'\n[factors.x1]\nlow=0\nhigh=1\n", "factors.x1.levels"),
        ("[sweep]\nsampler='lhs'\nsamples=4\n[factors.x1]\nlow=0\nhigh=1\nscale='log'\n", "factors.x1.low"),
        ("[sweep]\nsampler='lhs'\nsamples=4\n[factors.x1]\nvalues=[1, 'a']\n", "factors.x1.values"),
        ("[sweep]\nsampler='lhs'\nsamples=4\n[factors.x1]\nlow=0\nhigh=1\n[fixed]\nx1=2\n", "fixed.x1"),
        ("[sweep]\nsampler='lhs'\nsamples=4\nseeds=1\n[factors.x1]\nlow=0\nhigh=1\n", "sweep.seeds"),
        ("[sweep]\nsampler='lhs'\nsamples=4\n", "factors"),
    ],
)
def test_spec_errors_name_the_field(text, field):
    with pytest.raises(InputError) as exc:
        spec_of(text)
    assert exc.value.field == field


def test_model_vets_input_names_and_values():
    spec = spec_of(f"[sweep]\nmodel='{MODEL}'\nsampler='lhs'\nsamples=4\n[factors.speed]\nlow=0\nhigh=1\n")
    with pytest.raises(InputError) as exc:
        sweep.check_spec(spec, sweep.load_model(MODEL))
    assert exc.value.field == "factors.speed"
    spec = spec_of(f"[sweep]\nmodel='{MODEL}'\nsampler='lhs'\nsamples=4\n[factors.x1]\nlow=0\nhigh=1\n"
                   "[fixed]\ndelay=-1.0\n")
    with pytest.raises(InputError) as exc:
        sweep.check_spec(spec, sweep.load_model(MODEL))
    assert exc.value.field == "fixed.delay"
    with pytest.raises(InputError) as exc:
        sweep.load_model("no_such_module_xyz")
    assert exc.value.field == "sweep.model"


def test_grid_is_the_full_factorial():
    designs = sweep.sample_designs(spec_of(GRID))
    assert len(designs) == 5 * 3 * 2
    assert {d["x1"] for d in designs} == {0.0, 0.25, 0.5, 0.75, 1.0}
    assert len({tuple(d.values()) for d in designs}) == 30


def _lhs_or_sobol(sampler, n, seed=3, extra=""):
    return spec_of(f"[sweep]\nsampler='{sampler}'\nsamples={n}\nseed={seed}\n"
                   "[factors.a]\nlow=2.0\nhigh=6.0\n[factors.b]\nlow=1e-3\nhigh=1e1\nscale='log'\n"
                   "[factors.c]\nvalues=['p','q','r','s']\n" + extra)


@pytest.mark.parametrize("sampler", ["lhs", "sobol"])
def test_space_filling_samples_are_stratified(sampler):
    n = 64
    designs = sweep.sample_designs(_lhs_or_sobol(sampler, n))
    a = np.array([d["a"] for d in designs])
    b = np.array([d["b"] for d in designs])
    # one point in each of the n equal strata of every factor (LHS by construction,
    # a scrambled Sobol net of 2^m points as its (0, m, 1) projections)
    assert sorted(np.floor((a - 2.0) / 4.0 * n).astype(int)) == list(range(n))
    assert sorted(np.floor((np.log10(b) + 3) / 4.0 * n).astype(int)) == list(range(n))
    counts = pd.Series([d["c"] for d in designs]).value_counts()
    assert set(counts) == {n // 4}
    # seeded: reproducible, and a different seed moves the points
    assert sweep.sample_designs(_lhs_or_sobol(sampler, n)) == designs
    assert sweep.sample_designs(_lhs_or_sobol(sampler, n, seed=4)) != designs


def test_integer_factor_and_random_sampler():
    spec = spec_of("[sweep]\nsampler='random'\nsamples=50\n[factors.k]\nlow=1\nhigh=9\ninteger=true\n")
    ks = [d["k"] for d in sweep.sample_designs(spec)]
    assert all(isinstance(k, int) and 1 <= k <= 9 for k in ks) and len(set(ks)) > 3


# ----------------------------------------------------------------- running on dask




def test_grid_sweep_on_local_cluster_matches_the_formula(client, tmp_path):
    spec = spec_of(GRID)
    s = sweep.run_sweep(spec, tmp_path / "run", client=client, batch_size=4, progress=False)
    assert s["complete"] and s["computed"] == 30 and s["failed"] == 0 and s["workers"] == 2
    df = pd.read_parquet(s["results"])
    assert list(df["design_id"]) == list(range(30))
    assert np.allclose(df["y"], _truth(df), rtol=0, atol=1e-12)
    # both worker processes did work: the sweep really ran on the cluster
    assert df["status"].eq("ok").all()
    # rerun: everything is already there, nothing is recomputed
    again = sweep.run_sweep(spec, tmp_path / "run", client=client, progress=False)
    assert again["computed"] == 0 and again["skipped"] == 30 and again["complete"]
    # the same keys as a run that computed (CONTRACT.md's list); no worker used and no rate to report
    assert set(again) == set(s)
    assert again["workers"] == 0 and again["designs_per_hour"] is None

    # main effects: x1's effect is 3 x1 (slope 3 over [0, 1]), x2's is x2^2, kind's is 10
    eff = sweep.main_effects(df, spec, ["y"])["y"]
    assert np.allclose(np.diff(eff["x1"]["mean"]) / np.diff(eff["x1"]["x"]), 3.0)
    assert eff["x2"]["span"] == pytest.approx(9.0 - 1.0)
    assert eff["kind"]["span"] == pytest.approx(10.0) and eff["kind"]["x"] == ["a", "b"]
    png = sweep.plot_main_effects(sweep.main_effects(df, spec, ["y", "n_evals"]), tmp_path / "me.png")
    assert png.stat().st_size > 5000


def test_failed_design_is_recorded_not_fatal_csv_resume(client, tmp_path):
    text = (f"[sweep]\nmodel='{MODEL}'\nsampler='lhs'\nsamples=40\nseed=7\n"
            "[factors.x1]\nlow=0.0\nhigh=1.0\n[fixed]\nfail_above=0.75\n")
    spec = spec_of(text)
    out = tmp_path / "csv"
    s = sweep.run_sweep(spec, out, fmt="csv", client=client, batch_size=3, progress=False)
    df = pd.read_csv(s["results"])
    bad = df["x1"] > 0.75
    assert s["complete"] and s["failed"] == bad.sum() == 10  # LHS: exactly 10 of 40 strata above 0.75
    assert (df.loc[bad, "status"] == "error").all() and df.loc[bad, "y"].isna().all()
    assert df.loc[bad, "error"].str.contains("RuntimeError: x1 = ").all()
    assert np.allclose(df.loc[~bad, "y"], 3 * df.loc[~bad, "x1"])

    # simulate a kill: drop the last 15 rows and leave half a line behind
    lines = (out / "results.csv").read_text().splitlines(keepends=True)
    kept = lines[:-15]
    (out / "results.csv").write_text("".join(kept) + lines[-15][:7])
    kept_ids = {int(line.split(",")[0]) for line in kept[1:]}
    log = tmp_path / "evals.log"
    spec2 = sweep.SweepSpec(**{**spec.__dict__, "fixed": spec.fixed + (("log", str(log)),)})
    # a different spec (log added) is refused in the same folder ...
    with pytest.raises(InputError) as exc:
        sweep.run_sweep(spec2, out, fmt="csv", client=client, progress=False)
    assert exc.value.field == "--out"
    # ... and the same spec resumes, recomputing only the lost rows
    again = sweep.run_sweep(spec, out, fmt="csv", client=client, batch_size=3, progress=False)
    assert again["computed"] == 15 and again["skipped"] == 25
    df2 = pd.read_csv(again["results"]).sort_values("design_id")
    assert list(df2["design_id"]) == list(range(40)) and kept_ids <= set(df2["design_id"])
    assert np.allclose(df2["x1"], df.sort_values("design_id")["x1"])
    # the failed ones are retried only on request
    retry = sweep.run_sweep(spec, out, fmt="csv", client=client, retry_failed=True, progress=False)
    assert retry["computed"] == 10


def test_a_part_cut_off_mid_write_is_invisible(tmp_path, monkeypatch):
    """A kill while a part is written leaves no file the store or pandas would read as a part."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = pa.schema([("design_id", pa.int64()), ("y", pa.float64())])
    store = sweep.ParquetStore(tmp_path, schema)
    store.append([{"design_id": 0, "y": 1.5}])

    def cut_off(table, where, **kw):  # what SIGKILL half way through pq.write_table leaves
        Path(where).write_bytes(b"PAR1")
        raise KeyboardInterrupt

    monkeypatch.setattr(pq, "write_table", cut_off)
    with pytest.raises(KeyboardInterrupt):
        store.append([{"design_id": 1, "y": 2.5}])
    monkeypatch.undo()
    assert len(list((tmp_path / "parts").iterdir())) == 2  # the stub is there ...
    assert list(pd.read_parquet(tmp_path / "parts")["design_id"]) == [0]  # ... and skipped
    assert list(store.read()["design_id"]) == [0]


# ----------------------------------------------------------------- the command line, killed and resumed


def _cli_env():
    return {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _rows(out: Path) -> int:
    import pyarrow.parquet as pq

    parts = list((out / "parts").glob("*.parquet")) if (out / "parts").is_dir() else []
    return sum(pq.read_metadata(p).num_rows for p in parts)


def test_thousand_design_sweep_killed_half_way_resumes(tmp_path):
    """A 1000-design CLI sweep on a LocalCluster, SIGKILLed half way, then resumed to completion."""
    log = tmp_path / "evals.log"
    spec = tmp_path / "spec.toml"
    spec.write_text(
        f"[sweep]\nmodel = 'tests.test_sweep'\nsampler = 'sobol'\nsamples = 1000\nseed = 11\n"
        "[factors.x1]\nlow = 0.0\nhigh = 1.0\n[factors.x2]\nlow = -1.0\nhigh = 1.0\n"
        f"[fixed]\ndelay = 0.004\nlog = '{log}'\n"
    )
    out = tmp_path / "sweep"
    args = [sys.executable, "-m", "studies", "sweep", str(spec), "--out", str(out), "--workers", "2",
            "--batch-size", "10", "--json"]
    p = subprocess.Popen(args, cwd=tmp_path, env=_cli_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         start_new_session=True)
    deadline = time.time() + 120
    while _rows(out) < 400 and time.time() < deadline and p.poll() is None:
        time.sleep(0.05)
    assert p.poll() is None, "the sweep finished before it could be killed: " + p.stderr.read().decode()[-500:]
    os.killpg(p.pid, signal.SIGKILL)  # the process group: the CLI and its worker processes
    p.wait()
    recorded = _rows(out)
    assert 400 <= recorded < 1000
    first_ids = set(pd.read_parquet(out / "parts")["design_id"])
    first_evals = log.read_text().splitlines()

    rc = subprocess.run(args, cwd=tmp_path, env=_cli_env(), capture_output=True, text=True, timeout=300)
    assert rc.returncode == 0, rc.stderr[-1000:]
    res = json.loads(rc.stdout)
    assert res["complete"] and res["skipped"] == recorded and res["computed"] == 1000 - recorded
    assert "design" in rc.stderr  # the tqdm progress bar went to stderr
    df = pd.read_parquet(res["results"])
    assert len(df) == 1000 and list(df["design_id"]) == list(range(1000))
    assert np.allclose(df["y"], _truth(df)) and df["status"].eq("ok").all()
    # no finished design was evaluated again: the second run's evaluations are all new
    second_evals = log.read_text().splitlines()[len(first_evals):]
    x_first = set(df.loc[df["design_id"].isin(first_ids), "x1"].map(repr))
    assert len(second_evals) == 1000 - recorded and not x_first & set(second_evals)


def test_cli_errors_and_plot(cli, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[sweep]\nsampler = 'lhs'\nsamples = -3\n[factors.x1]\nlow=0\nhigh=1\n")
    rc, out, err, obj = cli("sweep", bad, "--json")
    assert rc == 2 and obj is None and "sweep.samples" in err and len(err.strip().splitlines()) == 1
    rc, out, err = cli("sweep", tmp_path / "missing.toml")
    assert rc == 2 and "missing.toml" in err and "Traceback" not in err
    rc, out, err = cli("sweep-plot", tmp_path)
    assert rc == 2 and "not a sweep folder" in err

    good = tmp_path / "g.toml"
    good.write_text(GRID.replace(MODEL, "tests.test_sweep"))
    rc, out, err, obj = cli("sweep", good, "--out", tmp_path / "g", "--workers", "1", "--plot", "--json")
    assert rc == 0, err
    assert obj["complete"] and obj["designs"] == 30
    assert Path(obj["main_effects"]["plot"]).is_file()
    rc, out, err, obj = cli("sweep-plot", tmp_path / "g", "--response", "y", "--json")
    assert rc == 0 and obj["effects"]["y"]["kind"]["span"] == pytest.approx(10.0)
    rc, out, err = cli("sweep-plot", tmp_path / "g", "--response", "nope")
    assert rc == 2 and "--response" in err
    # a user's folder is not taken over
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    rc, out, err = cli("sweep", good, "--out", mine)
    assert rc == 2 and "--out" in err and (mine / "notes.txt").read_text() == "mine"


# ----------------------------------------------------------------- the pump as the swept model


def test_pump_model_vets_names_and_values():
    from studies.sweeps import pump as sweep_pump

    base = "[sweep]\nsampler='lhs'\nsamples=4\n[factors.speed_rpm]\nlow=500\nhigh=900\n"
    cases = [
        ("[fixed]\nvalve='disc'\nload_pressure=2.8e6\ninlet.nonsense=1.0\n", "fixed.inlet.nonsense"),
        ("[fixed]\nvalve='disc'\nload_pressure=2.8e6\npump.dead_volume=-1e-6\n", "fixed.pump.dead_volume"),
        ("[fixed]\nvalve='gate'\nload_pressure=2.8e6\n", "fixed.valve"),
        ("[fixed]\nload_pressure=2.8e6\n", "fixed.model"),  # no pump model
        ("[fixed]\nvalve='disc'\nload_pressure=2.8e6\neffect.magic=true\n", "fixed.effect.magic"),
        ("[fixed]\nvalve='disc'\nload_pressure=2.8e6\nvalves.f1=1.5\n", "fixed.valves.f1"),
    ]
    model = sweep.load_model("pump")
    for extra, field in cases:
        with pytest.raises(InputError) as exc:
            sweep.check_spec(spec_of(base + extra), model)
        assert exc.value.field == field, (extra, exc.value)
    sweep.check_spec(spec_of(base + "[fixed]\nvalve='reed'\nload_pressure=2.8e6\nvalves.stiffness=8e6\n"), model)
    assert set(sweep_pump.MAIN_RESPONSES) <= set(sweep_pump.OUTPUTS)


def test_pump_sweep_on_local_cluster(client, tmp_path):
    """A small pump sweep on the cluster: both valve types, a model parameter, a failing design."""
    spec = spec_of(
        "[sweep]\nmodel='pump'\nsampler='grid'\n"
        "[factors.valve]\nvalues=['disc', 'reed']\n"
        "[factors.speed_rpm]\nvalues=[600.0, 800.0]\n"
        "[factors.valves.stiffness]\nvalues=[7.7e6]\n"   # a reed parameter: disc designs fail
        "[fixed]\nload_pressure=2.8e6\nrevolutions=2\n"
    )
    s = sweep.run_sweep(spec, tmp_path / "pump", client=client, progress=False)
    df = pd.read_parquet(s["results"]).set_index(["valve", "speed_rpm"])
    disc, reed = df.loc["disc"], df.loc["reed"]
    assert (disc["status"] == "error").all() and disc["error"].str.contains("structure").all()
    assert reed["status"].isin(["ok", "not_cyclic"]).all() and s["failed"] == 2
    # volumetric efficiency is delivery over the swept volume 2 A_p r (Table 5.1: d = 15.88 mm, r = 5.6 mm)
    swept = 2 * math.pi * 15.88e-3**2 / 4 * 5.6e-3
    assert np.allclose(reed["volumetric_efficiency"], reed["delivery_m3_per_rev"] / swept, rtol=1e-12)
    assert ((reed["volumetric_efficiency"] > 0.6) & (reed["volumetric_efficiency"] < 1.0)).all()
    assert (reed["delivery_peak_opening_m"] > 0).all() and (reed["revolutions_run"] == 2).all()


def test_contract_example_sweep_file_is_valid():
    """The sweep file shown in CONTRACT.md parses and passes the pump model's checks."""
    text = (ROOT / "CONTRACT.md").read_text()
    section = text[text.index("## Sweeps"):]
    block = section[section.index("```toml") + 7: section.index("```", section.index("```toml") + 7)]
    spec = spec_of(block)
    sweep.check_spec(spec, sweep.load_model("pump"))
    assert {f.name for f in spec.factors} == {"speed_rpm", "valve", "delivery.compliant_seat_stiffness"}
    assert spec.fixed_dict["effect.piston_leakage"] is True and len(sweep.sample_designs(spec)) == 1024


@pytest.mark.slow  # the address path is also run by test_sensitivity.py::test_cli_on_an_existing_scheduler
def test_cli_sweep_on_an_existing_scheduler(client, tmp_path):
    """--scheduler ADDRESS: the CLI submits to a running cluster instead of starting one."""
    spec = tmp_path / "s.toml"
    spec.write_text(GRID.replace(MODEL, "test_sweep"))  # importable by the CLI and the workers
    env = {**_cli_env(), "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "tests"), os.environ.get("PYTHONPATH", "")])}
    args = [sys.executable, "-m", "studies", "sweep", str(spec), "--out", str(tmp_path / "o"), "--scheduler",
            client.scheduler.address, "--json"]
    p = subprocess.run(args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-800:]
    res = json.loads(p.stdout)
    assert res["complete"] and res["computed"] == 30 and res["workers"] == 2
    # the tasks ran on the cluster's workers: the scheduler saw them
    assert any("evaluate_batch" in k for k in client.run_on_scheduler(
        lambda dask_scheduler: [str(t) for t in dask_scheduler.task_prefixes]))
    bad = subprocess.run([*args[:6], str(tmp_path / "o2"), "--scheduler", "tcp://127.0.0.1:9", "--json"],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "--scheduler" in bad.stderr


def test_own_cluster_is_quiet_when_another_holds_the_dashboard_port(recwarn):
    """A second valvelab cluster on the machine (another sweep, another user) must not print distributed's
    "Port 8787 is already in use" warning on the user's terminal: the scheduler's HTTP server takes a free port."""
    import socket

    from studies.sweeps.cluster import Cluster

    held = socket.socket()
    try:
        held.bind(("127.0.0.1", 8787))
        held.listen()
    except OSError:
        pass                     # someone else holds it already: the situation under test
    c = Cluster(workers=1)
    try:
        c.get()
        assert c.workers == 1
    finally:
        c.close()
        held.close()
    assert not [w for w in recwarn if "already in use" in str(w.message)]
