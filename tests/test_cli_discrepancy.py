"""``valvelab synth`` and ``valvelab discrepancy`` as a user runs them (stand-in model: --simulator tests.standin)."""

import json

import pytest

MODEL = ("--simulator", "tests.standin")


def test_synth_then_discrepancy_json_and_report(cli, tmp_path):
    rc, out, err, obj = cli("synth", "ds", "--effect", "seat_compliance@delivery:k_seat=1.5e6",
                            "--air-content", "0.013", "--seed", "3", *MODEL, "--json")
    assert rc == 0, err
    assert len(obj["runs"]) == 6 and (tmp_path / "ds" / "truth.toml").is_file()
    assert obj["warnings"] == []          # the thesis's conditions, the O-ring it measured: inside the envelope
    rc, out, err, res = cli("discrepancy", "ds", "--workers", "1", *MODEL, "--json")
    assert rc == 0, err
    for key in ("effects_added", "parameters", "gap_before", "gap_after", "disagreements", "held_out"):
        assert key in res
    for g in ("gap_before", "gap_after"):
        assert {"position_rms_m", "delivery_error_pct"} <= set(res[g])
    assert res["effects_added"] == ["seat_compliance"] and res["warnings"] == []
    assert set(res["parameters"]["seat_compliance"]) == {"k_seat", "c_seat"}
    # the discharge-coefficient factor is a fitted baseline nuisance, reported apart from the effects
    cd = res["baseline_nuisances"]["discharge_scale"]
    assert "discharge_scale" not in res["effects_added"] and 0.9 <= cd["values"]["scale"] <= 1.1
    assert "discrepancy round" in err or "discrepancy:" in err   # progress on stderr
    rep = tmp_path / "ds_discrepancy"
    for f in ("ranking.csv", "ranking.md", "disagreements.txt", "gap_bars.png", "residuals.png", "summary.json"):
        assert (rep / f).is_file(), f
    assert len(list(rep.glob("traces_*.png"))) == 6
    assert json.loads((rep / "summary.json").read_text())["effects_added"] == ["seat_compliance"]
    assert "Baseline nuisance: discharge_scale" in (rep / "disagreements.txt").read_text()
    # a second run may replace the report valvelab wrote, and prints readable text without --json;
    # the first versions' --model MODULE still names a simulator module, with a note
    rc, out, err = cli("discrepancy", "ds", "--workers", "1", "--model", "tests.standin")
    assert rc == 0 and "added seat_compliance (delivery)" in out and "--simulator" in err


def test_bad_dataset_exits_2_naming_file_line_field(cli, tmp_path):
    rc, *_ = cli("synth", "ds", "--seed", "1", *MODEL, "--json")
    assert rc == 0
    csv = next((tmp_path / "ds").glob("run03*/trace.csv"))
    lines = csv.read_text().splitlines()
    cells = lines[9].split(",")
    cells[1] = "nan"
    lines[9] = ",".join(cells)
    csv.write_text("\n".join(lines) + "\n")
    rc, out, err = cli("discrepancy", "ds", *MODEL)
    assert rc == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "trace.csv, line 10, valve_position_m" in err


def test_report_refuses_a_user_folder(cli, tmp_path):
    assert cli("synth", "ds", "--seed", "1", *MODEL)[0] == 0
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep me")
    rc, out, err = cli("discrepancy", "ds", "--report", "mine", *MODEL)
    assert rc == 2 and "mine" in err
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep me"


def test_synth_refuses_to_overwrite_and_checks_effects(cli, tmp_path):
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "data.csv").write_text("mine")
    rc, out, err = cli("synth", "ds", *MODEL)
    assert rc == 2 and "did not create" in err
    rc, out, err = cli("synth", "x", "--effect", "unicorn:k=1", *MODEL)
    assert rc == 2 and "unicorn" in err and "seat_compliance" in err
    rc, out, err = cli("synth", "x", "--effect", "seat_compliance:k_seat=-5", *MODEL)
    assert rc == 2 and "k_seat" in err
    rc, out, err = cli("synth", "x", "--condition", "600:2760", *MODEL)
    assert rc == 2 and "MPa" in err


@pytest.mark.parametrize("flag,value", [("--position-tolerance-um", "-1"), ("--min-improvement-pct", "150"),
                                        ("--min-gain-units", "0"),
                                        ("--workers", "0")])
