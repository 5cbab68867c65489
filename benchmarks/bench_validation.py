"""Wall time of ``valvelab validate`` (without and with its validation uncertainty, and --quick), its tables
against the saved ones, and the coverage study.

Run on demand from the repository root: ``python benchmarks/bench_validation.py [--skip-plain]
[--skip-full] [--skip-quick] [--skip-coverage] [--before REV] [--draws 200] [--save]``; prints one
JSON object. Each validate runs as a user runs it (a subprocess, a fresh output folder, dask
LocalCluster for the full run's Monte Carlo), and its wall time includes the reed chain, the 12
pump cases, the tolerance ladders, the Monte Carlo, the GCI studies and the files; ``plain`` is
``validate --no-uncertainty`` (limit 30 s). The load average before and after says how busy the
machine was. Each run's Markdown tables are compared cell by cell with the ones saved in
benchmarks/validate_before/ (written by the code before the steady-state stop and warm start,
commit 52bf526): the cells that differ are listed, except the measured seconds, the revolutions run
and the columns that did not exist then. ``--before REV``: the same runs with the code of git
revision REV (a temporary worktree; its numba cache compiled first, not timed), in the same session.
The coverage study (studies/validation/coverage.py) checks
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

#: acceptance limits (seconds) of the runs on a 2-core machine
LIMITS = {"full": 600.0, "quick": 180.0, "plain": 30.0}
SAVED = ROOT / "benchmarks" / "validate_before"
#: columns whose cells are measured or counted, not computed answers
UNCOMPARED = ("seconds [s]", "revolutions", "cycle_change")


def _tables(text: str) -> list[list[dict]]:
    """The Markdown tables of a file as lists of {column: cell} rows."""
    out, header = [], None
    for line in text.splitlines():
        if not line.startswith("|"):
            header = None
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if header is None:
            header, rows = cells, []
            out.append(rows)
        elif not all(set(c) <= set("-: ") for c in cells):
            rows.append(dict(zip(header, cells)))
    return out


def compare_tables(folder: Path, prefix: str) -> dict:
    """Cells of ``folder``'s tables that differ from the saved ones (``prefix``: nu_ or full_)."""
    diffs, compared = [], 0
    for saved in sorted(SAVED.glob(f"{prefix}*.md")):
        name = saved.name[len(prefix):]
        new = folder / name
        if not new.is_file():
            diffs.append({"file": name, "missing": True})
            continue
        for t_old, t_new in zip(_tables(saved.read_text()), _tables(new.read_text())):
            for i, (a, b) in enumerate(zip(t_old, t_new)):
                for col, va in a.items():
                    if col in UNCOMPARED or col not in b:
                        continue
                    compared += 1
                    if b[col] != va:
                        diffs.append({"file": name, "row": i, "column": col, "before": va, "after": b[col]})
    return {"cells_compared": compared, "cells_differing": len(diffs), "differences": diffs}


def run_validate(quick: bool, plain: bool = False, tree: Path = ROOT, compare: bool = True, extra=()) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        argv = [sys.executable, "-m", "studies", "validate", "--out", str(Path(tmp) / "out"), "--json", *extra]
        if quick:
            argv.insert(4, "--quick")
        if plain:
            argv.insert(4, "--no-uncertainty")
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        p = subprocess.run(argv, cwd=tree, capture_output=True, text=True,
                           env={**os.environ, "PYTHONPATH": str(tree)})
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            return {"returncode": p.returncode, "stderr": p.stderr.strip().splitlines()[-1:]}
        obj = json.loads(p.stdout)
        tables = compare_tables(Path(tmp) / "out", "nu_" if plain else "full_") if compare and not quick else None
    if plain:
        return {"wall_seconds": round(wall, 1), "limit_seconds": LIMITS["plain"], "within_limit": wall <= LIMITS["plain"],
                "revolutions": [c.get("revolutions") for c in obj.get("cases", [])],
                "load_average_before_after": [round(load0, 2), round(os.getloadavg()[0], 2)], "tables": tables}
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
        "load_average_before_after": [round(load0, 2), round(os.getloadavg()[0], 2)], "tables": tables,
        "worst": {t: max(((r["case"], round(r["E"] / r["D"] * 100, 2), round(r["U_val"] / r["D"] * 100, 2),
                           r["verdict"]) for r in v if r["case"].startswith(t)), key=lambda x: abs(x[1]),
                         default=None) for t in ("disc", "reed")},
    }


def scaling() -> list[dict]:
    """validate --no-uncertainty --skip-reed-chain on 6 (disc) and 12 cases: the cost of the pump cases alone."""
    out = []
    for cases, extra in ((6, ("--skip-reed-chain", "--valve", "disc")), (12, ("--skip-reed-chain",))):
        r = run_validate(False, plain=True, compare=False, extra=extra)
        out.append({"cases": cases, "command": "valvelab validate --no-uncertainty " + " ".join(extra),
                    "wall_seconds": r.get("wall_seconds"), "load_average_before_after": r.get("load_average_before_after")})
    return out


def _before(rev: str, plain: bool, full: bool) -> dict:
    """The plain and full runs with the code of ``rev``, in a temporary git worktree."""
    out = {"revision": rev}
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp) / "tree"
        subprocess.run(["git", "worktree", "add", "--detach", str(tree), rev], cwd=ROOT, check=True,
                       capture_output=True)
        try:
            print(f"compiling the fast path of {rev} ...", file=sys.stderr, flush=True)
            subprocess.run([sys.executable, "-c", "from lumped.run.simulate import ensure_compiled; ensure_compiled()"],
                           cwd=tree, env={**os.environ, "PYTHONPATH": str(tree)}, check=True, capture_output=True)
            if plain:
                print(f"validate --no-uncertainty ({rev}) ...", file=sys.stderr, flush=True)
                out["validate_plain"] = run_validate(False, plain=True, tree=tree, compare=False)
            if full:
                print(f"validate ({rev}) ...", file=sys.stderr, flush=True)
                out["validate_full"] = run_validate(False, tree=tree, compare=False)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT, capture_output=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-plain", action="store_true", help="skip validate --no-uncertainty")
    ap.add_argument("--skip-full", action="store_true")
    ap.add_argument("--before", metavar="REV", default=None,
                    help="also time the same runs with the code of git revision REV (e.g. 52bf526)")
    ap.add_argument("--skip-quick", action="store_true")
    ap.add_argument("--skip-coverage", action="store_true")
    ap.add_argument("--draws", type=int, default=200)
    ap.add_argument("--save", action="store_true", help="write benchmarks/results_validation.json")
    args = ap.parse_args()
    out = {"machine": {"cpus": os.cpu_count(), "python": platform.python_version()}}
    if not args.skip_plain:
        print("validate --no-uncertainty ...", file=sys.stderr, flush=True)
        out["validate_plain"] = run_validate(False, plain=True)
        print("validate --no-uncertainty --skip-reed-chain on 6 and 12 cases ...", file=sys.stderr, flush=True)
        out["scaling"] = scaling()
    if args.before:
        out["before"] = _before(args.before, not args.skip_plain, not args.skip_full)
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
