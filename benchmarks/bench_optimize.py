"""Wall time of the reed optimisation example as a user runs it, its front against the saved one, and its scaling.

Run from the repository root: ``python benchmarks/bench_optimize.py [--no-full] [--generations 5,10,20]
[--workers W] [--save]``; prints one JSON object (``--save``: also benchmarks/results_optimize.json).

- full: ``valvelab optimize docs/examples/optimize_reed.toml --out TMP --json`` in a subprocess,
  exactly as a user runs it (NSGA-II, population 40 x 40 generations x 3 speeds, the stress
  calibration, the solid FEA and reference re-check of 12 front designs, the reports); its wall
  time (target: 5 minutes), the stages' wall times (``stage_seconds`` of its JSON) and its front
  against ``benchmarks/optimize_front_before.json`` (the front before the steady-state stop and warm
  start): each design of one front at its distance from the other front's polyline, both
  objectives scaled by the saved front's range; the optimiser's own test (tests/test_optimize.py,
  ZDT1) accepts an inverted generational distance below 0.02 in such units;
- scaling: the loop alone (``run_optimize`` with the re-check off) at population 40 and each of
  ``--generations``: wall seconds against designs x operating points.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

EXAMPLE = ROOT / "docs" / "examples" / "optimize_reed.toml"
BEFORE = Path(__file__).resolve().parent / "optimize_front_before.json"
RESULTS = Path(__file__).resolve().parent / "results_optimize.json"
TARGET_SECONDS = 300.0
OBJECTIVES = ("volumetric_efficiency", "valve_loss_j")


def _front(designs, key) -> np.ndarray:
    pts = [[e[key][o] for o in OBJECTIVES] for e in designs if e.get(key) and all(e[key].get(o) is not None
                                                                                for o in OBJECTIVES)]
    return np.array(sorted(pts))


def _to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance of each point to the polyline through ``line`` (sorted by its first coordinate)."""
    out = []
    for p in points:
        best = np.min(np.linalg.norm(line - p, axis=1))
        for a, b in zip(line[:-1], line[1:]):
            ab = b - a
            t = np.clip(np.dot(p - a, ab) / max(np.dot(ab, ab), 1e-300), 0.0, 1.0)
            best = min(best, float(np.linalg.norm(a + t * ab - p)))
        out.append(best)
    return np.array(out)


def compare_fronts(new_designs, before=BEFORE, key="objectives_fast") -> dict:
    """The loop's front (fast objectives of the final front) against the saved one, in units of its range."""
    old = _front(json.loads(Path(before).read_text())["designs"], key)
    new = _front(new_designs, key)
    lo, span = old.min(axis=0), np.ptp(old, axis=0)
    a, b = (old - lo) / span, (new - lo) / span
    to_old, to_new = _to_polyline(b, a), _to_polyline(a, b)
    return {"objectives": list(OBJECTIVES), "designs_before": len(old), "designs_after": len(new),
            "igd_after_to_before": float(to_old.mean()), "igd_before_to_after": float(to_new.mean()),
            "max_distance_after_to_before": float(to_old.max()), "max_distance_before_to_after": float(to_new.max()),
            "tolerance": 0.02, "within_tolerance": bool(max(to_old.mean(), to_new.mean()) < 0.02),
            "range_before": {o: [float(old[:, i].min()), float(old[:, i].max())] for i, o in enumerate(OBJECTIVES)},
            "range_after": {o: [float(new[:, i].min()), float(new[:, i].max())] for i, o in enumerate(OBJECTIVES)}}


def full_run(workers: int | None) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "studies", "optimize", str(EXAMPLE), "--out", str(Path(tmp) / "opt"), "--json"]
        if workers:
            cmd += ["--workers", str(workers)]
        env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        t0 = time.perf_counter()
        rc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    if rc.returncode != 0:
        raise SystemExit(f"valvelab optimize failed ({rc.returncode}): {rc.stderr[-2000:]}")
    d = json.loads(rc.stdout)
    return {"command": "valvelab optimize docs/examples/optimize_reed.toml --out DIR --json",
            "wall_seconds": round(wall, 1), "target_seconds": TARGET_SECONDS, "meets_target": wall <= TARGET_SECONDS,
            "stage_seconds": d.get("stage_seconds"), "loop_wall_seconds": round(d["loop_wall_seconds"], 1),
            "evaluated_designs": d["evaluated_designs"], "feasible_designs": d["feasible_designs"],
            "evaluations": d["evaluations"], "dominating_baseline": d["dominating_baseline"],
            "front_size": sum(1 for e in d["designs"] if e.get("on_front")),
            "front": compare_fronts(d["designs"]),
            "front_rechecked": compare_fronts(d["designs"], key="objectives")}


def loop_run(population: int, generations: int, workers: int) -> dict:
    from studies.sweeps.design.optimize import run_optimize
    from studies.sweeps.design.spec import parse_spec

    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    doc = tomllib.loads(EXAMPLE.read_text())
    doc["run"].update(population=population, generations=generations)
    doc["recheck"] = {"enabled": False}
    spec = parse_spec(doc, "optimize", "", base_dir=EXAMPLE.parent)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        r = run_optimize(spec, Path(tmp) / "o", workers=workers, progress=False)
    wall = time.perf_counter() - t0
    return {"population": population, "generations": generations, "designs": r["evaluated_designs"],
            "evaluations": r["evaluations"], "wall_seconds": round(wall, 1),
            "loop_wall_seconds": round(r["loop_wall_seconds"], 1),
            "evaluations_per_hour_loop": round(r["evaluations"] / r["loop_wall_seconds"] * 3600)}


def run(full: bool = True, generations=(5, 10, 20), population: int = 40, workers: int = 2) -> dict:
    load0 = os.getloadavg()
    out = {"benchmark": "optimize", "machine": platform.machine(), "cores": os.cpu_count(), "workers": workers}
    before = json.loads(BEFORE.read_text())
    out["before"] = {k: before[k] for k in ("commit", "wall_seconds", "loop_wall_seconds", "evaluated_designs",
                                            "feasible_designs", "what")}
    if full:
        out["full"] = full_run(workers)
    out["scaling"] = [loop_run(population, g, workers) for g in generations]
    out["load_average_before_after"] = [round(load0[0], 2), round(os.getloadavg()[0], 2)]
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-full", action="store_true", help="skip the full example run")
    ap.add_argument("--generations", default="5,10,20", help="generations of the loop-only runs (comma list)")
    ap.add_argument("--population", type=int, default=40)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--save", action="store_true", help=f"also write {RESULTS.name}")
    a = ap.parse_args(argv)
    gens = tuple(int(g) for g in a.generations.split(",") if g.strip())
    res = run(not a.no_full, gens, a.population, a.workers)
    text = json.dumps(res, indent=2)
    print(text)
    if a.save:
        RESULTS.write_text(text + "\n")


if __name__ == "__main__":
    main()
