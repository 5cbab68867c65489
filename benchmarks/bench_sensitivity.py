"""Evaluations per hour of a Sobol sensitivity study of the thesis disc pump on a dask LocalCluster.

Run on demand from the repository root: ``python benchmarks/bench_sensitivity.py [--samples N]
[--workers W] [--points P]``; prints one JSON object. A Saltelli design of N base samples over
six parameters (N x 8 designs) at P operating points (one to four of Table 5.4's conditions)
runs through ``studies.sweeps.design.sensitivity.run_sensitivity`` on a fresh LocalCluster into a
temporary folder, exactly as ``valvelab sensitivity`` does (fast path, rtol 1e-4, five
revolutions); the cluster's start-up and each worker's numba cache load are included in the
whole-run figure, not in the evaluation-stage figure.
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

from studies.sweeps.design.sensitivity import run_sensitivity  # noqa: E402
from studies.sweeps.design.spec import parse_spec  # noqa: E402

SPEC = """
model = "thesis-disc"
[operating]
speed_rpm = {speeds}
load_pressure_mpa = {loads}
[variables]
"oil.air_content" = [0.005, 0.02]
"pump.dead_volume" = [1.95e-5, 2.39e-5]
"valves.spring.stiffness" = [190.0, 235.0]
"valves.mass.disc" = [2.25e-3, 2.75e-3]
"effects.discharge_scale.scale" = [0.85, 1.15]
"valves.drag.viscous_coefficient" = [5.0, 20.0]
[run]
samples = {n}
outputs = ["delivery_cc_per_rev", "inlet_closing_angle_deg", "valve_loss_j"]
"""


def run(samples: int = 256, workers: int = 2, points: int = 1) -> dict:
    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    speeds, loads = [[593.0], [593.0, 743.0], [593.0, 743.0], [593.0, 743.0]][points - 1], \
        [[2.76], [2.76], [2.76, 3.67], [2.76, 3.67]][points - 1]
    if points == 3:
        speeds, loads = [593.0, 743.0, 893.0], [2.76]
    text = SPEC.format(n=samples, speeds=speeds, loads=loads)
    spec = parse_spec(tomllib.loads(text), "sensitivity", text)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        r = run_sensitivity(spec, Path(tmp) / "s", workers=workers, progress=True)
    wall = time.perf_counter() - t0
    return {
        "benchmark": "sensitivity", "machine": platform.machine(), "cores": os.cpu_count(), "workers": workers,
        "method": "sobol", "variables": len(spec.variables), "samples": samples, "operating_points": len(spec.points),
        "designs": r["designs"], "evaluations": r["evaluations"], "failed": r["failed"],
        "wall_seconds": round(wall, 1), "evaluation_wall_seconds": round(r["evaluation_wall_seconds"], 1),
        "evaluations_per_hour": round(r["evaluations"] / wall * 3600),
        "evaluation_stage_evaluations_per_hour": round(r["designs_per_hour"]),
        "designs_per_hour": round(r["designs"] / wall * 3600),
        "delivery_total_indices": {x["variable"]: round(x["ST"], 4) for x in r["indices"]
                                   if x["output"] == "delivery_cc_per_rev" and x["operating_point"] ==
                                   ("mean" if len(spec.points) > 1 else r["indices"][0]["operating_point"])},
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=256)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--points", type=int, default=1, choices=(1, 2, 3, 4))
    a = ap.parse_args(argv)
    print(json.dumps(run(a.samples, a.workers, a.points), indent=2))


if __name__ == "__main__":
    main()
