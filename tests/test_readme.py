"""README.md stays true: its two opening commands, its figures and its examples.

Command lines are taken from README.md's fenced blocks (not copied here) and run in a
scratch folder, in README order (a later line may read what an earlier one wrote); lines
that take minutes (the validation, FEA tables, the discrepancy demo, benchmarks) run with
``pytest -m slow``. The Python block is executed as written.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
BLOCKS = re.findall(r"```(\w*)\n(.*?)```", README, re.S)
BIN = Path(sys.executable).parent


def _command_lines() -> list[str]:
    lines = []
    for lang, body in BLOCKS:
        if lang:
            continue
        for line in body.splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            if line.startswith(("valvelab ", "python -m ", "python benchmarks/")):
                lines.append(line)
    return lines


COMMANDS = _command_lines()
#: what takes minutes or belongs to the benchmarks: run with -m slow
SLOW = re.compile(r"^valvelab (validate|check|modes|seat|table [35]\.|discrepancy|synth|sensitivity|optimize)|"
                  r"--fidelity solid|"
                  r"^python benchmarks/|studies\.discrepancy\.confusion")


def _run(line: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ['PATH']}", "MPLBACKEND": "Agg",
           "PYTHONPATH": str(ROOT)}
    line = line.replace("python benchmarks/", f"python {ROOT}/benchmarks/")
    return subprocess.run(["bash", "-c", line], cwd=cwd, capture_output=True, text=True, env=env, timeout=3000)


def test_opening_commands_and_ci_agree():
    install_run, install_test = [b.strip() for lang, b in BLOCKS[:2]]
    assert install_run.endswith("pip install -e . && valvelab validate")
    assert install_test.endswith('pip install -e ".[test]" && pytest')
    ci = (ROOT / ".ci" / "run").read_text()
    assert install_test in ci, ".ci/run must call exactly the README's test command"


def test_figures_are_generated_from_the_benchmark_json():
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "readme_figures.py"), "--check"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_performance_page_is_generated_from_the_benchmark_json():
    """docs/performance.md holds what benchmarks/performance_doc.py makes of the results JSON."""
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "performance_doc.py"), "--check"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_there_are_examples_to_run():
    assert any(not SLOW.search(c) for c in COMMANDS) and any(SLOW.search(c) for c in COMMANDS)


def _check(lines, tmp_path):
    (tmp_path / "docs").symlink_to(ROOT / "docs")      # the README's examples name docs/examples/...
    for line in lines:
        r = _run(line, tmp_path)
        assert r.returncode == 0, f"{line!r} exited {r.returncode}:\n{r.stderr[-2000:]}"


def test_quick_command_examples_run(tmp_path):
    _check([c for c in COMMANDS if not SLOW.search(c)], tmp_path)


@pytest.mark.slow
def test_slow_command_examples_run(tmp_path):
    _check([c for c in COMMANDS if SLOW.search(c)], tmp_path)


def test_python_example_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    (code,) = [b for lang, b in BLOCKS if lang == "python"]
    exec(compile(code, "README.md", "exec"), {})


#: a wall time at the end of a command line's comment: ``# ... 25 s`` or ``# ... 1.5 min``
STATED = re.compile(r"#.*?(\d+(?:\.\d+)?) (s|min)\)?\s*$")


def _stated_times() -> dict:
    """{command line (comment removed): the wall time its comment states [s]} for the README's command lines."""
    out = {}
    for lang, body in BLOCKS:
        if lang:
            continue
        for raw in body.splitlines():
            line = re.sub(r"\s+#.*$", "", raw).strip()
            if line.startswith("valvelab "):
                m = STATED.search(raw)
                out[line] = None if m is None else float(m.group(1)) * (60.0 if m.group(2) == "min" else 1.0)
    return out


def test_every_tour_line_states_the_wall_time_measured():
    """Each ``valvelab`` line of the tour says how long it takes, within 1.5x of the wall time
    benchmarks/bench_tour.py measured (benchmarks/results_tour.json, with its load average), and the
    opening command's validation time within 1.5x of benchmarks/results_validation.json's."""
    import json

    measured = json.loads((ROOT / "benchmarks" / "results_tour.json").read_text())["command_lines"]
    stated = _stated_times()
    assert [line for line, t in stated.items() if t is None] == [], "tour lines without a time"
    for line, t in stated.items():
        assert line in measured, f"{line!r} not in results_tour.json: python benchmarks/bench_tour.py --only ... --save"
        wall = measured[line]["wall_s"]
        assert measured[line]["exit"] == 0, line
        assert wall / 1.5 <= t <= wall * 1.5, f"{line!r}: README says {t:g} s, measured {wall:g} s"
    full = json.loads((ROOT / "benchmarks" / "results_validation.json").read_text())["validate_full"]["wall_seconds"]
    m = re.search(r"takes\s+about\s+(\d+)\s+min\s+on\s+two\s+cores", README)
    assert m, "the opening command's time"
    assert full / 1.5 <= float(m.group(1)) * 60.0 <= full * 1.5
    tests = re.search(r"the\s+default\s+run:\s+(\d+)\s+min\s+on\s+two\s+cores", README)
    assert tests and "pytest" in measured, "the opening test command's time"
    assert measured["pytest"]["wall_s"] / 1.5 <= float(tests.group(1)) * 60.0 <= measured["pytest"]["wall_s"] * 1.5
