"""Wall time of the discrepancy workflow per six-run dataset, over the confusion study's datasets, and its growth
with the runs per dataset.

Run on demand from the repository root::

    python benchmarks/bench_discrepancy.py [--workers 2] [--seeds 1] [--valves disc,reed] [--set library]
                                           [--no-scaling] [--save] [--figure PATH]
    python benchmarks/bench_discrepancy.py --from disc.json reed.json      # the times a confusion run recorded
    python benchmarks/bench_discrepancy.py --quick                          # two cases per valve: a look

prints one JSON object: per dataset (case, seed) the workflow's wall seconds, simulations and what it named;
the median and the largest against the targets (10 s median, 45 s at most, 2 cores); the load average before
and after (the machine is shared: a loaded machine's figures are not the targets'); and, unless
``--no-scaling``, the O-ring story (the delivery valve's compliant seat, R stated) on 4 to 12 runs (2 to 6
operating conditions, both valves measured at each) with a figure of wall seconds and simulations vs runs
(``--figure``, default docs/figures/discrepancy_cost_vs_runs.png). ``--save`` writes the object to
benchmarks/results_discrepancy.json. The fast path's compilation (or cache load) is done first and reported
separately.
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

HERE = Path(__file__).resolve().parent
TARGET_MEDIAN_S, TARGET_MAX_S = 10.0, 45.0
#: operating conditions of the scaling study: the thesis's three disc conditions (Table 5.4), then more
SCALING_CONDITIONS = [(593.0, 2.76e6), (743.0, 2.81e6), (591.0, 3.67e6), (650.0, 3.2e6), (820.0, 3.4e6),
                      (700.0, 2.5e6)]


def _stats(rows: list[dict]) -> dict:
    import numpy as np

    t = [r["workflow_seconds"] for r in rows if r.get("workflow_seconds") is not None]
    if not t:
        return {}
    med, mx = float(np.median(t)), float(max(t))
    cpu = [r["workflow_cpu_seconds"] for r in rows if r.get("workflow_cpu_seconds") is not None]
    return {"datasets": len(t), "median_seconds": med, "max_seconds": mx, "mean_seconds": float(np.mean(t)),
            "median_cpu_seconds": float(np.median(cpu)) if cpu else None, "max_cpu_seconds": max(cpu) if cpu else None,
            "note": "wall seconds on the machine as loaded (load_average per dataset); the CPU seconds of the "
                    "workflow and its workers do not depend on the load",
            "median_simulations": float(np.median([r["simulations"] for r in rows if r.get("simulations")])),
            "target_median_seconds": TARGET_MEDIAN_S, "target_max_seconds": TARGET_MAX_S,
            "median_within_target": med <= TARGET_MEDIAN_S, "max_within_target": mx <= TARGET_MAX_S}


#: --quick: these cases only, and the scaling study on 4 and 6 runs
QUICK_CASES = ("none", "piston_leakage")


def confusion_datasets(valves, seeds: int, set_: str, workers: int, progress: bool = True,
                       cases=None) -> list[dict]:
    """The workflow on each dataset of the confusion study (studies.discrepancy.confusion): its wall time."""
    from studies.discrepancy import confusion
    from studies.discrepancy.model_choice import choose
    from studies.discrepancy.workflow import Settings

    rows = []
    for valve in valves:
        sim = choose(valve_type=valve)
        pool = {"library": confusion.CASES[valve], "mismatch": confusion.MISMATCH[valve],
                "all": {**confusion.CASES[valve], **confusion.MISMATCH[valve]}}[set_]
        for case, spec in pool.items():
            if cases is not None and case not in cases:
                continue
            for seed in range(1, seeds + 1):
                r = confusion.run_case(case, spec, valve, seed, sim, Settings(workers=workers))
                rows.append({"valve": valve, "case": case, "seed": seed, "workflow_seconds": r["workflow_seconds"],
                             "workflow_cpu_seconds": r["workflow_cpu_seconds"], "simulations": r["simulations"],
                             "found": r["found"], "correct": r["correct"], "load_average": r["load_average"]})
                if progress:
                    sys.stderr.write(f"{valve} {case} seed {seed}: {r['workflow_seconds']:.1f} s, {r['simulations']} "
                                     f"simulations, named {r['found']}\n")
    return rows


def from_confusion(paths) -> list[dict]:
    """The per-dataset times a confusion run recorded (its JSON on stdout)."""
    rows = []
    for p in paths:
        d = json.loads(Path(p).read_text())
        for r in d["results"]:
            if r.get("workflow_seconds") is not None:
                rows.append({"valve": d["summary"].get("valve"), "case": r["case"], "seed": r["seed"],
                             "workflow_seconds": r["workflow_seconds"],
                             "workflow_cpu_seconds": r.get("workflow_cpu_seconds"), "simulations": r["simulations"],
                             "found": r["found"], "correct": r["correct"], "load_average": r.get("load_average")})
    return rows


def scaling(workers: int, figure: Path | None, progress: bool = True, largest: int | None = None) -> list[dict]:
    """Wall seconds and simulations of the O-ring story on 4-12 runs; a figure of both vs runs."""
    from lumped.model.effects import Applied
    from studies.discrepancy.model_choice import choose
    from studies.discrepancy.synth import Condition, Noise, synthesize
    from studies.discrepancy.workflow import Settings, Workflow

    sim = choose(model="thesis-disc")
    truth = (Applied.of("seat_compliance", "delivery", {"k_seat": 1.5e6}),)
    out = []
    for n in range(2, (largest or len(SCALING_CONDITIONS)) + 1):
        conds = [Condition(s, p, v, 0.013) for s, p in SCALING_CONDITIONS[:n] for v in ("inlet", "delivery")]
        runs, _ = synthesize(sim.simulate, "disc", conds, truth, Noise(), seed=0, workers=workers)
        t0 = time.perf_counter()
        res = Workflow(runs, sim.simulate, sim.library, Settings(workers=workers), progress=False,
                       context=sim.context).run().as_contract()
        wall = time.perf_counter() - t0
        out.append({"runs": len(conds), "conditions": n, "workflow_seconds": wall, "simulations": res["simulations"],
                    "found": res["effects_added"], "load_average": os.getloadavg()[0]})
        if progress:
            sys.stderr.write(f"scaling: {len(conds)} runs, {wall:.1f} s, {res['simulations']} simulations\n")
    if figure is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 3.8))
        x = [r["runs"] for r in out]
        ax.plot(x, [r["workflow_seconds"] for r in out], "o-", color="tab:blue", label="wall time")
        ax.set_xlabel("runs per dataset [-]")
        ax.set_ylabel("workflow wall time [s]", color="tab:blue")
        ax2 = ax.twinx()
        ax2.plot(x, [r["simulations"] for r in out], "s--", color="tab:red", label="simulations")
        ax2.set_ylabel("simulations [-]", color="tab:red")
        ax.set_title(f"discrepancy workflow, O-ring story, {workers} workers")
        fig.tight_layout()
        fig.savefig(figure, dpi=120)
        plt.close(fig)
    return out


def _shown(path: Path) -> str:
    """A path relative to the repository where it lies inside it."""
    try:
        return str(path.resolve().relative_to(HERE.parent))
    except ValueError:
        return str(path)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seeds", type=int, default=1, help="seeds per confusion case (default 1)")
    ap.add_argument("--valves", default="disc,reed")
    ap.add_argument("--set", default="library", choices=("library", "mismatch", "all"))
    ap.add_argument("--from", dest="from_", nargs="+", default=None, metavar="JSON",
                    help="take the per-dataset times from confusion runs' JSON instead of running them")
    ap.add_argument("--no-scaling", action="store_true")
    ap.add_argument("--quick", action="store_true",
                    help=f"only the cases {', '.join(QUICK_CASES)}, seed 1, and the scaling on 4 and 6 runs (a look, "
                         "not the targets)")
    ap.add_argument("--figure", default=None,
                    help="the scaling figure (default docs/figures/discrepancy_cost_vs_runs.png; none with --quick)")
    ap.add_argument("--save", action="store_true")
    args = ap.parse_args()

    from lumped.run.simulate import ensure_compiled

    load0 = os.getloadavg()
    compile_s = ensure_compiled()
    t0 = time.perf_counter()
    rows = from_confusion(args.from_) if args.from_ else confusion_datasets(
        args.valves.split(","), 1 if args.quick else args.seeds, args.set, args.workers,
        cases=QUICK_CASES if args.quick else None)
    figure = Path(args.figure) if args.figure else (None if args.quick else HERE.parent / "docs" / "figures" / "discrepancy_cost_vs_runs.png")
    scale = [] if args.no_scaling else scaling(args.workers, figure, largest=3 if args.quick else None)
    out = {
        "benchmark": "discrepancy workflow per six-run dataset of the confusion study (studies.discrepancy.confusion)",
        "source": ("confusion JSON: " + ", ".join(args.from_)) if args.from_ else
                  (f"run here: {args.valves}, " + (f"cases {', '.join(QUICK_CASES)}, seed 1 (--quick)" if args.quick
                                                   else f"{args.set} cases, seeds 1-{args.seeds}")),
        "workers": args.workers, "cpus": os.cpu_count(), "machine": platform.machine(),
        "compile_or_cache_seconds": compile_s, "load_average_before": load0, "load_average_after": os.getloadavg(),
        "seconds_in_all": time.perf_counter() - t0,
        # the load while the datasets ran (with --from: when the confusion study ran, not now)
        "load_average_datasets": [min(r["load_average"] for r in rows if r.get("load_average") is not None),
                                  max(r["load_average"] for r in rows if r.get("load_average") is not None)]
        if any(r.get("load_average") is not None for r in rows) else None,
        "summary": _stats(rows),
        "by_valve": {v: _stats([r for r in rows if r["valve"] == v]) for v in sorted({r["valve"] for r in rows})},
        "datasets": rows,
        "scaling": scale, "figure": None if (args.no_scaling or figure is None) else _shown(figure),
    }
    text = json.dumps(out, indent=1, default=float)
    print(text)
    if args.save:
        (HERE / "results_discrepancy.json").write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
