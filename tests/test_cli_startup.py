"""The command line starts fast: ``--help`` imports no numerical library (benchmarks/bench_cli.py times it).

A command module imports numba, scipy, matplotlib, dask, scikit-fem, gmsh and the model layers
(``lumped``, ``fea``) inside ``run``; importing one of them while the parser is built costs from
0.2 s to several seconds per call (``valvelab --help`` once took 10 s).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from studies.cli import COMMANDS

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "scipy", "matplotlib", "dask", "distributed", "skfem", "gmsh", "pandas", "lumped", "fea")

PROBE = """
import sys
from studies.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print("IMPORTED", ",".join(m for m in {heavy!r} if m in sys.modules))
"""


def _imported(*argv: str) -> tuple[list[str], str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    p = subprocess.run([sys.executable, "-c", PROBE.format(heavy=HEAVY), *argv], env=env, capture_output=True,
                       text=True, timeout=120)
    line = next(x for x in p.stdout.splitlines() if x.startswith("IMPORTED"))
    return [m for m in line.split(" ", 1)[1].split(",") if m], p.stdout


def test_top_level_help_imports_no_command_module():
    heavy, out = _imported("--help")
    assert heavy == []
    for name in COMMANDS:   # every command listed with its help line, read without importing it
        assert f"    {name} " in out or f"    {name}\n" in out
    assert "%%" not in out


@pytest.mark.parametrize("command", list(COMMANDS))
def test_command_help_imports_nothing_heavy(command):
    heavy, out = _imported(command, "--help")
    assert heavy == [], f"valvelab {command} --help imported {heavy}"
    assert "%%" not in out       # argparse's % escaping shown literally (check's description once did)


def test_help_line_reads_every_command_literal():
    """help_line reads HELP from the source; it must be what the module says."""
    import importlib

    from studies.cli import help_line

    for name, modname in COMMANDS.items():
        assert help_line(modname) == importlib.import_module(modname).HELP


def test_values_written_for_the_help_match_their_declarations():
    """What the light command modules restate for their help (to import no model) is what the models declare."""
    from lumped.valves.kind import kind_names
    from studies.cli import check, pump
    from studies.validation.reed_check import DEFAULT_TOLERANCE_PCT

    assert check.DEFAULT_TOLERANCE_PCT == DEFAULT_TOLERANCE_PCT
    assert set(pump.SHIPPED_KINDS) <= set(kind_names())
    assert pump.AIR_BOUNDS == pump.air_bounds()


def test_lazy_flags_refuse_as_before(cli):
    """Ranges and kinds resolved when the flag is given refuse with the same one line."""
    rc, _, err = cli("pump", "--valve", "disk")
    assert rc == 2 and "--valve" in err and "disc, reed, ball" in err and "'disk'" in err
    rc, _, err = cli("pump", "--valve", "disc", "--speed-rpm", "1e6")
    assert rc == 2 and "expected a number in rpm from 10 to 20000" in err
