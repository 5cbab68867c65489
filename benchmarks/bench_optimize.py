"""Designs per hour of the optimisation loop (NSGA-II on the thesis reed pump) on a dask LocalCluster.

Run on demand from the repository root: ``python benchmarks/bench_optimize.py [--population P]
[--generations G] [--workers W] [--recheck]``; prints one JSON object. The example of
docs/optimization.md (the prototype reed's thickness, widths, length and step; three speeds;
the reed stress and impact constraints) runs through ``studies.sweeps.design.optimize.run_optimize``
on a fresh LocalCluster into a temporary folder, as ``valvelab optimize`` does: analytic reed
model and fast path in the loop (rtol 1e-4). A design is one reed at all three speeds (three
pump simulations plus the reed's analytic model and stress estimate). The front's re-check
(solid FEA and reference integrator, minutes per design on two cores) is off unless
``--recheck``; the stress calibration's one solid FEA run is included in the wall time.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from studies.sweeps.design.optimize import run_optimize  # noqa: E402
from studies.sweeps.design.spec import parse_spec  # noqa: E402

EXAMPLE = ROOT / "docs" / "examples" / "optimize_reed.toml"


def run(population: int = 40, generations: int = 10, workers: int = 2, recheck: bool = False) -> dict:
    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    doc = tomllib.loads(EXAMPLE.read_text())
    doc["run"].update(population=population, generations=generations)
    doc["recheck"] = {"enabled": recheck}
    spec = parse_spec(doc, "optimize", "", base_dir=EXAMPLE.parent)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        r = run_optimize(spec, Path(tmp) / "o", workers=workers, progress=True)
    wall = time.perf_counter() - t0
    npts = len(spec.points)
    return {
        "benchmark": "optimize", "machine": platform.machine(), "cores": os.cpu_count(), "workers": workers,
        "algorithm": r["algorithm"], "variables": len(spec.variables), "operating_points": npts,
        "population": population, "generations": generations, "designs": r["evaluated_designs"],
        "feasible": r["feasible_designs"], "evaluations": r["evaluations"], "recheck": recheck,
        "wall_seconds": round(wall, 1), "loop_wall_seconds": round(r["loop_wall_seconds"], 1),
        "designs_per_hour_loop": round(r["evaluated_designs"] / r["loop_wall_seconds"] * 3600),
        "evaluations_per_hour_loop": round(r["evaluations"] / r["loop_wall_seconds"] * 3600),
        "evaluation_stage_evaluations_per_hour": round(r["designs_per_hour"]),
        "designs_per_hour_whole_run": round(r["evaluated_designs"] / wall * 3600),
        "front_size": len(r["designs"]),
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--population", type=int, default=40)
    ap.add_argument("--generations", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--recheck", action="store_true")
    a = ap.parse_args(argv)
    print(json.dumps(run(a.population, a.generations, a.workers, a.recheck), indent=2))


if __name__ == "__main__":
    main()
