"""Benchmark of the default Table 3.3 solid run (four reeds, converged meshes). Run on demand:

    python benchmarks/bench_fea.py [--repeat N]

Prints one JSON object: wall seconds of ``valvelab table 3.3``'s computation, peak resident
memory, and the profile split (mesh, assembly, factorisation, static solve, eigen-solve,
post-processing) per reed, from :func:`fea.solid.solve`'s timings.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fea import solid  # noqa: E402
from geometry import load_reed  # noqa: E402

REEDS = ("uniform", "stepped1", "stepped2", "prototype")


def run_once() -> dict:
    """Solve the four reeds as Table 3.3 does; the E-B column (beam FE or analytic) is timed apart."""
    per_reed, total = {}, {}
    t0 = time.perf_counter()
    for name in REEDS:
        t = time.perf_counter()
        r = solid.solve(load_reed(name))
        per_reed[name] = {"seconds": round(time.perf_counter() - t, 3), "dofs": r.dofs,
                          "omega_n": round(r.omega_n, 2), "kappa": round(r.kappa, 1),
                          "profile": {k: round(v, 3) for k, v in r.timings.items()}}
        for k, v in r.timings.items():
            total[k] = total.get(k, 0.0) + v
    solid_seconds = time.perf_counter() - t0
    t1 = time.perf_counter()
    from studies.tables.fea import _eb_properties

    for name in REEDS:
        _eb_properties(load_reed(name))
    return {"solid_seconds": round(solid_seconds, 3), "eb_seconds": round(time.perf_counter() - t1, 3),
            "profile_total": {k: round(v, 3) for k, v in total.items()}, "reeds": per_reed}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    runs = [run_once() for _ in range(args.repeat)]
    best = min(runs, key=lambda r: r["solid_seconds"])
    out = {
        "benchmark": "table_3_3_solid",
        "seconds": best["solid_seconds"] + best["eb_seconds"],
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "cpus": os.cpu_count(),
        "load_average_1min": round(os.getloadavg()[0], 2),
        "repeat": args.repeat,
        **best,
    }
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