def test_discrepancy_flags_checked(cli, tmp_path, flag, value):
    rc, out, err = cli("discrepancy", "ds", flag, value, *MODEL)   # flags are checked before any data
    assert rc == 2 and flag in err


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(8))
def test_readme_discrepancy_example_names_piston_leakage(cli, seed):
    """The README's example with the real pump model, seeds 0-7: the data read (no pressure below the
    vapour pressure), the workflow names piston_leakage and fits the clearance within 20 %."""
    rc, out, err, obj = cli("synth", "my_data", "--effect", "piston_leakage:clearance=4e-5", "--seed", str(seed),
                            "--json")
    assert rc == 0, err
    rc, out, err, res = cli("discrepancy", "my_data", "--no-report", "--json", timeout=1800)
    assert rc == 0, err
    assert res["effects_added"] == ["piston_leakage"]
    assert res["parameters"]["piston_leakage"]["clearance"] == pytest.approx(4e-5, rel=0.2)


@pytest.mark.slow
@pytest.mark.parametrize("effect, name, target, param, value", [
    ("piston_leakage:clearance=4e-5", "piston_leakage", "pump", "clearance", 4e-5),
    ("seat_compliance@delivery:k_seat=2e6", "seat_compliance", "delivery", "k_seat", 2e6),
])
def test_a_hidden_effect_of_a_ball_valve_pump_is_named(cli, effect, name, target, param, value):
    """The ball check valve (the shipped thesis-ball: the thesis pump with ball valves): a leak and a compliant
    delivery seat hidden by synth, named by discrepancy, on the right target, the parameter within 20 %, the
    held-out gap shrunk by at least 70 %."""
    rc, out, err, obj = cli("synth", "ball_data", "--model", "thesis-ball", "--effect", effect, "--air-content",
                            "0.013", "--seed", "1", "--json")
    assert rc == 0, err
    rc, out, err, res = cli("discrepancy", "ball_data", "--no-report", "--json", "--workers", "2", timeout=1800)
    assert rc == 0, err
    assert res["model"] == "thesis-ball"
    assert res["effects_added"] == [name] and res["targets"][name] == target
    assert res["parameters"][name][param] == pytest.approx(value, rel=0.2)
    c0, c1 = res["held_out"]["cost_before"], res["held_out"]["cost_after"]
    assert c1 <= 0.3 * c0


def test_report_figures_show_the_printed_gaps(tmp_path, monkeypatch, capsys):
    """gap_bars.png's first group is the gap the command prints (every run, before and after), each group
    says how many runs it pools, each bar carries its value; every report figure passes the figure checks;
    the fitted parameters are printed with their units."""
    import figure_checks
    from studies.cli import main
    from studies.cli.discrepancy import render

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    assert main(["synth", "ds", "--effect", "seat_compliance@delivery:k_seat=1.5e6", "--air-content", "0.013",
                 "--seed", "3", *MODEL]) == 0
    capsys.readouterr()
    with figure_checks.capture() as saved:
        assert main(["discrepancy", "ds", "--workers", "1", *MODEL, "--json"]) == 0
    printed = capsys.readouterr()
    res = json.loads(printed.out)
    # progress in words and units, not Python's reprs
    assert "adding seat_compliance@delivery k_seat = " in printed.err and " N/m, c_seat = " in printed.err
    assert "{'" not in printed.err, printed.err
    found = [p for path, fig in saved for p in figure_checks.problems(fig, path.rsplit("/", 1)[-1])]
    assert not found, "\n".join(found)
    (fig,) = [f for path, f in saved if path.endswith("gap_bars.png")]
    pos, dele = fig.axes[:2]
    n = len(res["runs"])
    assert [t.get_text() for t in pos.get_xticklabels()] == [
        f"all {n} runs", f"fitted ({len(res['fitted']['runs'])})", f"held out ({len(res['held_out']['runs'])})"]
    for ax, key, scale in ((pos, "position_rms_m", 1e3), (dele, "delivery_error_pct", 1.0)):
        before, after = ax.containers[0], ax.containers[1]
        assert before.patches[0].get_height() == pytest.approx(res["gap_before"][key] * scale, rel=1e-12)
        assert after.patches[0].get_height() == pytest.approx(res["gap_after"][key] * scale, rel=1e-12)
        assert before.patches[1].get_height() == pytest.approx(res["fitted"]["gap_before"][key] * scale, rel=1e-12)
        assert before.patches[2].get_height() == pytest.approx(res["held_out"]["gap_before"][key] * scale, rel=1e-12)
    # the number printed for the gap before is the number written on its bar
    drawn = [t.get_text() for t in pos.texts]
    printed = f"{res['gap_before']['position_rms_m'] * 1e3:.3f}"
    assert printed in drawn
    text = render(res)
    assert f"gap before, all {n} runs: position RMS {printed} mm" in text
    assert res["parameter_units"]["seat_compliance"] == {"k_seat": "N/m", "c_seat": "N s/m"}
    assert " N/m, c_seat = " in text and text.split("c_seat = ", 1)[1].split(" ", 2)[1] == "N"
