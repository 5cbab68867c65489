"""Benchmark of the fluid references (fea.fluid). Run on demand:

    python benchmarks/bench_fluid.py [--skip-characterisation] [--valve thesis-disc:inlet]

Prints one JSON object: the thin film's seconds per point (target < 2 s), one axisymmetric
point on the default mesh (target < 30 s) and with its three-mesh GCI ladder, the whole disc
characterisation behind ``fluid = "predicted"`` (target < 10 min; computed afresh into a
temporary cache), each with DOFs; peak resident memory of the process and the load average
(timings on a shared machine say so).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fea.fluid import compact  # noqa: E402
from fea.fluid.axisymmetric import axisymmetric_point  # noqa: E402
from fea.fluid.disc_film import thin_film_point  # noqa: E402
from fea.fluid.point import load_fluid_valve  # noqa: E402


def _timed(f, *args, **kw):
    t, c = time.perf_counter(), time.process_time()
    out = f(*args, **kw)
    return out, round(time.perf_counter() - t, 3), round(time.process_time() - c, 3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--valve", default="thesis-disc:inlet")
    ap.add_argument("--skip-characterisation", action="store_true")
    args = ap.parse_args()
    v = load_fluid_valve(args.valve)
    out = {"benchmark": "fluid", "valve": v.name, "cpus": os.cpu_count(), "loadavg_start": os.getloadavg()}
    p, wall, cpu = _timed(thin_film_point, v, 0.1e-3, 20.0, {"squeeze": True, "displacement": True})
    out["thin_film_point"] = {"seconds": wall, "cpu_seconds": cpu, "dofs": p.extra["mesh"]["dofs"], "target_s": 2}
    p, wall, cpu = _timed(axisymmetric_point, v, 0.6e-3, 60.0, {})
    out["axisymmetric_point"] = {"seconds": wall, "cpu_seconds": cpu, "dofs": p.extra["mesh"]["dofs"],
                                 "lift_mm": 0.6, "reynolds": 60.0, "target_s": 30}
    p, wall, cpu = _timed(axisymmetric_point, v, 0.6e-3, 60.0, {"gci": True, "moving": True})
    out["axisymmetric_point_gci_moving"] = {"seconds": wall, "cpu_seconds": cpu, "u_num": p.extra["u_num_all"]}
    if not args.skip_characterisation:
        with tempfile.TemporaryDirectory() as tmp:
            os.environ["VALVELAB_CACHE_DIR"] = tmp
            data, wall, cpu = _timed(compact.compact_forms, v, recompute=True, progress=True)
        prov = data["provenance"]
        out["characterisation"] = {"seconds": wall, "cpu_seconds": cpu, "points": len(data["points"]),
                                   "failed": len(data.get("failed", [])), "dofs": prov["dofs"], "target_s": 600}
    out["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    out["loadavg_end"] = os.getloadavg()
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
