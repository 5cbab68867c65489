"""The Python API's entry points refuse a wrong type or value with InputError naming the argument (hypothesis).

Each example draws an entry point and one of its arguments, gives that argument a wrong value (a wrong type, a
string for a number, NaN, a negative, an empty name, a unit slip) and the others good ones, and asks for an
InputError whose field names the argument, raised before any work (a time limit per example). The good calls of
the cheap entry points are drawn too and must return. Entry points: ``lumped.simulate``, ``load_model``,
``with_values``, ``check_valve_kind``, the fluid references (``fea.fluid.get``, ``load_fluid_valve``, the
orifice point), the GCI function (``fea.convergence.gci``) and the measured-data reader
(``studies.discrepancy.measured.read_run``). Deterministic (``derandomize``).
"""

from __future__ import annotations

import math
import time

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from geometry.errors import InputError

NAN = float("nan")


def _simulate(data):
    from lumped import simulate

    good = {"model": "thesis-disc", "speed_rpm": 593.0, "load_pressure": 2.76e6, "method": "fast", "trace": False,
            "revolutions": 2, "rtol": 1e-3, "accuracy_check": True}
    wrong = {"model": [None, 3, "", "nowhere.toml"], "speed_rpm": ["593", NAN, -5.0, 1e9, True],
             "load_pressure": ["2.76e6", NAN, 0.05e6, -1.0], "method": ["fastest", 3, None],
             "trace": ["yes", 1.5, None], "revolutions": [2.5, 0, "5", -1], "rtol": [-1.0, NAN, "1e-3", 1.0],
             "accuracy_check": ["yes", None, 2]}
    arg = data.draw(st.sampled_from(sorted(wrong)))
    kw = dict(good, **{arg: data.draw(st.sampled_from(wrong[arg]))})
    names = {"model": ("model", "spec"), "load_pressure": ("load_pressure",)}.get(arg, (arg,))
    return lambda: simulate(kw.pop("model"), kw.pop("speed_rpm"), kw.pop("load_pressure"), **kw), names


def _load_model(data):
    from lumped import load_model

    spec = data.draw(st.sampled_from([None, 3, "", "nowhere.toml", b"thesis-disc", 2.5]))
    return lambda: load_model(spec), ("spec", "nowhere")


def _with_values(data):
    from lumped import load_model, with_values

    if data.draw(st.booleans()):
        model = data.draw(st.sampled_from([None, "thesis-disc", 3]))
        return lambda: with_values(model, {"pump.dead_volume": 2e-6}), ("model",)
    values = data.draw(st.sampled_from([None, [], "pump.dead_volume", {"": 1.0}, {"pump.dead_volume": "x"},
                                        {"pump.dead_volume": NAN}, {"pump.dead_volum": 1e-6}]))
    return lambda: with_values(load_model("thesis-disc"), values), ("values", "pump.dead_volum")


def _check_valve_kind(data):
    from lumped import check_valve_kind

    kind = data.draw(st.sampled_from([None, 3, "", "Disc", "nope"]))
    return lambda: check_valve_kind(kind), ("kind",)


def _fluid(data):
    from fea.fluid import get, load_fluid_valve
    from fea.fluid.lumped_laws import orifice_point

    which = data.draw(st.sampled_from(["get", "load_fluid_valve", "valve", "lift", "reynolds"]))
    if which == "get":
        name = data.draw(st.sampled_from([None, 3, "", "cfd"]))
        return lambda: get(name), ("name",)
    if which == "load_fluid_valve":
        spec = data.draw(st.sampled_from([None, 3, "", "thesis-disc:middle", "nowhere:inlet"]))
        return lambda: load_fluid_valve(spec), ("spec", "nowhere")
    valve = load_fluid_valve("thesis-disc:inlet")
    args = {"valve": valve, "lift": 1e-3, "reynolds": 50.0}
    args[which] = data.draw(st.sampled_from({"valve": [None, 3, "thesis-disc:middle"],
                                             "lift": ["1e-3", None, NAN, -1e-3, 1.0, True],
                                             "reynolds": ["50", None, -1.0, math.inf]}[which]))
    return lambda: orifice_point(args["valve"], args["lift"], args["reynolds"]), (which,)


def _gci(data):
    from fea.convergence import gci

    good = {"values": (6.063, 5.972, 5.863), "sizes": (1.0, 1.5, 2.0), "cells": None, "dim": None, "order": None}
    arg = data.draw(st.sampled_from(["values", "sizes", "cells", "dim", "order"]))
    kw = dict(good)
    if arg == "values":
        kw["values"] = data.draw(st.sampled_from(["abc", ["a", "b", "c"], (1.0,), (NAN, 1.0, 2.0), None,
                                                  (1e308, -1e308, 1e308)]))
    elif arg == "sizes":
        kw["sizes"] = data.draw(st.sampled_from([(2.0, 1.5, 1.0), (1.0, 2.0), ("1", "2", "3"), (0.0, 1.0, 2.0), None]))
    elif arg == "cells":
        kw.update(sizes=None, dim=2, cells=data.draw(st.sampled_from([(-18000, -8000, -4500), (100, 200, 300),
                                                                     (1.5, 1.0, 0.5), "18000"])))
    elif arg == "dim":
        kw.update(sizes=None, cells=(18000, 8000, 4500), dim=data.draw(st.sampled_from([None, 4, "2", 2.5, True])))
    else:
        kw["order"] = data.draw(st.sampled_from([2.0, -1.0, "2"]))           # three values take no order
    names = {"values": ("values",), "sizes": ("sizes",), "cells": ("cells",), "dim": ("dim",), "order": ("order",)}
    return lambda: gci(**kw), names[arg] + (("values",) if arg == "values" else ())


def _read_run(data):
    from studies.discrepancy.measured import read_run

    folder = data.draw(st.sampled_from([None, 3, "", "nowhere"]))
    return lambda: read_run(folder), ("folder", "nowhere")


ENTRIES = {"simulate": _simulate, "load_model": _load_model, "with_values": _with_values,
           "check_valve_kind": _check_valve_kind, "fluid": _fluid, "gci": _gci, "read_run": _read_run}


@settings(max_examples=150, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(st.data())
def test_entry_points_refuse_naming_the_argument(data):
    entry = data.draw(st.sampled_from(sorted(ENTRIES)))
    call, names = ENTRIES[entry](data)
    t0 = time.perf_counter()
    try:
        call()
    except InputError as exc:
        assert any(n in exc.field for n in names), f"{entry}: {exc.field!r} names none of {names} ({exc.message})"
    else:
        raise AssertionError(f"{entry}: accepted a wrong argument ({names})")
    assert time.perf_counter() - t0 < 10, f"{entry}: refused only after work"


@settings(max_examples=30, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(lift=st.floats(1e-5, 1.19e-3), reynolds=st.floats(0.1, 1e4), levels=st.sampled_from([2, 3]))
def test_good_calls_of_the_cheap_entry_points_return(lift, reynolds, levels):
    from fea.convergence import gci
    from fea.fluid.lumped_laws import orifice_point

    p = orifice_point("thesis-disc:inlet", lift, reynolds)
    assert 0.0 < p.cd < 1.0
    g = gci((6.063, 5.972, 5.863)[:levels], cells=(18000, 8000, 4500)[:levels], dim=2,
            order=2.0 if levels == 2 else None)
    assert math.isfinite(g.gci_fine_pct)
