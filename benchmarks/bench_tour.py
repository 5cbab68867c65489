"""Wall time of every command line of the README (its tour and its opening commands); prints one JSON object.

Run from the repository root: ``python benchmarks/bench_tour.py [--validate] [--pytest] [--only TEXT]``.
The command lines are read from README.md's fenced blocks (as tests/test_readme.py reads them) and run
in README order in one scratch folder, each a fresh process as a user types it (a later line reads what
an earlier one wrote: ``my_pump.toml``, ``my_data``). ``--validate`` adds the first opening command's
``valvelab validate`` and ``--pytest`` the second's ``pytest`` (the default test run, from the
repository root; both take minutes), without their ``pip install``. The JSON gives each line's wall
time, exit status and the machine's 1-minute load average before and after it, without which a time
on a shared machine means little. ``--save`` writes ``benchmarks/results_tour.json``, whose times the
README states beside each line (tests/test_readme.py checks them against it).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
RESULTS = ROOT / "benchmarks" / "results_tour.json"


def tour_lines(text: str | None = None) -> list[str]:
    """The ``valvelab`` command lines of README.md's unlabelled fenced blocks, comments removed, in order."""
    text = README.read_text() if text is None else text
    lines = []
    for lang, body in re.findall(r"```(\w*)\n(.*?)```", text, re.S):
        if lang:
            continue
        for line in body.splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            if line.startswith("valvelab "):
                lines.append(line)
    return lines


def _env() -> dict:
    bin_dir = Path(sys.executable).parent
    return {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}", "MPLBACKEND": "Agg",
            "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def timed(line: str, cwd: Path, logs: Path | None = None) -> dict:
    """Run one command line with bash in CWD; its wall time [s], exit status and load averages (its stdout and
    stderr appended to LOGS/tour.log when given)."""
    before = os.getloadavg()[0]
    t = time.perf_counter()
    p = subprocess.run(["bash", "-c", line], cwd=cwd, env=_env(), capture_output=True, text=True)
    took = time.perf_counter() - t
    if p.returncode:
        print(p.stderr[-2000:], file=sys.stderr)
    if logs is not None:
        with open(logs / "tour.log", "a") as f:
            f.write(f"$ {line}\n{p.stdout}\n--- stderr ---\n{p.stderr}\n")
    return {"wall_s": round(took, 2), "exit": p.returncode, "load_average_1min_before": round(before, 2),
            "load_average_1min_after": round(os.getloadavg()[0], 2)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--validate", action="store_true", help="also time the opening `valvelab validate`")
    ap.add_argument("--pytest", action="store_true", help="also time the opening `pytest` (the default run)")
    ap.add_argument("--only", help="only the tour lines containing this text")
    ap.add_argument("--logs", type=Path, help="folder to keep tour.log (every line's output) in")
    ap.add_argument("--save", action="store_true", help=f"write {RESULTS.relative_to(ROOT)}")
    args = ap.parse_args()
    lines = [x for x in tour_lines() if not args.only or args.only in x]
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "docs").symlink_to(ROOT / "docs")       # the tour names docs/examples/...
        jobs = [(x, tmp) for x in lines]
        jobs += [("valvelab validate", tmp)] if args.validate else []
        jobs += [("pytest", ROOT)] if args.pytest else []
        for i, (line, cwd) in enumerate(jobs, 1):
            print(f"[{i}/{len(jobs)}] {line}", file=sys.stderr, flush=True)
            rows[line] = timed(line, cwd, args.logs)
            print(f"    {rows[line]['wall_s']:.1f} s, exit {rows[line]['exit']}", file=sys.stderr, flush=True)
    out = {"benchmark": "tour", "cpus": os.cpu_count(), "command_lines": rows}
    text = json.dumps(out, indent=2)
    print(text)
    if args.save:                                   # a partial run (--only) updates its own lines
        old = json.loads(RESULTS.read_text())["command_lines"] if RESULTS.exists() else {}
        RESULTS.write_text(json.dumps({**out, "command_lines": {**old, **rows}}, indent=2) + "\n")


if __name__ == "__main__":
    main()
