"""Measured-run I/O: round trip, and every bad input named by file, line and field."""

import numpy as np
import pytest

from geometry.errors import InputError
from studies.discrepancy.measured import Run, Trace, read_dataset, read_run, swept_volume_m3, write_dataset, write_run

RPM = 600.0  # 0.1 s per revolution
FS = 10_000.0


def make_run(name="r1", valve="delivery", revs=1, **kw) -> Run:
    n = int(revs * 60 / RPM * FS)
    t = np.arange(n) / FS
    x = 1e-3 * np.clip(np.sin(2 * np.pi * t * RPM / 60), 0, None)
    p = 2.8e6 + 1e5 * np.cos(2 * np.pi * t * RPM / 60)
    positions = {"inlet": x, "delivery": -x} if valve == "both" else {valve: x}
    fields = dict(valve_type="disc", speed_rpm=RPM, load_pressure_pa=2.79e6, measured_valve=valve,
                  delivery_cc_per_rev=1.79, air_content=0.013)
    fields["trace"] = Trace.measured(t, positions, p, p * 0 + 2.79e6)
    fields.update(kw)
    return Run(name=name, **fields)


def write_csv(folder, header, rows, toml=None):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "run.toml").write_text(toml or (
        'valve_type = "disc"\nmeasured_valve = "delivery"\nspeed_rpm = 600.0\nload_pressure_pa = 2.79e6\n'))
    lines = [",".join(header)] + [",".join(str(v) for v in r) for r in rows]
    (folder / "trace.csv").write_text("\n".join(lines) + "\n")


def good_rows(n=1000, x=None):
    t = np.arange(n) / FS
    x = 1e-3 * np.clip(np.sin(2 * np.pi * t * 10), 0, None) if x is None else x
    return [[f"{ti:.6f}", f"{xi:.6e}"] for ti, xi in zip(t, x)]


@pytest.mark.parametrize("valve", ["inlet", "delivery", "both"])
def test_round_trip(tmp_path, valve):
    run = make_run(valve=valve, revs=2)
    write_run(tmp_path / "a", run)
    back = read_run(tmp_path / "a")
    assert back.measured_valve == valve and back.speed_rpm == RPM
    assert back.delivery_cc_per_rev == pytest.approx(1.79) and back.air_content == pytest.approx(0.013)
    for v, x in run.trace.positions.items():
        np.testing.assert_allclose(back.trace.positions[v], x, rtol=1e-8, atol=1e-15)
    np.testing.assert_allclose(back.trace.cylinder_pressure_pa, run.trace.cylinder_pressure_pa, rtol=1e-8)


def test_dataset_folder_and_single_run(tmp_path):
    runs = [make_run("b"), make_run("a", valve="inlet")]
    write_dataset(tmp_path / "ds", runs)
    (tmp_path / "ds" / "notes.txt").write_text("ignored")
    got = read_dataset(tmp_path / "ds")
    assert [r.name for r in got] == ["a", "b"]
    assert [r.name for r in read_dataset(tmp_path / "ds" / "b")] == ["b"]


def test_run_without_trace_is_valid(tmp_path):
    write_run(tmp_path / "d", make_run(trace=None))
    r = read_run(tmp_path / "d")
    assert r.trace is None and r.delivery_m3_per_rev == pytest.approx(1.79e-6)


def test_writing_never_overwrites_user_files(tmp_path):
    folder = tmp_path / "mine"
    write_csv(folder, ["time_s", "valve_position_m"], good_rows())
    with pytest.raises(InputError, match="did not create"):
        write_run(folder, make_run())
    write_run(folder, make_run(), force=True)
    assert read_run(folder).delivery_cc_per_rev == pytest.approx(1.79)


def err(tmp_path, header, rows, toml=None) -> str:
    write_csv(tmp_path / "r", header, rows, toml)
    with pytest.raises(InputError) as e:
        read_run(tmp_path / "r")
    return str(e.value)


def test_nan_named_by_line_and_column(tmp_path):
    rows = good_rows()
    rows[17][1] = "nan"
    msg = err(tmp_path, ["time_s", "valve_position_m"], rows)
    assert "trace.csv, line 19, valve_position_m" in msg  # header is line 1, row 0 is line 2


