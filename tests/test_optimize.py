"""valvelab optimize: NSGA-II against the analytic ZDT1 front, differential evolution against a constrained
optimum, replay-resume after a kill, an existing scheduler, input errors, and (slow) the thesis reed pump: a
design file re-run by ``valvelab pump --method reference`` reproduces its objectives.

This module is also the stand-in model the optimiser evaluates on dask: ZDT1 with five variables
(f1 = x1, g = 1 + 9 mean(x2..x5), f2 = g (1 - sqrt(f1 / g)); Pareto front f2 = 1 - sqrt(f1), f1 in [0, 1]) and a
quadratic q = (x1 - 0.3)^2 + (x2 + 0.2)^2 with s = x1 + x2 (min q subject to s >= 0.5: x = (0.5, 0), q = 0.08).
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
import pytest

from geometry.errors import InputError
from studies.sweeps.design import spec as dspec
from studies.sweeps.design.optimize import run_optimize

ROOT = Path(__file__).resolve().parents[1]

# ----------------------------------------------------------------- the stand-in model
OUTPUTS = {"f1": "float64", "f2": "float64", "q": "float64", "s": "float64"}
N_ZDT = 5


def evaluate(d: dict) -> dict:
    if d.get("log"):
        with open(d["log"], "a") as fh:
            fh.write(repr(tuple(d.get(f"x{i}") for i in range(1, N_ZDT + 1))) + "\n")
    time.sleep(d.get("delay", 0.0))
    xs = [d.get(f"x{i}", 0.0) for i in range(1, N_ZDT + 1)]
    g = 1 + 9 * sum(xs[1:]) / (N_ZDT - 1)
    return {"f1": xs[0], "f2": g * (1 - math.sqrt(xs[0] / g)), "q": (xs[0] - 0.3) ** 2 + (xs[1] + 0.2) ** 2,
            "s": xs[0] + xs[1]}


MODEL = __name__
ZDT = f"""
model = "{MODEL}"
[variables]
""" + "".join(f"x{i} = [0.0, 1.0]\n" for i in range(1, N_ZDT + 1)) + """
[run]
objectives = ["min f1", "min f2"]
population = 40
generations = 80
seed = 3
"""
DE = f"""
model = "{MODEL}"
[variables]
x1 = [-1.0, 1.0]
x2 = [-1.0, 1.0]
[run]
objectives = ["min q"]
population = 20
generations = 60
seed = 2
[constraints]
s = {{ min = 0.5 }}
"""


def _spec(text: str, tmp_path: Path | None = None):
    import tomllib

    return dspec.parse_spec(tomllib.loads(text), "optimize", text, base_dir=tmp_path)




def _front(res):
    return np.array([[d["objectives"]["f1"], d["objectives"]["f2"]] for d in res["designs"] if d["on_front"]])


def test_nsga2_finds_the_analytic_zdt1_front(client, tmp_path):
    res = run_optimize(_spec(ZDT), tmp_path / "zdt", client=client, progress=False)
    F = _front(res)
    assert len(F) >= 30 and res["computed"] == 40 * 80 and res["workers"] == 2
    # every design on the front lies on the analytic front f2 = 1 - sqrt(f1) ...
    gd = np.abs(F[:, 1] - (1 - np.sqrt(F[:, 0])))
    assert gd.max() < 0.02, gd.max()
    # ... and the front covers it: the analytic front's points are all near a found design (IGD)
    f1 = np.linspace(0, 1, 201)
    ref = np.c_[f1, 1 - np.sqrt(f1)]
    igd = np.mean([np.min(np.hypot(*(F - p).T)) for p in ref])
    assert igd < 0.02, igd
    assert F[:, 0].min() < 0.02 and F[:, 0].max() > 0.98
    # outputs: the Pareto table (Parquet and CSV) and the plots
    import pandas as pd

    table = pd.read_parquet(res["files"]["parquet"])
    assert len(table) == len(res["designs"]) and "min mean(f2)" in table.columns and "x3 [-]" in table.columns
    assert np.allclose(sorted(table["min mean(f1)"]), sorted(d["objectives"]["f1"] for d in res["designs"]))
    assert Path(res["files"]["csv"]).is_file() and Path(res["files"]["front_plot"]).stat().st_size > 10_000
    assert Path(res["files"]["parallel_plot"]).stat().st_size > 10_000


def test_differential_evolution_finds_the_constrained_optimum(client, tmp_path):
    res = run_optimize(_spec(DE), tmp_path / "de", client=client, progress=False)
    assert res["algorithm"] == "de" and len(res["designs"]) == 1
    d = res["designs"][0]
    assert d["constraints_met"] and d["constraints"]["s"] >= 0.5 - 1e-9
    assert d["objectives"]["q"] == pytest.approx(0.08, abs=2e-3)
    assert d["variables"]["x1"] == pytest.approx(0.5, abs=0.03) and d["variables"]["x2"] == pytest.approx(0.0, abs=0.03)
    # the unconstrained optimum (0.3, -0.2) violates s >= 0.5: the constraint was active
    assert d["objectives"]["q"] > 0.05
    # the generations asked for were run and written, one folder each, the designs counted once
    import pandas as pd

    folders = sorted((tmp_path / "de" / "generations").glob("gen-*"))
    assert res["generations"] == len(folders) == 60
    assert res["evaluated_designs"] == sum(len(pd.read_parquet(f / "designs.parquet")) for f in folders)
    assert all(len(pd.read_parquet(f / "designs.parquet")) <= 20 for f in folders)   # one population each


# ----------------------------------------------------------------- resume and clusters
def _env():
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "tests"),
                                                         os.environ.get("PYTHONPATH", "")])}


def _complete_generations(out: Path) -> int:
    return sum(1 for g in (out / "generations").glob("gen-*") if (g / "results.parquet").is_file())


def test_a_rerun_replays_without_recomputing(client, tmp_path):
    """The same study run again in its folder: every generation is read back (nothing computed), same front."""
    small = ZDT.replace("population = 40", "population = 8").replace("generations = 80", "generations = 4")
    first = run_optimize(_spec(small), tmp_path / "o", client=client, progress=False)
    again = run_optimize(_spec(small), tmp_path / "o", client=client, progress=False)
    assert first["computed"] == 8 * 4 and again["computed"] == 0 and again["skipped"] == 8 * 4
    assert [d["variables"] for d in again["designs"]] == [d["variables"] for d in first["designs"]]


@pytest.mark.slow
def test_killed_optimisation_replays_without_recomputing(client, tmp_path):
    """(slow: a subprocess killed and rerun) SIGKILL the CLI a few generations in; the rerun replays the recorded generations (no evaluation twice) and
    ends with exactly the front of an uninterrupted run."""
    log = tmp_path / "evals.log"
    small = ZDT.replace(f'model = "{MODEL}"', 'model = "test_optimize"').replace("population = 40", "population = 12") \
        .replace("generations = 80", "generations = 8")
    spec = tmp_path / "s.toml"
    spec.write_text(small + f"\n[fixed]\ndelay = 0.05\nlog = '{log}'\n")
    out = tmp_path / "o"
    args = [sys.executable, "-m", "studies", "optimize", str(spec), "--out", str(out), "--workers", "2", "--json"]
    p = subprocess.Popen(args, cwd=tmp_path, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         start_new_session=True)
    deadline = time.time() + 120
    while _complete_generations(out) < 3 and time.time() < deadline and p.poll() is None:
        time.sleep(0.05)
    assert p.poll() is None, "finished before it could be killed: " + p.stderr.read().decode()[-800:]
    os.killpg(p.pid, signal.SIGKILL)
    p.wait()
    first = log.read_text().splitlines()
    assert 3 * 12 <= len(first) < 8 * 12
    import pandas as pd

    def key(r):
        return repr(tuple(r[f"x{i}"] for i in range(1, N_ZDT + 1)))

    before = set()   # every evaluation recorded when the CLI was killed (complete generations and part files)
    for g in (out / "generations").glob("gen-*"):
        files = [g / "results.parquet"] if (g / "results.parquet").is_file() else list((g / "parts").glob("*.parquet"))
        for f in files:
            before |= set(pd.read_parquet(f).apply(key, axis=1))
    rc = subprocess.run(args, cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=300)
    assert rc.returncode == 0, rc.stderr[-1500:]
    res = json.loads(rc.stdout)
    second = log.read_text().splitlines()[len(first):]
    assert not set(second) & before                      # nothing recorded was evaluated again
    assert res["skipped"] == len(before) and res["computed"] == len(second)
    assert res["computed"] + res["skipped"] == res["evaluated_designs"] == 12 * 8
    # the same front as an uninterrupted run (replay is exact)
    ref = run_optimize(_spec(small.replace('model = "test_optimize"', f'model = "{MODEL}"')), tmp_path / "c",
                       client=client, progress=False)
    assert [d["variables"] for d in res["designs"]] == [d["variables"] for d in ref["designs"]]
    assert [d["objectives"] for d in res["designs"]] == [d["objectives"] for d in ref["designs"]]


def test_cli_on_an_existing_scheduler(client, tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text(ZDT.replace(f'model = "{MODEL}"', 'model = "test_optimize"').replace("generations = 80",
                                                                                       "generations = 3"))
    args = [sys.executable, "-m", "studies", "optimize", str(spec), "--out", str(tmp_path / "o"), "--scheduler",
            client.scheduler.address, "--json", "--no-progress"]
    p = subprocess.run(args, cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=180)
    assert p.returncode == 0, p.stderr[-800:]
    res = json.loads(p.stdout)
    assert res["computed"] == 120 and res["workers"] == 2
    assert any("evaluate_batch" in k for k in client.run_on_scheduler(
        lambda dask_scheduler: [str(t) for t in dask_scheduler.task_prefixes]))


# ----------------------------------------------------------------- input errors
REED = """
model = "thesis-reed"
[fixed]
"valves.geometry" = "prototype"
"valves.fidelity" = "analytic"
[operating]
speed_rpm = [595.0, 893.0]
load_pressure_mpa = [2.76]
[variables]
"valves.geometry.thickness" = [1.0e-3, 1.6e-3]
[run]
objectives = ["max volumetric_efficiency", "min valve_loss_j"]
population = 8
generations = 2
[constraints]
reed_stress = { safety_factor = 1.5 }
seat_impact_m_s = { max = 1.0 }
"""


@pytest.mark.parametrize("edit, field", [
    (('objectives = ["max volumetric_efficiency", "min valve_loss_j"]', 'objectives = ["maximise volumetric_efficiency"]'),
     "run.objectives[0]"),
    (('"min valve_loss_j"]', '"min valve_los"]'), "run.objectives[1]"),
    (("[run]", "[run]\nalgorithm = \"de\""), "run.algorithm"),
    (('"valves.geometry.thickness" = [1.0e-3, 1.6e-3]', '"valves.geometry.thickness" = [1.6e-3, 1.0e-3]'),
     'variables."valves.geometry.thickness".high'),
    (('"valves.geometry.thickness" = [1.0e-3, 1.6e-3]', '"valves.geometry.thicknes" = [1.0e-3, 1.6e-3]'),
     'variables."valves.geometry.thicknes"'),
    (('"valves.geometry.thickness" = [1.0e-3, 1.6e-3]', '"valves.geometry.thickness" = [0.3e-3, 1.6e-3]'),
     'variables."valves.geometry.thickness".low'),
    (('"valves.geometry.thickness" = [1.0e-3, 1.6e-3]', '"valves.geometry.thickness" = {values = [1e-3, 2e-3]}'),
     'variables."valves.geometry.thickness".values'),
    (("seat_impact_m_s = { max = 1.0 }", "seat_impact = { max = 1.0 }"), "constraints.seat_impact"),
    (("reed_stress = { safety_factor = 1.5 }", "reed_stress = { safety_factor = 0.5 }"),
     "constraints.reed_stress.safety_factor"),
    (('model = "thesis-reed"', 'model = "thesis-disc"'), "fixed"),
    (("generations = 2", "generations = 2000000"), "run.generations"),
    (("population = 8\ngenerations = 2", "population = 100000\ngenerations = 200\nmax_evaluations = 1000000000"),
     "run.population"),
])
def test_bad_specs_name_the_field_before_any_computation(tmp_path, edit, field):
    text = REED.replace(*edit)
    assert text != REED
    with pytest.raises(InputError) as exc:
        run_optimize(_spec(text, tmp_path), tmp_path / "o", progress=False)
    assert exc.value.field == field or exc.value.field.startswith(field), (exc.value.field, str(exc.value))
    assert not (tmp_path / "o").exists()


def test_a_different_spec_in_the_same_folder_is_refused(client, tmp_path):
    small = ZDT.replace("generations = 80", "generations = 2").replace("population = 40", "population = 8")
    run_optimize(_spec(small), tmp_path / "o", client=client, progress=False)
    with pytest.raises(InputError) as exc:
        run_optimize(_spec(small.replace("seed = 3", "seed = 4")), tmp_path / "o", client=client, progress=False)
    assert exc.value.field == "--out"
    res = run_optimize(_spec(small.replace("seed = 3", "seed = 4")), tmp_path / "o", client=client, progress=False,
                       force=True)
    assert res["computed"] == 16


# ----------------------------------------------------------------- the thesis reed pump through the CLI
@pytest.mark.slow
def test_reed_design_files_reproduce_their_objectives_through_the_cli(cli, tmp_path):
    """A small optimisation of the prototype reed's thickness with the stress and impact constraints; every design
    on the re-checked front meets every constraint (solid FEA stress) and ``valvelab pump --model design.toml
    --method reference`` reproduces its objectives at every operating point within 0.5 %."""
    spec = tmp_path / "reed.toml"
    spec.write_text(REED + "\n[recheck]\nmax_designs = 2\n")
    rc, out, err, res = cli("optimize", spec, "--out", tmp_path / "o", "--workers", "2", "--json", timeout=1800)
    assert rc == 0, err[-1500:]
    checked = [d for d in res["designs"] if d["rechecked"]]
    assert len(checked) == 2
    b = res["baseline"]
    assert b["fea_check"]["delivery"]["stress_solid_mpa"] == pytest.approx(b["fea_check"]["delivery"]
                                                                           ["stress_estimate_mpa"], rel=1e-9)
    for d in checked:
        assert d["fea_check"] is not None and "delivery" in d["fea_check"]
        if d["constraints_met"]:
            assert d["constraints"]["reed_stress_mpa"] <= 42.0 and d["constraints"]["seat_impact_m_s"] <= 1.0
        for point, command in zip(d["points"], d["commands"]):
            args = command.split()[1:]          # "valvelab pump --model ..." without the program name
            rc, out, err, pump = cli(*args)
            assert rc == 0, err[-800:]
            assert pump["volumetric_efficiency"] == pytest.approx(point["volumetric_efficiency"], rel=5e-3)
            loss = pump["valve_loss_j_per_rev"]["inlet"] + pump["valve_loss_j_per_rev"]["delivery"]
            assert loss == pytest.approx(point["valve_loss_j"], rel=5e-3)
