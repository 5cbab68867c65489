"""Designs per hour of a pump design sweep on a dask LocalCluster, before and after the steady-state stop, and its accuracy.

Run from the repository root: ``python benchmarks/bench_sweep.py [--designs N] [--workers W]
[--sizes 1000,10000] [--before-designs M] [--accuracy K] [--save]``; prints one JSON object
(``--save``: also into benchmarks/results_sweep.json). A Sobol sweep over valve type, speed,
load pressure and air content (the fast path) runs through ``studies.sweeps.sweep.run_sweep``
on a fresh LocalCluster into a temporary folder, exactly as ``valvelab sweep`` does; the
cluster's start-up and each worker's numba cache load are included in the wall time.

- after (today's default): each design until the cyclic steady-state test passes, warm-started
  from the nearest design solved before it in its batch (studies/sweeps/locality.py);
- before: the former default, five revolutions from today's start (``revolutions = 5``,
  ``warm_start = false``), on ``--before-designs`` designs (default: as many; 0 skips it);
- scaling: the default sweep at each of ``--sizes`` designs (and at N), for the figure of
  wall time against designs;
- accuracy: K designs drawn at random, each also run 40 revolutions from today's start; the
  relative difference of the sweeps' delivery from it (after and before), and the 40-revolution
  run's own spread over its last ten revolutions; and all three against a sharp reference (12
  revolutions at rtol 1e-5), which tells the stop rule's error from the integrator's at the sweep's rtol.

Peak memory is the largest resident set of the client and of each worker process.
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
{fixed}
"""
BEFORE = "[fixed]\nrevolutions = 5\nwarm_start = false"
TARGET_DESIGNS_PER_HOUR = 2_000_000
RESULTS = Path(__file__).resolve().parent / "results_sweep.json"


def _maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _sweep(n_designs: int, workers: int, fixed: str = "") -> tuple[dict, object]:
    """One sweep on a fresh LocalCluster: (figures, results DataFrame)."""
    import tomllib

    import pandas as pd
    from distributed import Client, LocalCluster

    text = SPEC.format(n=n_designs, fixed=fixed)
    spec = sweep.parse_spec(tomllib.loads(text), text)
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=40)
    client = Client(cluster)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            s = sweep.run_sweep(spec, Path(tmp) / "sweep", client=client, progress=True)
            df = pd.read_parquet(s["results"])
        worker_rss = client.run(_maxrss_mb)
    finally:
        client.close()
        cluster.close()
    wall = time.perf_counter() - t0
    client_cpu = time.process_time() - cpu0
    ok = df[df["status"] != "error"]
    revs = df["revolutions_run"].value_counts().sort_index()
    out = {
        "designs": len(df), "failed": int((df["status"] == "error").sum()),
        "not_cyclic": int((df["status"] == "not_cyclic").sum()),
        "wall_seconds": round(wall, 1),
        "designs_per_hour": round(len(df) / wall * 3600),
        "sweep_loop_designs_per_hour": round(s["designs_per_hour"]),
        "cpu_seconds_per_design_mean": round(float(df["eval_seconds"].mean()), 5),
        # the client's own CPU (sampling, ordering, scheduler, Parquet parts): it shares the cores with the workers
        "client_cpu_seconds": round(client_cpu, 1),
        "revolutions_mean": round(float(df["revolutions_run"].mean()), 4),
        "revolutions_counts": {str(int(k)): int(v) for k, v in revs.items()},
        "warm_started_fraction": round(float(df["warm_started"].mean()), 4),
        "cycle_change_max": float(ok["cycle_change"].max()),
        "peak_memory_mb": {"client": round(_maxrss_mb(), 1),
                           "workers": [round(v, 1) for v in worker_rss.values()]},
        "delivery_cc_per_rev_range": [round(float(ok["delivery_m3_per_rev"].min()) * 1e6, 4),
                                      round(float(ok["delivery_m3_per_rev"].max()) * 1e6, 4)],
    }
    return out, df


def _long_run(design: dict) -> tuple[float, float, float]:
    """(delivery [m^3] of a 40-revolution run from today's start, spread of its last ten revolutions [-],
    delivery of the sharp reference [m^3]: 12 revolutions at rtol 1e-5, a hundred times tighter than the
    sweep's, whose last revolutions agree to ~1e-7)."""
    from lumped.run.simulate import simulate
    from studies.sweeps.pump import build_model

    model = build_model(design)
    r = simulate(model, design["speed_rpm"], design["load_pressure"], air_content=design["air_content"], revolutions=40)
    sharp = simulate(model, design["speed_rpm"], design["load_pressure"], air_content=design["air_content"],
                     revolutions=12, rtol=1e-5)
    tail = r.deliveries[-10:]
    return r.delivery_per_rev, (max(tail) - min(tail)) / abs(sum(tail) / len(tail)), sharp.delivery_per_rev


