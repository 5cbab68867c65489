"""Designs per hour of a pump design sweep on a dask LocalCluster, and peak memory.

Run on demand from the repository root: ``python benchmarks/bench_sweep.py [--designs N]
[--workers W]``; prints one JSON object. A Sobol sweep over valve type, speed, load
pressure and air content (5 revolutions per design, the fast path) runs through
``studies.sweeps.sweep.run_sweep`` on a fresh LocalCluster into a temporary folder, exactly as
``valvelab sweep`` does; the cluster's start-up and each worker's numba cache load are
included in the wall time. Peak memory is the largest resident set of the client and of
each worker process.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from studies.sweeps import sweep  # noqa: E402

SPEC = """
[sweep]
model = "pump"
sampler = "sobol"
samples = {n}
seed = 1
[factors.valve]
values = ["disc", "reed"]
[factors.speed_rpm]
low = 450.0
high = 950.0
[factors.load_pressure]
low = 1.5e6
high = 4.5e6
[factors.air_content]
low = 0.0
high = 0.03
[fixed]
revolutions = 5
"""


def _maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run(n_designs: int = 1000, workers: int | None = None) -> dict:
    import tomllib

    from distributed import Client, LocalCluster

    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    text = SPEC.format(n=n_designs)
    spec = sweep.parse_spec(tomllib.loads(text), text)
    workers = workers or sweep.default_workers()
    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=40)
    client = Client(cluster)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            s = sweep.run_sweep(spec, Path(tmp) / "sweep", client=client, progress=True)
            import pandas as pd

            df = pd.read_parquet(s["results"])
        worker_rss = client.run(_maxrss_mb)
    finally:
        client.close()
        cluster.close()
    wall = time.perf_counter() - t0
    ok = df[df["status"] != "error"]
    return {
        "benchmark": "sweep", "machine": platform.machine(), "cores": os.cpu_count(), "workers": workers,
        "designs": len(df), "failed": int((df["status"] == "error").sum()),
        "not_cyclic": int((df["status"] == "not_cyclic").sum()),
        "wall_seconds": round(wall, 1),
        "designs_per_hour": round(len(df) / wall * 3600),
        "sweep_loop_designs_per_hour": round(s["designs_per_hour"]),
        "cpu_seconds_per_design_mean": round(float(df["eval_seconds"].mean()), 4),
        "simulated_seconds_per_design_mean": round(float((5 * 60 / df["speed_rpm"]).mean()), 4),
        "peak_memory_mb": {"client": round(_maxrss_mb(), 1),
                           "workers": {k: round(v, 1) for k, v in worker_rss.items()}},
        "delivery_cc_per_rev_range": [round(float(ok["delivery_m3_per_rev"].min()) * 1e6, 4),
                                      round(float(ok["delivery_m3_per_rev"].max()) * 1e6, 4)],
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=1000)
    ap.add_argument("--workers", type=int, default=None)
    a = ap.parse_args(argv)
    print(json.dumps(run(a.designs, a.workers), indent=2))


if __name__ == "__main__":
    main()
