"""The discrepancy workflow on a pump that is not the thesis's, described only by a model file.

``valvelab synth --model FILE`` writes data from the model's baseline with an effect hidden in
it (the model travels with the dataset: model.toml, named in run.toml); ``valvelab
discrepancy`` reads the model from run.toml (or ``--model``), starts from its baseline (every
candidate effect off) and must find the hidden seat compliance, with its parameter within
20 %, and name nothing on clean data.
"""

from __future__ import annotations


from pathlib import Path

import pytest

#: a bigger, faster pump with a heavier, stiffer-sprung disc valve pair: not the thesis rig
MODEL = (Path(__file__).parent / "data" / "bench-pump.toml").read_text()
CONDITIONS = ("600:2.5:inlet", "600:2.5:delivery", "800:2.8:inlet", "800:2.8:delivery", "650:3.5:inlet",
              "650:3.5:delivery")


def _synth(cli, tmp_path, effects, seed):
    f = tmp_path / "bench.toml"
    f.write_text(MODEL)
    args = ["synth", "ds", "--model", f, "--air-content", "0.01", "--seed", str(seed), "--workers", "2", "--json"]
    for c in CONDITIONS:
        args += ["--condition", c]
    for e in effects:
        args += ["--effect", e]
    rc, out, err, obj = cli(*args, timeout=900)
    assert rc == 0, err
    ds = tmp_path / "ds"
    assert (ds / "model.toml").is_file()
    assert 'model = "../model.toml"' in next(ds.glob("run01*/run.toml")).read_text()
    return ds


def test_hidden_seat_compliance_of_a_model_file_is_found(cli, tmp_path):
    ds = _synth(cli, tmp_path, ["seat_compliance@delivery:k_seat=2.5e6"], seed=4)
    rc, out, err, res = cli("discrepancy", ds, "--workers", "2", "--no-report", "--json", timeout=1800)
    assert rc == 0, err
    assert res["model"] == "bench-pump"
    assert res["effects_added"] == ["seat_compliance"] and res["targets"]["seat_compliance"] == "delivery"
    assert res["parameters"]["seat_compliance"]["k_seat"] == pytest.approx(2.5e6, rel=0.2)


def test_nothing_is_named_on_clean_data_of_a_model_file(cli, tmp_path):
    ds = _synth(cli, tmp_path, [], seed=5)
    f = tmp_path / "bench.toml"
    rc, out, err, res = cli("discrepancy", ds, "--model", f, "--workers", "2", "--no-report", "--json", timeout=1800)
    assert rc == 0, err
    assert res["effects_added"] == []


def test_a_dataset_of_other_valves_is_refused(cli, tmp_path):
    ds = _synth(cli, tmp_path, [], seed=6)
    rc, out, err = cli("discrepancy", ds, "--model", "thesis-reed", "--no-report")
    assert rc == 2 and "--model" in err and "disc" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("named", ["thesis-ball", "../model.toml"])
def test_run_toml_names_a_shipped_model_or_a_file_relative_to_the_run(tmp_path, named):
    """run.toml's ``model``: a shipped model's name (what ``synth --model thesis-ball`` writes) is that model, not a
    file in the run folder; anything else is a file relative to the run folder."""
    from lumped.model.model_file import load_model, to_toml
    from studies.discrepancy.measured import Run
    from studies.discrepancy.model_choice import choose

    (tmp_path / "model.toml").write_text(to_toml(load_model("thesis-ball")))
    run_dir = tmp_path / "run01"
    run_dir.mkdir()
    runs = [Run("run01", "ball", 593.0, 2.76e6, "inlet", path=run_dir, model=named)]
    sim = choose(runs=runs)
    assert sim.context.label == "ball" and sim.context.pump == load_model("thesis-ball").pump
