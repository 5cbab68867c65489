"""Wall time of ``valvelab validate`` (without and with its validation uncertainty, and --quick), what it finds
(the detectable errors, the calibrated air content, the verdicts) and its tables against the saved ones.

Run on demand from the repository root: ``python benchmarks/bench_validation.py [--skip-plain]
[--skip-full] [--skip-quick] [--before REV] [--save]``; prints one JSON object. Each validate runs as a user runs it (a subprocess, a fresh output folder, dask
LocalCluster for the full run's Monte Carlo), and its wall time includes the reed chain, the 12
pump cases, the tolerance ladders, the Monte Carlo, the GCI studies and the files; ``plain`` is
``validate --no-uncertainty`` (limit 30 s). The load average before and after says how busy the
machine was. Each run's Markdown tables are compared cell by cell with the ones saved in
benchmarks/validate_before/ (written by the code before the steady-state stop and warm start,
commit 52bf526): the cells that differ are listed, except the measured seconds, the revolutions run,
the columns that did not exist then, validation.md, whose budget is computed differently since (the
pooled repeatability, a Monte Carlo interval), and reed_validation.md, whose columns and words changed. ``--before REV``: the same runs with the code of
git revision REV (a temporary worktree; its numba cache compiled first, not timed), in the same
session. The procedure's coverage and power are measured by benchmarks/bench_coverage.py.
``--save`` writes benchmarks/results_validation.json and copies the full run's validation.png (E with
U_val per case) to docs/figures/validation_e_uval.png.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
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
#: tables computed by another method, or with other columns and words, since the saved ones were written (not
#: compared): validation.md's budget (pooled repeatability, Monte Carlo intervals), reed_validation.md's columns
METHOD_CHANGED = ("validation.md", "reed_validation.md")
FIGURE = ROOT / "docs" / "figures" / "validation_e_uval.png"


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
        if name in METHOD_CHANGED:
            continue
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


def run_validate(quick: bool, plain: bool = False, tree: Path = ROOT, compare: bool = True, extra=(),
                 figure: Path | None = None) -> dict:
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
        if figure is not None and (Path(tmp) / "out" / "validation.png").is_file():
            shutil.copyfile(Path(tmp) / "out" / "validation.png", figure)
    if plain:
        return {"wall_seconds": round(wall, 1), "limit_seconds": LIMITS["plain"], "within_limit": wall <= LIMITS["plain"],
                "revolutions": [c.get("revolutions") for c in obj.get("cases", [])],
                "load_average_before_after": [round(load0, 2), round(os.getloadavg()[0], 2)], "tables": tables}
    return {"wall_seconds": round(wall, 1), "limit_seconds": LIMITS["quick" if quick else "full"],
            "within_limit": wall <= LIMITS["quick" if quick else "full"],
            "load_average_before_after": [round(load0, 2), round(os.getloadavg()[0], 2)], "tables": tables,
            "files": len(obj.get("files", [])), **findings(obj)}


def findings(obj: dict) -> dict:
    """What a run of validate found: the detectable errors, the calibrated values and every verdict."""
    u = obj.get("uncertainty", {})
    v = obj.get("validation", [])
    rv = obj.get("reed_validation", [])

    def pct(r):
        return [r["case"], round(r["E"] / r["D"] * 100, 2), round(r["U_val"] / r["D"] * 100, 2), r["verdict"]]

    return {
        "uncertainty_wall_seconds": u.get("wall_seconds"), "draws": sum(u.get("draws", {}).values()),
        "worst_u_input_precision": u.get("worst_u_input_precision"),
        "detectable_error_pct": {rig: {k: d.get(k) for k in ("rig", "case", "uncalibrated_rig", "uncalibrated_case")}
                                 for rig, d in obj.get("detectable_error", {}).items()},
        "calibration": [{k: e.get(k) for k in ("parameter", "rig", "value", "u", "prior", "prior_u", "runs")}
                        for e in obj.get("calibration", [])],
        "predictions": [pct(r) + [bool(r.get("suspect"))] for r in obj.get("prediction", [])],
        "rig_tests": [[t["case"], round(t["E"], 2), round(t["U_val"], 2), t["verdict"], round(t["chi2_p"], 3)]
                      for t in obj.get("rig_tests", [])],
        "differences_within": sum(r["verdict"] == "within" for r in obj.get("differences", [])),
        "differences": len(obj.get("differences", [])),
        "repeatability_pct": (obj.get("repeatability") or {}).get("s_pct"),
        "repeatability_dof": (obj.get("repeatability") or {}).get("dof"),
        "pump_cases_within": sum(r["verdict"] == "within" for r in v), "pump_cases": len(v),
        "reed_model_form_errors": [f"{r['case']} {r['output']}" for r in rv if r["verdict"] != "within"],
        "area_metric_cc": obj.get("area_metric"),
        "worst": {t: max((pct(r) for r in v if r["case"].startswith(t)), key=lambda x: abs(x[1]), default=None)
                  for t in ("disc", "reed")},
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
            # the module moved (lumped.cycle before the subpackages, lumped.run.simulate since)
            compile_it = ("try:\n    from lumped.run.simulate import ensure_compiled\nexcept ImportError:\n"
                          "    from lumped.cycle import ensure_compiled\nensure_compiled()")
            subprocess.run([sys.executable, "-c", compile_it],
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
    ap.add_argument("--save", action="store_true",
                    help="write benchmarks/results_validation.json and docs/figures/validation_e_uval.png")
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
        out["validate_full"] = run_validate(False, figure=FIGURE if args.save else None)
    text = json.dumps(out, indent=2)
    if args.save:
        (ROOT / "benchmarks" / "results_validation.json").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
