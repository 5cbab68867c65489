"""Start-up time of the command line, and the estimates long commands announce; prints one JSON object.

Run from the repository root: ``python benchmarks/bench_cli.py [--repeat N] [--estimates]``. Each
call is a fresh process, as a user's is (``python -m studies ARGS``); the JSON gives the median and
the worst wall time of ``valvelab --help`` and of every command's ``--help`` over N repeats, the heavy
libraries each one imported (none expected: the command modules import numba, scipy, matplotlib,
dask, scikit-fem and gmsh only when they run), the target (1 s) and the machine's load average,
without which a time on a shared machine means little.

``--estimates`` also runs the README tour's long commands once each in a scratch folder and gives the
estimate each announced on stderr (studies.costs) beside the wall time it took.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: the start-up target of every ``--help`` [s]
TARGET_S = 1.0
#: libraries that argument parsing must not import (each costs from 0.2 s to several seconds)
HEAVY = ("numba", "scipy", "matplotlib", "dask", "distributed", "skfem", "gmsh", "pandas", "lumped", "fea")

#: runs one command line in-process and prints which heavy libraries it imported (the timed call is the
#: plain ``python -m studies``; this second call only reports imports)
PROBE = """
import sys
from studies.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print("IMPORTED", ",".join(m for m in {heavy!r} if m in sys.modules))
"""


def command_lines() -> list[list[str]]:
    """``--help`` alone and after every command."""
    from studies.cli import COMMANDS

    return [["--help"]] + [[name, "--help"] for name in COMMANDS]


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def wall(argv: list[str]) -> float:
    """Wall time [s] of ``python -m studies ARGV`` in a fresh process."""
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "studies", *argv], env=_env(), capture_output=True, check=True)
    return time.perf_counter() - t


def imported(argv: list[str]) -> list[str]:
    """The heavy libraries a command line imports."""
    p = subprocess.run([sys.executable, "-c", PROBE.format(heavy=HEAVY), *argv], env=_env(), capture_output=True,
                       text=True, check=True)
    line = next(x for x in p.stdout.splitlines() if x.startswith("IMPORTED"))
    return [m for m in line.split(" ", 1)[1].split(",") if m]


#: the README tour's long command lines (docs/examples paths from the repository root)
LONG = ("table 5.4", "pump --model thesis-ball --uncertainty", "check prototype --out check-prototype",
        "check prototype --dynamics --quick", "sweep docs/examples/sweep_quick.toml --out sweep-quick",
        "sensitivity docs/examples/sensitivity_quick.toml --out sens-quick",
        "optimize docs/examples/optimize_quick.toml --out opt-quick")
ABOUT = re.compile(r"; about (\d+(?:\.\d+)?) (s|min|h) on two cores")


def estimates() -> dict:
    """Each long command line's announced estimate and wall time [s], run in a scratch folder."""
    import tempfile

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for line in LONG:
            argv = [a.replace("docs/examples", str(ROOT / "docs" / "examples")) for a in line.split()]
            t = time.perf_counter()
            p = subprocess.run([sys.executable, "-m", "studies", *argv], env=_env(), cwd=tmp, capture_output=True,
                               text=True)
            took = time.perf_counter() - t
            said = [m for m in ABOUT.finditer(p.stderr)]
            est = sum(float(m.group(1)) * {"s": 1, "min": 60, "h": 3600}[m.group(2)] for m in said) if said else None
            out["valvelab " + line] = {"exit": p.returncode, "wall_s": round(took, 1), "estimate_s": est,
                                       "ratio": None if not est else round(took / est, 2),
                                       "load_average_1min": round(os.getloadavg()[0], 2)}
            print(f"{line}: {took:.1f} s (estimated {est} s)", file=sys.stderr, flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=5, help="fresh processes per command line (default 5)")
    ap.add_argument("--estimates", action="store_true", help="also run the long commands against their estimates")
    args = ap.parse_args()
    load_before = os.getloadavg()
    bare = statistics.median(_bare() for _ in range(args.repeat))
    rows = {}
    for argv in command_lines():
        times = [wall(argv) for _ in range(args.repeat)]
        rows[" ".join(["valvelab", *argv])] = {"median_s": round(statistics.median(times), 3),
                                               "max_s": round(max(times), 3), "imports": imported(argv)}
        print(f"{' '.join(argv)}: {statistics.median(times):.3f} s", file=sys.stderr, flush=True)
    worst = max(r["median_s"] for r in rows.values())
    extra = {"estimates": estimates()} if args.estimates else {}
    print(json.dumps({
        "benchmark": "cli_startup", "repeat": args.repeat, "target_s": TARGET_S,
        "python_startup_s": round(bare, 3),
        "worst_median_s": worst, "met": worst < TARGET_S,
        "heavy_imports": sorted({m for r in rows.values() for m in r["imports"]}),
        "load_average": {"before": [round(x, 2) for x in load_before],
                         "after": [round(x, 2) for x in os.getloadavg()]},
        "command_lines": rows, **extra,
    }, indent=2))


def _bare() -> float:
    """Wall time [s] of a bare ``python -c pass``: the interpreter's own share of every figure."""
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
    return time.perf_counter() - t


if __name__ == "__main__":
    main()
