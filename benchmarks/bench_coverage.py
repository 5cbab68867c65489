"""Coverage and power of the real validation procedure on synthetic measurements of the thesis's pumps.

Run on demand from the repository root: ``python benchmarks/bench_coverage.py [--draws 2000] [--per-delta 400]
[--per-scramble 128] [--save]``; prints one JSON object. It runs the 12 thesis cases on the reference stepper,
their tolerance ladders and a joint Monte Carlo of 8 x ``per-scramble`` draws per rig (half of them the synthetic
truths, half the procedure's own Monte Carlo, bootstrapped per dataset), then ``draws`` synthetic datasets without
a model error (coverage) and ``per-delta`` datasets per injected model-form error (1-10 %) and pattern (power),
each through :func:`studies.validation.procedure.analyse` (studies/validation/coverage.py). Acceptance: every kind
of comparison "within" in 90-99 % of the datasets at the nominal 95.45 %. ``--save`` writes
benchmarks/results_coverage.json and the power curves to docs/figures/validation_power.png.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: acceptance: coverage of every kind of comparison at the nominal 95.45 %
COVERAGE_RANGE = (0.90, 0.99)
FIGURE = ROOT / "docs" / "figures" / "validation_power.png"
LABELS = {"validation": "one run, nominal inputs", "prediction": "one predicted run (calibrated)",
          "differences": "a difference between conditions", "rig_calibrated": "rig test, predicted runs together",
          "rig_nominal": "rig test, all runs, nominal inputs"}


def plot(result: dict, path: Path) -> Path:
    """Fraction of datasets with a model-form error found against the injected error, one panel per pattern."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.2), sharey=True, constrained_layout=True)
    titles = {"held_out": "error in every run outside the calibration condition",
              "common": "error common to every run (calibrated away)"}
    x = [0.0] + result["deltas_pct"]
    for ax, (pattern, title) in zip(axes, titles.items()):
        curves = result["power"][pattern]["detected"]
        for kind, label in LABELS.items():
            y = [1.0 - result["coverage"][kind]] + curves[kind]
            ax.plot(x, [100 * v for v in y], marker="o", ms=3, label=label)
        ax.axhline(80.0, color="k", lw=0.6, ls=":")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("injected model-form error in delivery [%]")
    axes[0].set_ylabel("datasets with a model-form error found [%]")
    axes[1].legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=8)
    fig.suptitle(f"Power of the validation procedure on synthetic thesis-pump data ({result['per_delta']} datasets per "
                 f"point; 80 % dotted)", fontsize=9)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=2000, help="synthetic datasets without a model error")
    ap.add_argument("--per-delta", type=int, default=400, help="synthetic datasets per injected error and pattern")
    ap.add_argument("--per-scramble", type=int, default=128, help="Monte Carlo points per Sobol scramble (8 scrambles)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--save", action="store_true", help="write benchmarks/results_coverage.json and the figure")
    args = ap.parse_args()
    from studies.sweeps.design.runner import Cluster
    from studies.validation import coverage

    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    cluster = Cluster()
    try:
        bench = coverage.prepare(per_scramble=args.per_scramble, progress=True, cluster=cluster)
    finally:
        cluster.close()
    t1 = time.perf_counter()
    res = coverage.study(bench, draws=args.draws, per_delta=args.per_delta, seed=args.seed, progress=True)
    t2 = time.perf_counter()
    lo, hi = COVERAGE_RANGE
    res.update(machine={"cpus": os.cpu_count(), "python": platform.python_version()},
               prepare_seconds=round(t1 - t0, 1), study_seconds=round(t2 - t1, 1),
               load_average_before_after=[round(load0, 2), round(os.getloadavg()[0], 2)],
               acceptance={"coverage_range": list(COVERAGE_RANGE),
                           "met": all(lo <= v <= hi for v in res["coverage"].values())})
    text = json.dumps(res, indent=2)
    if args.save:
        (ROOT / "benchmarks" / "results_coverage.json").write_text(text + "\n")
        plot(res, FIGURE)
    print(text)


if __name__ == "__main__":
    main()
