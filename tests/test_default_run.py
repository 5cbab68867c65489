"""The default test run says what it leaves out (tests/conftest.py's summary line)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _pytest(*args: str) -> str:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    p = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", *args], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=300)
    return p.stdout


def test_deselected_slow_tests_are_counted_and_named():
    """The count printed is the number of slow tests collected with -m slow (serial and on two workers)."""
    target = "tests/test_fea_slow.py"
    listed = _pytest(target, "-m", "slow", "--collect-only", "-q", "-n", "0")
    n_slow = int(re.search(r"(\d+)(?:/\d+)? tests? collected", listed).group(1))
    assert n_slow > 0
    for workers in ("0", "2"):
        out = _pytest(target, "--collect-only", "-q", "-n", workers) if workers == "0" else \
            _pytest(target, "-q", "-n", workers)
        assert f"{n_slow} slow tests deselected; run them with pytest -m slow" in out, out[-600:]
    assert "slow tests deselected" not in _pytest(target, "-m", "slow", "--collect-only", "-q", "-n", "0")
