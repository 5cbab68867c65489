import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

# plots are written headless in tests
os.environ.setdefault("MPLBACKEND", "Agg")

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def cli(tmp_path):
    """Run ``valvelab ARGS`` as a user would (a subprocess), from a scratch folder.

    Returns (returncode, stdout, stderr); with ``--json`` in ARGS also the parsed
    object as a 4th item (None if stdout is not exactly one JSON object).
    """

    def run(*args, cwd=None, timeout=600):
        env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        p = subprocess.run(
            [sys.executable, "-m", "studies", *map(str, args)],
            cwd=cwd or tmp_path, env=env, capture_output=True, text=True, timeout=timeout,
        )
        if "--json" in args:
            try:
                obj = json.loads(p.stdout)
            except json.JSONDecodeError:
                obj = None
            return p.returncode, p.stdout, p.stderr, obj
        return p.returncode, p.stdout, p.stderr

    return run


@pytest.fixture(scope="module")
def client():
    """A dask LocalCluster of two single-threaded worker processes (one per module that asks)."""
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=40)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


# --------------------------------------------------------------------------- what the default run leaves out
#: the key a worker's count of deselected slow tests travels under to the controller (pytest-xdist)
_SLOW_KEY = "valvelab_slow_deselected"


def pytest_configure(config):
    config._valvelab_slow_deselected = 0


def pytest_deselected(items):
    """Count the slow tests ``-m 'not slow'`` (the default, pyproject.toml) leaves out."""
    if items:
        config = items[0].config
        config._valvelab_slow_deselected += sum(1 for it in items if it.get_closest_marker("slow") is not None)


def pytest_sessionfinish(session):
    """An xdist worker hands its count to the controller (every worker collects every test)."""
    if hasattr(session.config, "workeroutput"):
        session.config.workeroutput[_SLOW_KEY] = session.config._valvelab_slow_deselected


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    """The controller keeps the workers' count (each saw the same collection)."""
    n = getattr(node, "workeroutput", {}).get(_SLOW_KEY, 0)
    node.config._valvelab_slow_deselected = max(node.config._valvelab_slow_deselected, n)


def pytest_terminal_summary(terminalreporter, config):
    """Say what the run left out and how to run it."""
    n = config._valvelab_slow_deselected
    if n and "not slow" in (config.option.markexpr or "") and not hasattr(config, "workeroutput"):
        terminalreporter.write_line(f"{n} slow test{'s' if n > 1 else ''} deselected; run them with pytest -m slow "
                                    "(long convergence studies and full validation runs)")
