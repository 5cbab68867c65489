"""Wall time of the discrepancy workflow on a 6-run dataset (the thesis's O-ring story).

Run on demand from the repository root: ``python benchmarks/bench_discrepancy.py
[--workers N] [--reference]``; prints one JSON object. It synthesises the six disc runs
of Tables 5.3/5.4 with the delivery valve's compliant seat hidden (k_seat = 1.5e6 N/m,
R = 0.013 stated), then runs the whole workflow (every candidate, every round) and
reports wall seconds, simulations, simulations per second and what was found. The fast
path's numba compilation (or cache load) is done first and reported separately.
``--reference`` forces the reference integrator (VALVELAB_REFERENCE=1): ~100x slower.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--reference", action="store_true")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    if args.reference:
        os.environ["VALVELAB_REFERENCE"] = "1"

    from lumped.effects import Applied
    from studies.discrepancy.synth import thesis_conditions
    from studies.discrepancy.workflow import RunCondition, Settings, Workflow
    from studies.discrepancy.pump_sim import LIBRARY, simulate
    from studies.discrepancy.synth import Noise, synthesize

    t0 = time.perf_counter()
    simulate(RunCondition("warm-up", "disc", 593.0, 2.79e6, 0.013), ())   # compile or load the cache
    compile_s = time.perf_counter() - t0
    truth = (Applied.of("seat_compliance", "delivery", {"k_seat": 1.5e6}),)
    t1 = time.perf_counter()
    runs, _ = synthesize(simulate, "disc", thesis_conditions("disc", 0.013), truth, Noise(), seed=args.seed,
                         workers=args.workers)
    synth_s = time.perf_counter() - t1
    t2 = time.perf_counter()
    out = Workflow(runs, simulate, LIBRARY, Settings(workers=args.workers), progress=True).run().as_contract()
    wall = time.perf_counter() - t2
    print(json.dumps({
        "benchmark": "discrepancy workflow, 6 disc runs, O-ring hidden",
        "integrator": "reference" if args.reference else "fast",
        "workers": args.workers, "cpus": os.cpu_count(), "machine": platform.machine(),
        "compile_or_cache_seconds": compile_s, "synth_seconds": synth_s,
        "workflow_wall_seconds": wall, "simulations": out["simulations"],
        "simulations_per_second": out["simulations"] / wall,
        "effects_added": out["effects_added"], "parameters": out["parameters"],
        "held_out_position_rms_reduction_pct": out["held_out"]["position_rms_reduction_pct"],
    }, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
