"""CPU seconds per simulated second of pumping: fast path vs reference path, same process.

Run on demand from the repository root: ``python benchmarks/bench_pump.py [--quick]
[--repeat R]``; prints one JSON object. For each valve type it simulates the thesis's
validation cases (Tables 5.4 and 5.6; ``--quick``: the first of each) for five
revolutions, as the thesis did (section 5.6: 23 s of CPU per simulated second), with
``lumped.run.simulate.simulate`` on the fast stepper (compiled Rodas4P, default tolerances) and
on the reference stepper (scipy Radau, its defaults), one after the other in this
process, and reports CPU seconds per simulated second of each (per case, the median over
the cases of each valve kind, and the total), their ratio, steps per revolution and CPU
time per step of the fast path, and the delivery and angle differences. Each fast run is repeated R
times (default 3) and its median CPU time counted (the machine may be shared; the
reference, ~100x longer, runs once). The fast path's one-off numba compilation (or cache
load) is reported separately and never counted in its CPU time. The load average before
and after is reported: repeat the run if it is high.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lumped.solver import steppers  # noqa: E402
from lumped.run.simulate import DEFAULT_TOLERANCES, ensure_compiled, simulate  # noqa: E402
from lumped.valves.kind import KINDS  # noqa: E402
from studies.tables.thesis import experiments  # noqa: E402


def run(quick: bool = False, revolutions: int = 5, repeat: int = 3) -> dict:
    t0 = time.perf_counter()
    load_before = os.getloadavg()
    compile_s = ensure_compiled()
    rtol, atol = DEFAULT_TOLERANCES["fast"]
    out = {
        "benchmark": "pump", "machine": platform.machine(), "cpus": os.cpu_count(),
        "python": platform.python_version(), "revolutions": revolutions, "fast_repeats": repeat,
        "thesis_cpu_per_simulated_second": 23.0,
        "fast_compile_or_cache_load_seconds": round(compile_s, 3),
        "fast_tolerances": {"rtol": rtol, "atol": atol, "free_velocity_atol": {k.name: k.free_velocity_atol for k in KINDS.values()},
                            "free_position_atol": steppers.FREE_POSITION_ATOL,
                            "contact_position_atol": {k.name: k.contact_position_atol for k in KINDS.values()},
                            "contact_velocity_atol": {k.name: k.contact_velocity_atol for k in KINDS.values()}},
        "load_average_before": [round(x, 2) for x in load_before], "valves": {},
    }
    for valve in ("disc", "reed"):
        cases = [c for c in experiments() if c["valve"] == valve]
        if quick:
            cases = cases[:1]
        rows, f_cpu, r_cpu, sim = [], 0.0, 0.0, 0.0
        for c in cases:
            args = (f"thesis-{valve}", c["speed_rpm"], c["load_pressure"])
            kw = dict(air_content=c["air_content"], revolutions=revolutions)
            fs = [simulate(*args, method="fast", **kw) for _ in range(repeat)]
            f = fs[0]
            f_case = statistics.median(x.cpu_seconds for x in fs)
            print(f"{valve} {c['condition']}: fast {f_case / f.simulated_seconds * 1e3:.1f} ms per simulated s",
                  file=sys.stderr, flush=True)
            r = simulate(*args, method="reference", **kw)
            f_cpu += f_case
            r_cpu += r.cpu_seconds
            sim += f.simulated_seconds
            rows.append({
                "condition": c["condition"], "measured_valve": c["measured_valve"], "speed_rpm": c["speed_rpm"],
                "fast_cpu_per_simulated_second": round(f_case / f.simulated_seconds, 5),
                "fast_cpu_per_simulated_second_min": round(min(x.cpu_seconds for x in fs) / f.simulated_seconds, 5),
                "reference_cpu_per_simulated_second": round(r.cpu_per_simulated_second, 4),
                "speedup": round(r.cpu_seconds / f_case, 1),
                "delivery_relative_difference": (f.delivery_per_rev - r.delivery_per_rev) / r.delivery_per_rev,
                "opening_closing_angle_difference_deg": _angle_diff(f, r),
                "fast_rhs_evaluations": f.rhs_evaluations, "reference_rhs_evaluations": r.rhs_evaluations,
                "fast_steps_per_revolution": round(f.steps / f.revolutions, 1),
                "fast_microseconds_per_step": round(f_case / f.steps * 1e6, 3),
                "stop_contacts_fast": [v.stop_contacts for v in f.valves.values()],
                "stop_contacts_reference": [v.stop_contacts for v in r.valves.values()],
            })
        out["valves"][valve] = {
            "fast_cpu_per_simulated_second_median": round(statistics.median(
                x["fast_cpu_per_simulated_second"] for x in rows), 5),
            "fast_steps_per_revolution_median": statistics.median(x["fast_steps_per_revolution"] for x in rows),
            "fast_microseconds_per_step_median": statistics.median(x["fast_microseconds_per_step"] for x in rows),
            "speedup_median": statistics.median(x["speedup"] for x in rows),
            "stop_contacts_equal": all(x["stop_contacts_fast"] == x["stop_contacts_reference"] for x in rows),
            "fast_cpu_per_simulated_second": round(f_cpu / sim, 5),
            "reference_cpu_per_simulated_second": round(r_cpu / sim, 4),
            "speedup": round(r_cpu / f_cpu, 1),
            "worst_delivery_relative_difference": max(abs(x["delivery_relative_difference"]) for x in rows),
            "worst_angle_difference_deg": max(x["opening_closing_angle_difference_deg"] for x in rows),
            "cases": rows,
        }
    out["load_average_after"] = [round(x, 2) for x in os.getloadavg()]
    out["peak_memory_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    out["wall_seconds"] = round(time.perf_counter() - t0, 1)
    return out


def _angle_diff(f, r) -> float:
    """Largest difference [deg] between the two runs' valve opening and closing angles."""
    import math

    worst = 0.0
    fa = [f.inlet.opening_angle, f.delivery.opening_angle, f.inlet.closing_angle, f.delivery.closing_angle]
    ra = [r.inlet.opening_angle, r.delivery.opening_angle, r.inlet.closing_angle, r.delivery.closing_angle]
    for a, b in zip(fa, ra):
        if (a is None) != (b is None):
            return 360.0
        if a is not None:
            d = abs(a - b) % (2 * math.pi)
            worst = max(worst, math.degrees(min(d, 2 * math.pi - d)))
    return round(worst, 4)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one case per valve type")
    ap.add_argument("--revolutions", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=3, help="fast runs per case (median counted)")
    a = ap.parse_args(argv)
    print(json.dumps(run(a.quick, a.revolutions, a.repeat), indent=2))


if __name__ == "__main__":
    main()
