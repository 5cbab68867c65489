"""docs/discrepancy.md stays true: its command lines run as written, its tables are what the saved runs give.

Command lines are taken from the page's unlabelled fenced blocks (not copied here) and run in a scratch
folder in page order. A line whose comment says ``slow`` (minutes to hours: the workflow, the confusion
studies) runs with ``pytest -m slow``; the others (printing the tables of the saved confusion runs in
``benchmarks/confusion/``) run by default, and what they print must be on the page.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = (ROOT / "docs" / "discrepancy.md").read_text()
BLOCKS = re.findall(r"```(\w*)\n(.*?)```", PAGE, re.S)
BIN = Path(sys.executable).parent


def _lines() -> list[tuple[str, bool]]:
    """(command, slow) for each command line of the page's unlabelled blocks."""
    out = []
    for lang, body in BLOCKS:
        if lang:
            continue
        for raw in body.splitlines():
            comment = raw.split("#", 1)[1] if "#" in raw else ""
            line = re.sub(r"\s+#.*$", "", raw).strip()
            if line.startswith(("valvelab ", "python -m ", "python benchmarks/")):
                out.append((line, "slow" in comment))
    return out


LINES = _lines()


def _run(line: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ['PATH']}", "MPLBACKEND": "Agg",
           "PYTHONPATH": str(ROOT)}
    return subprocess.run(["bash", "-c", line], cwd=cwd, capture_output=True, text=True, env=env, timeout=6 * 3600)


def _scratch(tmp_path: Path) -> Path:
    for name in ("docs", "benchmarks"):
        (tmp_path / name).symlink_to(ROOT / name)
    return tmp_path


def test_the_page_has_quick_and_slow_commands():
    assert any(not s for _, s in LINES) and any(s for _, s in LINES)


def test_quick_commands_run_and_print_what_the_page_shows(tmp_path):
    """The tables of the saved confusion runs: each summary line and table row printed is on the page."""
    cwd = _scratch(tmp_path)
    for line, slow in LINES:
        if slow:
            continue
        r = _run(line, cwd)
        assert r.returncode == 0, f"{line!r} exited {r.returncode}:\n{r.stderr[-2000:]}"
        if "--tables" in line:
            for out in r.stdout.splitlines():
                if out.strip():
                    assert out.strip() in PAGE, f"{line!r} prints a line the page lacks: {out!r}"


@pytest.mark.slow
def test_slow_commands_run(tmp_path):
    cwd = _scratch(tmp_path)
    for line, slow in LINES:
        if slow:
            r = _run(line, cwd)
            assert r.returncode == 0, f"{line!r} exited {r.returncode}:\n{r.stderr[-2000:]}"
