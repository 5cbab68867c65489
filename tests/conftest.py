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
