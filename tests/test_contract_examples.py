"""Every example of CONTRACT.md runs as written.

The fenced blocks are extracted from CONTRACT.md itself (not copied here), so editing an
example edits what this test runs. Input files (TOML) are written as shown and given to
the command that reads them; JSON outputs are compared with the output of the command
they document: every key of the example must be in the real output, with the same
kind of value (placeholders ``"..."`` stand for more of the same). Examples that take a
minute or more (the FEA check with convergence, the seat FEA, the discrepancy demo, the
1024-design sweep) run with ``pytest -m slow``.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BLOCKS = re.findall(r"```(\w*)\n(.*?)```", (ROOT / "CONTRACT.md").read_text(), re.S)


def block(lang: str, starts: str) -> str:
    """The one CONTRACT.md block of ``lang`` whose first line starts with ``starts``."""
    found = [b for k, b in BLOCKS if k == lang and b.lstrip().startswith(starts)]
    assert len(found) == 1, f"{len(found)} {lang} blocks start with {starts!r}"
    return found[0]


def same_shape(example, real, path="$"):
    """Every key of ``example`` is in ``real`` with a value of the same kind (recursively)."""
    if isinstance(example, dict):
        assert isinstance(real, dict), f"{path}: expected an object, got {real!r}"
        for k, v in example.items():
            if k == "...":
                continue
            assert k in real, f"{path}: no key {k!r} (keys: {sorted(real)})"
            same_shape(v, real[k], f"{path}.{k}")
    elif isinstance(example, list):
        assert isinstance(real, list), f"{path}: expected a list, got {real!r}"
        items = [e for e in example if e != "..."]
        if items and real:
            same_shape(items[0], real[0], f"{path}[0]")
    elif isinstance(example, bool):
        assert isinstance(real, bool), f"{path}: expected true/false, got {real!r}"
    elif isinstance(example, (int, float)):
        assert real is None or (isinstance(real, (int, float)) and not isinstance(real, bool)), \
            f"{path}: expected a number, got {real!r}"
    elif isinstance(example, str) and example != "...":
        assert isinstance(real, str), f"{path}: expected a string, got {real!r}"


def ok(cli, *args, cwd=None):
    rc, out, err, obj = cli(*args, "--json", cwd=cwd)
    assert rc == 0, err[-800:]
    assert obj is not None, out[-400:]
    return obj


# ------------------------------------------------------------------ input files
def test_reed_file_example_runs(cli, tmp_path):
    (tmp_path / "reed.toml").write_text(block("toml", "[reed]\nlength"))
    r = ok(cli, "reed", "reed.toml")
    assert r["omega_n"] > 0 and r["kappa"] > 0


def test_half_ring_groove_example_runs(cli, tmp_path):
    """The half ring closes the prototype's outer U-groove: it goes into the example reed."""
    text = block("toml", "[reed]\nlength") + "\n" + block("toml", "[[reed.grooves]]\nkind")
    (tmp_path / "reed.toml").write_text(text)
    ok(cli, "reed", "reed.toml")


def test_sections_example_runs(cli, tmp_path):
    head = block("toml", "[reed]\nlength").split("[[reed.grooves]]")[0]
    head = "\n".join(ln for ln in head.splitlines() if not ln.split("=")[0].strip() in
                     ("width_root", "width_tip", "step_fraction", "tip_radius"))
    (tmp_path / "reed.toml").write_text(head + "\n" + block("toml", "[[reed.sections]]"))
    r = ok(cli, "reed", "reed.toml", "--fidelity", "beam")
    assert r["omega_n"] > 0


def test_lts_setup_example_runs(cli, tmp_path):
    (tmp_path / "setup.toml").write_text(block("toml", "[lts]"))
    r = ok(cli, "lts", "setup.toml")
    assert r["setups"][0]["setup"] == "my manifold"


def test_run_toml_example_is_a_dataset(cli, tmp_path):
    run = tmp_path / "ds" / "run1"
    run.mkdir(parents=True)
    (run / "run.toml").write_text(block("toml", 'valve_type = "disc"'))
    r = ok(cli, "discrepancy", "ds", "--no-report", "--max-rounds", "0", cwd=tmp_path)
    assert [run["run"] for run in r["runs"]] == ["run1"]
    assert r["runs"][0]["delivery_error_pct"] is not None  # delivery alone is a dataset


def test_model_file_example_runs(cli, tmp_path):
    (tmp_path / "model.toml").write_text(block("toml", "[pump]\npiston_diameter"))
    ok(cli, "model", "check", "model.toml", "--no-fea", cwd=tmp_path)
    r = ok(cli, "pump", "--model", "model.toml", "--speed-rpm", "593", "--load-pressure-mpa", "2.76",
           "--revolutions", "2", cwd=tmp_path)
    assert r["valve"] == "disc/reed"


def test_reed_dynamics_example_runs(cli, tmp_path):
    """The reed dynamics keys, on the thesis reed pump: the pump JSON's dynamics as CONTRACT.md shows it."""
    (tmp_path / "modal.toml").write_text('base = "thesis-reed"\n' + block("toml", "[valves.delivery]\nkind"))
    r = ok(cli, "pump", "--model", "modal.toml", "--revolutions", "2", cwd=tmp_path)
    assert r["dynamics"] == {"delivery": {"kind": "modal", "modes": 3}}


def test_sweep_file_example_is_accepted(tmp_path):
    from studies.sweeps import sweep

    (tmp_path / "spec.toml").write_text(block("toml", "[sweep]\nmodel"))
    spec = sweep.load_spec(tmp_path / "spec.toml")
    sweep.check_spec(spec, sweep.load_model(spec.model))
    assert spec.n_designs == 1024


@pytest.mark.slow
def test_sweep_file_example_runs(cli, tmp_path):
    (tmp_path / "spec.toml").write_text(block("toml", "[sweep]\nmodel"))
    r = ok(cli, "sweep", "spec.toml", "--no-progress", cwd=tmp_path, )
    assert r["designs"] == 1024 and r["complete"]


# ------------------------------------------------------------------ JSON outputs
def test_reed_json_example(cli):
    example = json.loads(block("json", '{"geometry": "stepped1"'))
    same_shape(example, ok(cli, "reed", "stepped1", "--fidelity", "solid"))


def test_pump_json_example(cli):
    example = json.loads(block("json", '{"valve": "reed"'))
    real = ok(cli, "pump", "--valve", "reed", "--speed-rpm", "743", "--load-pressure-mpa", "2.76")
    same_shape(example, real)


def test_lts_json_example(cli, tmp_path):
    example = json.loads(block("json", '{"setups"'))
    (tmp_path / "run.csv").write_text("volts\n0.0\n0.125\n0.25\n")
    real = ok(cli, "lts", "disc_inlet", "--voltages", "run.csv", "--column", "volts", "--plot", "lts.png",
              cwd=tmp_path)
    same_shape(example, real)


@pytest.mark.slow
def test_discrepancy_json_example(cli, tmp_path):
    example = json.loads(block("json", '{"effects_added"'))
    same_shape(example, ok(cli, "discrepancy", "--demo", "--no-report", cwd=tmp_path))


@pytest.mark.slow
def test_check_json_example(cli, tmp_path):
    example = json.loads(block("json", '{"geometry": "prototype"'))
    real = ok(cli, "check", "prototype", "--modes", "4", "--convergence", "--out", "out", cwd=tmp_path)
    same_shape(example, real)


@pytest.mark.slow
def test_seat_json_example(cli):
    example = json.loads(block("json", '{"disc_valve"'))
    same_shape(example, ok(cli, "seat"))
