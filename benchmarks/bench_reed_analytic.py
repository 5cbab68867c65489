"""Speed of the analytic (exact Euler-Bernoulli) reed model; prints one JSON object.

Run from the repository root: ``python benchmarks/bench_reed_analytic.py [--repeat N]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from geometry import PRESETS, load_reed  # noqa: E402
from lumped.reed import euler_bernoulli as rb  # noqa: E402


def best_of(f, repeat):
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    out = {"benchmark": "reed_analytic", "repeat": args.repeat, "seconds": {}}
    for name in PRESETS:
        reed = load_reed(name)
        rb.reed_properties(reed)  # warm caches
        out["seconds"][name] = {
            "reed_properties": best_of(lambda: rb.reed_properties(reed), args.repeat),
            "natural_frequency": best_of(lambda: rb.natural_frequency(reed), args.repeat),
            "exact_stiffness": best_of(lambda: rb.exact_stiffness(reed), args.repeat),
            "three_section_stiffness": best_of(lambda: rb.three_section_stiffness(reed), args.repeat),
        }
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