def _quantiles(x) -> dict:
    import numpy as np

    x = np.abs(np.asarray(x, dtype=float))
    return {"median": float(np.median(x)), "p90": float(np.quantile(x, 0.9)), "p99": float(np.quantile(x, 0.99)),
            "max": float(x.max()), "within_1e-4": int((x <= 1e-4).sum()), "count": int(len(x))}


def accuracy(after, before, k: int, workers: int, seed: int = 7) -> dict:
    """Deliveries of K random designs against 40-revolution runs from today's start (on a LocalCluster)."""
    import numpy as np
    from distributed import Client, LocalCluster

    ids = np.random.default_rng(seed).choice(after["design_id"].to_numpy(), size=min(k, len(after)), replace=False)
    a = after.set_index("design_id").loc[ids]
    designs = [{"valve": r.valve, "speed_rpm": float(r.speed_rpm), "load_pressure": float(r.load_pressure),
                "air_content": float(r.air_content)} for r in a.itertuples()]
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=40) as cluster, Client(cluster) as client:
        long = client.gather(client.map(_long_run, designs, pure=False))
    ref = np.array([d for d, _, _ in long])
    sharp = np.array([d for _, _, d in long])
    # a 40-revolution run at the sweep's rtol carries the integrator's error (its step sequence differs from
    # the sweep's, ~1e-4 in the median): the sharp reference tells the stop rule's error from that
    out = {"designs_checked": len(designs), "reference": "40 revolutions from today's start, same rtol",
           "after": _quantiles(a["delivery_m3_per_rev"].to_numpy() / ref - 1),
           "long_run_spread_last_10": _quantiles([s for _, s, _ in long]),
           "sharp_reference": "12 revolutions from today's start at rtol 1e-5",
           "after_vs_sharp": _quantiles(a["delivery_m3_per_rev"].to_numpy() / sharp - 1),
           "long_run_vs_sharp": _quantiles(ref / sharp - 1)}
    if before is not None:
        b = before.set_index("design_id")
        common = [i for i in ids if i in b.index]
        if common:
            keep = [k for k, i in enumerate(ids) if i in b.index]
            out["before"] = _quantiles(b.loc[common, "delivery_m3_per_rev"].to_numpy() / ref[keep] - 1)
            out["before_vs_sharp"] = _quantiles(b.loc[common, "delivery_m3_per_rev"].to_numpy() / sharp[keep] - 1)
    return out


def run(n_designs: int = 100_000, workers: int | None = None, sizes=(1000, 10_000), before_designs: int | None = None,
        k_accuracy: int = 200) -> dict:
    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    workers = workers or sweep.default_workers()
    load0 = os.getloadavg()
    after, df_after = _sweep(n_designs, workers)
    scaling = []
    for n in sorted(set(sizes)):
        if n != n_designs:
            s, _ = _sweep(n, workers)
            scaling.append({"designs": n, "wall_seconds": s["wall_seconds"], "designs_per_hour": s["designs_per_hour"],
                            "revolutions_mean": s["revolutions_mean"]})
    scaling.append({"designs": n_designs, "wall_seconds": after["wall_seconds"],
                    "designs_per_hour": after["designs_per_hour"], "revolutions_mean": after["revolutions_mean"]})
    scaling.sort(key=lambda r: r["designs"])
    before = df_before = None
    nb = n_designs if before_designs is None else before_designs
    if nb:
        before, df_before = _sweep(nb, workers, BEFORE)
    acc = accuracy(df_after, df_before if nb == n_designs else None, k_accuracy, workers) if k_accuracy else None
    return {
        "benchmark": "sweep", "machine": platform.machine(), "cores": os.cpu_count(), "workers": workers,
        "load_average_before_after": [round(load0[0], 2), round(os.getloadavg()[0], 2)],
        "settings": "until cyclic steady state (steady_tol 1e-3, floored at rtol 1e-3), warm-started in batches, "
                    "one revolution when the warm start is a fixed point of the revolution map",
        **after,
        "target_designs_per_hour": TARGET_DESIGNS_PER_HOUR,
        "meets_target": after["designs_per_hour"] >= TARGET_DESIGNS_PER_HOUR,
        "before": None if before is None else {"settings": "5 revolutions from today's start", **before},
        "speedup": None if before is None else round(after["designs_per_hour"] / before["designs_per_hour"], 2),
        "scaling": scaling,
        "accuracy": acc,
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=100_000)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--sizes", default="1000,10000", help="other sweep sizes for the scaling figure (comma list)")
    ap.add_argument("--before-designs", type=int, default=None, help="designs of the 'before' sweep (0: skip)")
    ap.add_argument("--accuracy", type=int, default=200, help="designs checked against 40-revolution runs (0: skip)")
    ap.add_argument("--save", action="store_true", help=f"also write {RESULTS.name}")
    a = ap.parse_args(argv)
    sizes = tuple(int(s) for s in a.sizes.split(",") if s.strip())
    res = run(a.designs, a.workers, sizes, a.before_designs, a.accuracy)
    text = json.dumps(res, indent=2)
    print(text)
    if a.save:
        RESULTS.write_text(text + "\n")


if __name__ == "__main__":
    main()
