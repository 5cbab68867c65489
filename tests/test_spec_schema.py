"""The one machinery of the spec files (studies.sweeps.schema): the sweep file and the design specs refuse the same
value the same way, and its key declarations check what they declare."""

from __future__ import annotations

import tomllib

import pytest

from geometry.errors import InputError
from studies.sweeps import SweepRun, parse_spec, run_sweep, schema
from studies.sweeps.design import spec as dspec

SWEEP = "[sweep]\nmodel = 'thesis-disc'\nsampler = 'lhs'\nsamples = 4\n[factors.speed_rpm]\n{range}\n"
DESIGN = ('model = "thesis-disc"\n[operating]\nspeed_rpm = [593.0]\nload_pressure_mpa = [2.76]\n[variables]\n'
          '"oil.air_content" = {{ {range} }}\n[run]\noutputs = ["delivery_cc_per_rev"]\nsamples = 4\n')


def _sweep(text):
    return parse_spec(tomllib.loads(text), text)


def _design(text, command="sensitivity"):
    return dspec.parse_spec(tomllib.loads(text), command, text)


def _refusal(fn) -> InputError:
    with pytest.raises(InputError) as exc:
        fn()
    return exc.value


@pytest.mark.parametrize("sweep_range, design_range, end", [
    ("low = 0.02\nhigh = 0.01", "low = 0.02, high = 0.01", "high"),          # high <= low
    ("low = -1.0\nhigh = 1.0\nscale = 'log'", "low = -1.0, high = 1.0, scale = 'log'", "low"),
    ("low = 0.01\nhigh = 0.02\nscale = 'logarithmic'", "low = 0.01, high = 0.02, scale = 'logarithmic'", "scale"),
    ("high = 0.02", "high = 0.02", "low"),                                   # a range without its low end
    ("low = 'a'\nhigh = 0.02", "low = 'a', high = 0.02", "low"),
])
def test_a_bad_range_is_refused_with_the_same_words_in_both_spec_files(sweep_range, design_range, end):
    a = _refusal(lambda: _sweep(SWEEP.format(range=sweep_range)))
    b = _refusal(lambda: _design(DESIGN.format(range=design_range)))
    assert a.field == f"factors.speed_rpm.{end}"
    assert b.field == f'variables."oil.air_content".{end}'
    assert a.message == b.message


def test_an_unknown_key_names_the_closest_in_both_spec_files():
    a = _refusal(lambda: _sweep(SWEEP.format(range="low = 450.0\nhigh = 950.0\nscael = 'log'")))
    b = _refusal(lambda: _design(DESIGN.format(range="low = 0.01, high = 0.02, scael = 'log'")))
    assert (a.field, b.field) == ("factors.speed_rpm.scael", 'variables."oil.air_content".scael')
    assert "did you mean scale?" in a.message and "did you mean scale?" in b.message


def test_levels_of_mixed_kinds_are_refused_in_both_spec_files():
    a = _refusal(lambda: _sweep(SWEEP.format(range="values = [450.0, 'fast']")))
    text = DESIGN.replace('"oil.air_content" = {{ {range} }}', '"effects.flow_force" = {{ values = [true, 1] }}')
    b = _refusal(lambda: _design(text.format()))
    assert a.field == "factors.speed_rpm.values" and b.field == 'variables."effects.flow_force".values'
    assert a.message == b.message == "must all be numbers, all strings or all booleans"


def test_declared_keys_are_read_with_their_defaults_and_bounds():
    keys = {"n": schema.Key("int", 4, bounds=(2, 100)), "tol": schema.Key("number", 1e-3, positive=True, below=0.1),
            "margin": schema.Key("number", 1.0, minimum=1.0), "how": schema.Key("choice", "mean",
                                                                                choices=("mean", "worst")),
            "on": schema.Key("bool", True), "need": schema.Key("int", schema.REQUIRED, bounds=(0, 9)),
            "opt": schema.Key("number")}
    assert schema.read_keys({"need": 3}, keys, "run") == {"n": 4, "tol": 1e-3, "margin": 1.0, "how": "mean",
                                                         "on": True, "need": 3}
    for bad, field in (({"need": 3, "n": 1}, "run.n"), ({"need": 3, "n": 2.5}, "run.n"),
                       ({"need": 3, "tol": 0.1}, "run.tol"), ({"need": 3, "tol": 0.0}, "run.tol"),
                       ({"need": 3, "margin": 0.5}, "run.margin"), ({"need": 3, "how": "worse"}, "run.how"),
                       ({"need": 3, "on": 1}, "run.on"), ({}, "run.need"), ({"need": 3, "opt": float("nan")},
                                                                              "run.opt")):
        assert _refusal(lambda: schema.read_keys(bad, keys, "run")).field == field, bad
    assert "did you mean worst?" in _refusal(lambda: schema.read_keys({"need": 3, "how": "worse"}, keys, "run")).message


def test_run_sweep_takes_its_options_as_keywords_or_as_one_object(tmp_path):
    spec = _sweep(SWEEP.format(range="low = 450.0\nhigh = 950.0"))
    # refused before any work (no cluster, no folder): the same field either way
    assert _refusal(lambda: run_sweep(spec, tmp_path / "a", n_workers=0)).field == "n_workers"
    assert _refusal(lambda: run_sweep(spec, tmp_path / "a", SweepRun(n_workers=0))).field == "n_workers"
    assert _refusal(lambda: run_sweep(spec, tmp_path / "a", fmt="xlsx")).field == "fmt"
    with pytest.raises(TypeError):
        run_sweep(spec, tmp_path / "a", n_worker=2)
    assert not (tmp_path / "a").exists()
