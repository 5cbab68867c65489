"""Every figure the commands draw is fit for a report: legends off the data, a unit on every axis.

Each entry of :data:`FIGURES` draws figures with the code a command runs (the command itself where
that is cheap, else the plotting function on a small real run); every figure saved meanwhile is
checked by :func:`figure_checks.problems` (a legend's window holding a data point or crossed by a
drawn line; a numeric axis whose label has no ``[unit]``). Add a figure of your own with
``@figure("its name")`` on a function ``(tmp_path, request) -> None`` that draws it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import figure_checks

#: name -> function(tmp_path, request) drawing figures
FIGURES: dict = {}


def figure(name: str):
    """Register a function drawing figures (see the module docstring)."""
    def register(fn):
        FIGURES[name] = fn
        return fn
    return register


def _cli(*argv) -> None:
    from studies.cli import main

    assert main([str(a) for a in argv]) == 0


# --------------------------------------------------------------------------- reeds
@figure("reed --plot (beam: static shape and free mode)")
def _reed(tmp_path, request):
    _cli("reed", "prototype", "--fidelity", "beam", "--plot", tmp_path / "reed.png")


@figure("table 3.8 --plot (Figure 3.12, exact Euler-Bernoulli)")
def _table_3_8(tmp_path, request):
    _cli("table", "3.8", "--plot", tmp_path / "fig_3_12.png")


@figure("modes --fidelity analytic (mode shapes, Figure 3.12 by fidelity)")
def _modes_analytic(tmp_path, request):
    _cli("modes", "prototype", "stepped2", "--fidelity", "analytic", "--modes", "4", "--out", tmp_path / "m")


@figure("modes --fidelity plate (u_z over the face, nodal lines)")
def _modes_plate(tmp_path, request):
    _cli("modes", "prototype", "--fidelity", "plate", "--modes", "3", "--out", tmp_path / "m")


@figure("check --out (shapes of the FEA fidelities)")
def _check_shapes(tmp_path, request):
    _cli("check", "prototype", "--fidelities", "analytic,beam,plate", "--modes", "0", "--out", tmp_path / "c")


@figure("check --dynamics --out (opening by reed model, modal participation)")
def _reed_dynamics(tmp_path, request):
    from studies.validation import reed_dynamics as rd
    from studies.validation.chain import cases
    from geometry import load_reed

    case = rd.study_reeds(load_reed("prototype"))[0]
    models = [m for m in rd.variants(case, modes=(2, 6), fe=False)]
    by_label, traces = rd.run_point(case, cases(valve="reed")[0], revolutions=2, models=models, trace=True,
                                    method="fast")
    rd._against(by_label, "modal6")
    study = {"reeds": [rd._summary(case, list(by_label.values()), reference="modal6")],
             "rows": list(by_label.values()), "numerics": [], "traces": {case.name: traces},
             "tolerances": {"delivery_pct": 0.1, "angle_deg": 0.5, "method": "fast", "fast_rtol": rd.FAST_RTOL}}
    rd.write_outputs(study, tmp_path)


@figure("identify a plucked reed (ring-down fits of eq 3.67)")
def _ringdown(tmp_path, request):
    from test_reed_identify import G1, HEFF, RHO, synthetic_runs

    from lumped.reed import ringdown as ri
    from studies.plots import plot_ringdown

    traces = synthetic_runs(2)
    plot_ringdown(tmp_path / "ringdown.png", traces, ri.identify(traces, G1, RHO, HEFF)["runs"])


# --------------------------------------------------------------------------- the pump, the sensor
@figure("pump --plot (valve openings and pressures)")
def _pump(tmp_path, request):
    _cli("pump", "--valve", "disc", "--speed-rpm", "593", "--load-pressure-mpa", "2.76", "--plot", tmp_path / "p.png")


@figure("lts --plot (Figures 5.3, 5.4)")
def _lts(tmp_path, request):
    _cli("lts", "--plot", tmp_path / "lts.png")


# --------------------------------------------------------------------------- sweeps and design studies
@figure("sweep --plot (main effects)")
def _sweep(tmp_path, request):
    from pathlib import Path

    from studies.cli.sweep_plot import main_effects_report
    from studies.sweeps import sweep

    root = Path(__file__).resolve().parents[1]
    spec = sweep.load_spec(root / "docs" / "examples" / "sweep_quick.toml")
    sweep.run_sweep(spec, tmp_path / "s", client=request.getfixturevalue("client"), progress=False)
    main_effects_report(tmp_path / "s", None, tmp_path / "main_effects.png", force=True)


@figure("optimize, one objective (the objective per generation)")
def _optimize_one(tmp_path, request):
    from test_optimize import DE, _spec

    from studies.sweeps.design.optimize import run_optimize

    run_optimize(_spec(DE.replace("generations = 60", "generations = 5")), tmp_path / "o",
                 client=request.getfixturevalue("client"), progress=False)


@figure("optimize, two objectives (front, parallel coordinates)")
def _optimize_two(tmp_path, request):
    from test_optimize import ZDT, _spec

    from studies.sweeps.design.optimize import run_optimize

    small = ZDT.replace("population = 40", "population = 12").replace("generations = 80", "generations = 4")
    run_optimize(_spec(small), tmp_path / "o", client=request.getfixturevalue("client"), progress=False)


@figure("sensitivity (Sobol indices with intervals)")
def _sensitivity(tmp_path, request):
    import tomllib

    from test_sensitivity import SPEC

    from studies.sweeps.design import spec as dspec
    from studies.sweeps.design.sensitivity import run_sensitivity

    text = SPEC.replace("2048", "64")
    run_sensitivity(dspec.parse_spec(tomllib.loads(text), "sensitivity", text), tmp_path / "s",
                    client=request.getfixturevalue("client"), progress=False)


# --------------------------------------------------------------------------- the checks
def test_the_checks_can_fail(tmp_path):
    """A legend over the data and an axis without a unit are found; the same figure drawn right passes."""
    from matplotlib.figure import Figure

    from studies.plots import legend_outside

    x = np.linspace(0.0, 1.0, 50)
    bad = Figure()
    ax = bad.subplots()
    ax.plot(x, x, label="rising")
    ax.plot(x, 1 - x, label="falling")
    ax.legend(loc="center")                  # over the crossing of both lines
    ax.set_xlabel("time")
    ax.set_ylabel("opening [mm]")
    found = figure_checks.problems(bad)
    assert any("covers 'rising'" in p for p in found) and any("x axis" in p for p in found)
    good = Figure(figsize=(7, 4), layout="constrained")
    ax = good.subplots()
    ax.plot(x, x, label="rising")
    ax.plot(x, 1 - x, label="falling")
    legend_outside(ax)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("opening [mm]")
    assert figure_checks.problems(good) == []
    # a line crossing the legend between two of its points is found too
    cross = Figure()
    ax = cross.subplots()
    ax.plot([0.0, 1.0], [0.5, 0.5], label="two points")
    ax.legend(loc="center")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    assert any("two points" in p for p in figure_checks.problems(cross))
    # a legend over a bar is found; beside it, not
    bars = Figure()
    ax = bars.subplots()
    ax.bar([0, 1], [1.0, 0.2], label="baseline")
    ax.set_xticks([0, 1], ["fitted", "held out"])
    ax.legend(loc="upper left")
    ax.set_ylabel("position RMS [mm]")
    assert any("the bars 'baseline'" in p for p in figure_checks.problems(bars))
    ax.legend(loc="upper right")
    assert figure_checks.problems(bars) == []


@pytest.mark.parametrize("name", list(FIGURES))
def test_figure_is_fit_for_a_report(name, tmp_path, request, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with figure_checks.capture() as saved:
        FIGURES[name](tmp_path, request)
    assert saved, f"{name}: drew no figure"
    found = [p for path, fig in saved for p in figure_checks.problems(fig, path.rsplit("/", 1)[-1])]
    assert not found, "\n".join(found)
