"""What a new user meets in the first hour says what is true: the counts a command prints are what it
wrote, its progress bar's total is known from the start and reached, documented shapes and units hold,
and nothing but progress and warnings reaches stderr.

Each check compares what is printed or documented with what was actually written or returned,
read back independently (folders counted, tables read with pandas, shapes measured).
"""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "docs" / "examples"


def _bar_totals(stderr: str, desc: str) -> list[tuple[int, int]]:
    """(n, total) of every refresh of a tqdm bar named ``desc``."""
    return [(int(a), int(b)) for a, b in re.findall(rf"{desc}:\s+\d+%\|[^|]*\|\s*(\d+)/(\d+)", stderr)]


def test_optimize_counts_what_it_runs_and_writes(cli, tmp_path):
    """optimize_quick.toml asks for 4 generations of 8: it reports 4, writes gen-0001..0004 holding the designs
    it counts, and its bar goes to 4/4 with that total from the start (it once reported 1, wrote 3 folders and
    ended at "5generation")."""
    spec = tomllib.loads((EXAMPLES / "optimize_quick.toml").read_text())["run"]
    rc, out, err, r = cli("optimize", EXAMPLES / "optimize_quick.toml", "--out", "o", "--json")
    assert rc == 0, err[-2000:]
    folders = sorted((tmp_path / "o" / "generations").glob("gen-*"))
    written = sum(len(pd.read_parquet(f / "designs.parquet")) for f in folders)
    assert r["generations"] == spec["generations"] == len(folders)
    assert r["evaluated_designs"] == written == spec["generations"] * spec["population"]
    assert r["evaluations"] == written * len(r["operating_points"])
    bar = _bar_totals(err, "optimize")
    assert bar and {t for _, t in bar} == {spec["generations"]} and bar[-1][0] == spec["generations"]
    counts = re.sub(r"[\d.]+(?:generation/s|s/generation)", "", err)   # tqdm's rates ("1.25generation/s") apart
    assert "generation [" not in counts and "5generation" not in counts
    rc, text, _ = cli("optimize", EXAMPLES / "optimize_quick.toml", "--out", "o")    # the rerun replays it
    assert rc == 0 and f"{spec['generations']} generations of up to {spec['population']} designs: {written} designs" \
        in text


def test_sweep_counts_what_it_writes(cli, tmp_path):
    """The designs a sweep prints, its bar's total and the rows it wrote agree."""
    n = tomllib.loads((EXAMPLES / "sweep_quick.toml").read_text())["sweep"]["samples"]
    rc, out, err, r = cli("sweep", EXAMPLES / "sweep_quick.toml", "--out", "s", "--json")
    assert rc == 0, err[-2000:]
    results = pd.read_parquet(tmp_path / "s" / "results.parquet")
    assert r["designs"] == n == len(results) == r["computed"] + r["skipped"]
    assert sum(r["status_counts"].values()) == n
    bar = _bar_totals(err, "sweep")
    assert bar and {t for _, t in bar} == {n} and bar[-1][0] == n


def test_to_frame_is_what_getting_started_says():
    """Getting started states the table's shape and units (it once said one row)."""
    from lumped import load_model, simulate

    frame = simulate(load_model("thesis-disc"), 593, 2.76e6).to_frame()
    page = (ROOT / "docs" / "getting_started.md").read_text()
    rows, cols = map(int, re.search(r"to_frame\(\)\s+# (\d) rows \(inlet, delivery\) x (\d+) columns", page).groups())
    assert frame.shape == (rows, cols) and list(frame.index) == ["inlet", "delivery"]
    for column in frame.columns:                      # every column is named, with its unit where it has one
        assert f"`{column}`" in page
    # SI: an opening of about a millimetre in m, the delivery of about 1.7 cc in m^3, angles in rad
    assert 1e-4 < frame.loc["delivery", "peak_opening"] < 1e-2
    assert 1e-7 < frame.loc["delivery", "delivery_m3_per_rev"] < 1e-5
    assert 0.0 <= frame.loc["inlet", "closing_angle"] <= 2 * 3.1416


def test_writing_a_2d_mesh_as_vtu_prints_nothing(tmp_path, capfd):
    """A plate's modes as VTU: no meshio warning on stderr, 3-D points (z = 0) in the file."""
    import meshio

    from fea import plate
    from geometry import load_reed

    result = plate.solve(load_reed("prototype"))
    capfd.readouterr()
    plate.write_modes_vtu(result, tmp_path / "modes.vtu")
    captured = capfd.readouterr()
    assert captured.err == "" and captured.out == ""
    points = meshio.read(tmp_path / "modes.vtu").points
    assert points.shape[1] == 3 and (points[:, 2] == 0).all()


def test_reed_frequencies_carry_their_unit(cli):
    """frequencies in reed --json are rad/s: said by the help and CONTRACT.md, and true (the first bending
    frequency in the list is omega_n)."""
    rc, out, err = cli("reed", "--help")
    assert "frequencies [rad/s]" in " ".join(out.split())
    contract = " ".join((ROOT / "CONTRACT.md").read_text().split())
    assert "`frequencies`, the first N natural frequencies [rad/s]" in contract
    rc, out, err, r = cli("reed", "prototype", "--fidelity", "beam", "--modes", "2", "--json")
    assert rc == 0 and abs(r["frequencies"][0] / r["omega_n"] - 1.0) < 1e-6


def test_help_texts_show_percent_signs_once(cli):
    """argparse's %-escaping shown literally (check's description once read "with %% deviations")."""
    for command in ("check", "pump"):
        rc, out, err = cli(command, "--help")
        assert rc == 0 and "%%" not in out and "%" in out


def test_printed_objectives_keep_their_digits():
    """optimize's text gives every objective to the same significant digits (1.7260, not 1.726)."""
    from studies.cli.optimize import _f

    assert [_f(v) for v in (1.726, 1.75768, 2.0)] == ["1.7260", "1.7577", "2.0000"]
    assert json.dumps(_f(None)) == '"-"'


def test_a_tables_numbers_share_their_columns_decimals(capsys):
    """Table 5.4's simulated deliveries S (modeled_cc) are printed to the same decimals (once 1.726 beside
    1.70637), in the text, and agree with the JSON to that precision."""
    from studies.cli import main
    from studies.cli.table import render

    assert main(["table", "5.4", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    lines = render(r).splitlines()           # the text valvelab table 5.4 prints
    head = lines[1].split()
    col = head.index("modeled_cc")
    cells = [line.split()[col] for line in lines[3:3 + len(r["rows"])]]
    decimals = {len(c.split(".")[1]) for c in cells}
    assert len(decimals) == 1, cells
    d = decimals.pop()
    assert [float(c) for c in cells] == [round(row["modeled_cc"], d) for row in r["rows"]]
