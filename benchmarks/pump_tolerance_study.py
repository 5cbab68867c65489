"""Tolerance study of the fast path: accuracy against the reference vs work, per setting.

Run on demand from the repository root: ``python benchmarks/pump_tolerance_study.py
[--random N] [--quick]``; prints one JSON object (progress on stderr). The reference
(``lumped.pump.simulate`` at its defaults, Radau rtol = atol = 1e-6) is run once per case:
the 12 validation cases of Tables 5.4 and 5.6 (five revolutions) and N random designs
(three revolutions; operating point, air, seat stiffness, spring, reed kappa and f1/f2
drawn by studies.random_designs, as in tests/test_pump_fast.py). Then the fast path runs every case under each
setting below, and the study reports per setting and valve type: Rosenbrock step
attempts per revolution (the machine-independent measure of work), CPU ms per
simulated second (median of two runs), the worst delivery deviation and the worst
opening/closing angle deviation from the reference. The defaults of ``lumped.pump_fast``
keep every case within 0.03 % (delivery) and 0.5 deg (angles, the bound of
tests/test_pump_fast.py); a looser rtol saves a few percent of the steps for a larger
deviation, and the margin is kept for designs outside these cases.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lumped import pump as reference  # noqa: E402
from lumped import pump_fast as fast  # noqa: E402
from studies.random_designs import random_design  # noqa: E402
from studies.thesis import experiments  # noqa: E402

# (name, attributes of lumped.pump_fast to set, simulate keyword arguments)
SETTINGS = [
    ("default", {}, {}),
    ("rtol 3e-4", {}, {"rtol": 3e-4}),
    ("rtol 3e-3", {}, {"rtol": 3e-3}),
    ("contact velocity x1 (disc)", {"CONTACT_ATOL": {"disc": 1.0, "reed": 1.0}}, {}),
    ("contact velocity x100 (both)", {"CONTACT_ATOL": {"disc": 100.0, "reed": 100.0}}, {}),
    ("contact opening x100", {"CONTACT_POSITION_ATOL": 100.0}, {}),
    ("free velocity x1000", {"FREE_VELOCITY_ATOL": 1000.0}, {}),
]


def _random_case(rng, valve):
    speed, load, air, model = random_design(rng, valve)
    return dict(valve=valve, speed_rpm=speed, load_pressure=load, air_content=air, params=model, revolutions=3)


def _angle_error(a, b):
    worst = 0.0
    for x, y in zip(a.opening_angle + a.closing_angle, b.opening_angle + b.closing_angle):
        if (x is None) != (y is None):
            return math.inf
        if x is not None:
            d = abs(x - y) % (2 * math.pi)
            worst = max(worst, math.degrees(min(d, 2 * math.pi - d)))
    return worst


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--random", type=int, default=10, help="random designs (half disc, half reed)")
    ap.add_argument("--quick", action="store_true", help="first validation case of each valve, 2 random designs")
    args = ap.parse_args()
    cases = [dict(valve=c["valve"], speed_rpm=c["speed_rpm"], load_pressure=c["load_pressure"],
                  air_content=c["air_content"], params=None, revolutions=5) for c in experiments()]
    n_random = 2 if args.quick else args.random
    if args.quick:
        cases = [cases[0], cases[6]]
    rng = np.random.default_rng(2026)
    cases += [_random_case(rng, ("disc", "reed")[i % 2]) for i in range(n_random)]

    steps = []
    orig = fast._solver

    def counting(*a):
        r = orig(*a)
        steps.append(int(r[10]))  # step attempts that reached the error test (rejections included)
        return r

    fast._solver = counting
    refs = []
    for i, c in enumerate(cases):
        print(f"reference {i + 1}/{len(cases)}", file=sys.stderr, flush=True)
        refs.append(reference.simulate(**c))
    fast.simulate("disc", 593.0, 2.76e6, revolutions=2)  # compile or load the cache first
    out = {"benchmark": "pump_tolerance_study", "cases": len(cases), "random_designs": n_random, "settings": []}
    for name, attrs, kw in SETTINGS:
        saved = {k: getattr(fast, k) for k in attrs}
        for k, v in attrs.items():
            setattr(fast, k, v)
        per = {"disc": [], "reed": []}
        for c, r in zip(cases, refs):
            runs = []
            for _ in range(2):
                steps.clear()
                runs.append((fast.simulate(**c, **kw), sum(steps)))
            f, n_steps = runs[0]
            per[c["valve"]].append(dict(
                steps_per_rev=n_steps / f.revolutions,
                ms=statistics.median(x.cpu_seconds / x.simulated_seconds for x, _ in runs) * 1e3,
                delivery=abs(f.delivery_per_rev / r.delivery_per_rev - 1), angle=_angle_error(f, r)))
        for k, v in saved.items():
            setattr(fast, k, v)
        row = {"setting": name}
        for valve, rows in per.items():
            row[valve] = {"steps_per_revolution": round(statistics.mean(x["steps_per_rev"] for x in rows), 1),
                          "cpu_ms_per_simulated_second": round(statistics.mean(x["ms"] for x in rows), 2),
                          "worst_delivery_deviation": float(f"{max(x['delivery'] for x in rows):.3g}"),
                          "worst_angle_deviation_deg": round(max(x["angle"] for x in rows), 4)}
        print(json.dumps(row), file=sys.stderr, flush=True)
        out["settings"].append(row)
    fast._solver = orig
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
