"""Wall time of ``valvelab validate`` with its validation uncertainty (full and --quick), and the coverage study.

Run on demand from the repository root: ``python benchmarks/bench_validation.py [--skip-full]
[--skip-quick] [--skip-coverage] [--draws 200] [--save]``; prints one JSON object. Each
validate runs as a user runs it (a subprocess, a fresh output folder, dask LocalCluster for the
full run's Monte Carlo), and its wall time includes the reed chain, the 12 pump cases, the
tolerance ladders, the Monte Carlo, the GCI studies and the files. The load average before and
after says how busy the machine was. The coverage study (studies/validation/coverage.py) checks
that the V&V 20 verdict means what it says on synthetic measurements: its acceptance is
"within" in 90-99 % of the draws without a model error, and a model-form error whose interval
holds the true error in at least 90 % with a hidden 3 % discharge-coefficient error.
``--save`` writes benchmarks/results_validation.json.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: acceptance limits (seconds) of the two runs on a 2-core machine
LIMITS = {"full": 600.0, "quick": 180.0}


def run_validate(quick: bool) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        argv = [sys.executable, "-m", "studies", "validate", "--out", str(Path(tmp) / "out"), "--json"]
        if quick:
            argv.insert(4, "--quick")
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        p = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True,
                           env={**os.environ, "PYTHONPATH": str(ROOT)})
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            return {"returncode": p.returncode, "stderr": p.stderr.strip().splitlines()[-1:]}
        obj = json.loads(p.stdout)
    u = obj.get("uncertainty", {})
    v = obj.get("validation", [])
    rv = obj.get("reed_validation", [])
    return {
        "wall_seconds": round(wall, 1), "limit_seconds": LIMITS["quick" if quick else "full"],
        "within_limit": wall <= LIMITS["quick" if quick else "full"],
        "uncertainty_wall_seconds": u.get("wall_seconds"), "draws": sum(u.get("draws", {}).values()),
        "worst_u_input_precision": u.get("worst_u_input_precision"),
        "pump_cases_within": sum(r["verdict"] == "within" for r in v), "pump_cases": len(v),
        "reed_model_form_errors": [f"{r['case']} {r['output']}" for r in rv if r["verdict"] != "within"],
        "area_metric_cc": obj.get("area_metric"),
        "load_average_before_after": [round(load0, 2), round(os.getloadavg()[0], 2)],
        "worst": {t: max(((r["case"], round(r["E"] / r["D"] * 100, 2), round(r["U_val"] / r["D"] * 100, 2),
                           r["verdict"]) for r in v if r["case"].startswith(t)), key=lambda x: abs(x[1]),
                         default=None) for t in ("disc", "reed")},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-full", action="store_true")
    ap.add_argument("--skip-quick", action="store_true")
    ap.add_argument("--skip-coverage", action="store_true")
    ap.add_argument("--draws", type=int, default=200)
    ap.add_argument("--save", action="store_true", help="write benchmarks/results_validation.json")
    args = ap.parse_args()
    out = {"machine": {"cpus": os.cpu_count(), "python": platform.python_version()}}
    if not args.skip_quick:
        print("validate --quick ...", file=sys.stderr, flush=True)
        out["validate_quick"] = run_validate(True)
    if not args.skip_full:
        print("validate ...", file=sys.stderr, flush=True)
        out["validate_full"] = run_validate(False)
    if not args.skip_coverage:
        from studies.validation.coverage import coverage_study

        print("coverage study ...", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        c = coverage_study(draws=args.draws, seed=0, inputs=True)
        c["wall_seconds"] = round(time.perf_counter() - t0, 1)
        c["acceptance"] = {"within_90_99": 0.90 <= c["within_fraction"] <= 0.99,
                           "bias_detected_and_contained_90": c["bias"]["model_form_error_and_contains_fraction"] >= 0.90}
        # the same hidden error with the synthetic generator's default delivery noise (0.3 %): mostly not seen
        c["at_synth_default_u_D"] = coverage_study(draws=args.draws, seed=1, u_D_rel=0.003)["bias"]
        out["coverage"] = c
    text = json.dumps(out, indent=2)
    if args.save:
        (ROOT / "benchmarks" / "results_validation.json").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