def test_empty_and_text_cells(tmp_path):
    rows = good_rows()
    rows[3][0] = ""
    assert "line 5, time_s: empty" in err(tmp_path, ["time_s", "valve_position_m"], rows)
    rows = good_rows()
    rows[4][1] = "abc"
    assert "line 6, valve_position_m" in err(tmp_path, ["time_s", "valve_position_m"], rows)


def test_missing_column(tmp_path):
    msg = err(tmp_path, ["time_s", "position"], good_rows())
    assert "valve_position_m" in msg and "missing column" in msg


def test_non_monotonic_time(tmp_path):
    rows = good_rows()
    rows[50][0], rows[51][0] = rows[51][0], rows[50][0]
    assert "line 53, time_s" in err(tmp_path, ["time_s", "valve_position_m"], rows)


def test_non_uniform_time(tmp_path):
    rows = good_rows()
    rows = rows[:300] + rows[302:]  # data row 300 (file line 302) jumps three steps
    msg = err(tmp_path, ["time_s", "valve_position_m"], rows)
    assert "line 302, time_s" in msg and "non-uniform" in msg


def test_not_whole_revolutions(tmp_path):
    assert "revolutions" in err(tmp_path, ["time_s", "valve_position_m"], good_rows(1370))


def test_position_in_wrong_units(tmp_path):
    x = 1e-3 * np.clip(np.sin(2 * np.pi * np.arange(1000) / FS * 10), 0, None)
    x[200] = 2.0   # "a valve position of 2 m"
    msg = err(tmp_path, ["time_s", "valve_position_m"], good_rows(x=x))
    assert "line 202, valve_position_m" in msg and "not a valve position" in msg


def test_pressure_in_mpa_written_as_pa(tmp_path):
    rows = [r + [f"{2.8 + 0.1 * np.sin(i / 50):.4f}"] for i, r in enumerate(good_rows())]
    msg = err(tmp_path, ["time_s", "valve_position_m", "cylinder_pressure_pa"], rows)
    assert "cylinder_pressure_pa" in msg and "MPa" in msg


@pytest.mark.parametrize("line,field,hint", [
    ("load_pressure_pa = 2.79", "load_pressure_pa", "MPa"),
    ("speed_rpm = 9.9", "speed_rpm", "rev/s"),
    ("delivery_cc_per_rev = 1.79e-6", "delivery_cc_per_rev", "m^3"),
    ("delivery_cc_per_rev = 5.0", "delivery_cc_per_rev", "swept volume"),
    ("air_content = 1.3", "air_content", "percent"),
])
def test_run_toml_units(tmp_path, line, field, hint):
    base = {"valve_type": '"disc"', "measured_valve": '"delivery"', "speed_rpm": "600.0",
            "load_pressure_pa": "2.79e6"}
    k, v = (s.strip() for s in line.split("="))
    base[k] = v
    toml = "".join(f"{a} = {b}\n" for a, b in base.items())
    msg = err(tmp_path, ["time_s", "valve_position_m"], good_rows(), toml)
    assert f"run.toml: {field}" in msg and hint in msg


def test_swept_volume_is_thesis_value():
    # Table 5.1: 2 A_p r = 2.22 cc/rev
    assert swept_volume_m3() * 1e6 == pytest.approx(2.22, abs=0.005)


def test_missing_measured_valve_and_bad_type(tmp_path):
    toml = 'valve_type = "disc"\nspeed_rpm = 600.0\nload_pressure_pa = 2.79e6\n'
    assert "measured_valve" in err(tmp_path, ["time_s", "valve_position_m"], good_rows(), toml)
    toml = 'valve_type = "poppet"\nmeasured_valve = "inlet"\nspeed_rpm = 600.0\nload_pressure_pa = 2.79e6\n'
    assert "valve_type" in err(tmp_path, ["time_s", "valve_position_m"], good_rows(), toml)


def test_dataset_errors(tmp_path):
    with pytest.raises(InputError, match="no such folder"):
        read_dataset(tmp_path / "nope")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no run folders"):
        read_dataset(tmp_path / "empty")
    write_dataset(tmp_path / "mixed", [make_run("a"), make_run("b", valve_type="reed")])
    with pytest.raises(InputError, match="mixes valve types"):
        read_dataset(tmp_path / "mixed")
