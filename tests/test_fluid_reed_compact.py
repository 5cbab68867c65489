"""The reed's compact forms (fea.fluid.reed_compact) from given points: the operating line and the X table.

Synthetic points with known laws (a Stokes film: Q = G dP; X constant or linear in x), so each
output has an independent closed form; the 3-D points themselves are computed by the slow studies.
"""

from __future__ import annotations

import numpy as np
import pytest

from fea.fluid import ns3d, reed_compact
from fea.fluid.reed3d import ReedValveFlow
from fea.fluid.reed_mesh import ReedSeat

KAPPA, RHO, MU = 7.709e6, 876.0, 0.0683


@pytest.fixture(scope="module")
def valve():
    from geometry.reed_io import load_reed

    reed = load_reed("prototype")
    s = np.linspace(0, reed.length, 11)
    return ReedValveFlow(reed=reed, seat=ReedSeat(), shape=(s, (s / reed.length) ** 2), fluid=ns3d.Fluid(RHO, MU),
                         orifice_length=19.4e-3, orifice_perimeter=91.2e-3, area_min=55.1e-6, area_max=338.4e-6,
                         stiffness=KAPPA)


def _rows(x: float, G: float, X: float) -> list[dict]:
    return [{"opening": x, "dp": dp, "flow": G * dp, "multiplier": X, "reynolds": 0.0, "cd": 0.0}
            for dp in (1.0, 1e3, 1e4, 1e5)]


def test_operating_line_of_a_linear_film(valve):
    x, G, X, x0 = 0.3e-3, 2.5e-10, 0.8, -0.18e-3
    (p,) = reed_compact.equilibrium_points(_rows(x, G, X), valve, x0)
    dp = KAPPA * (x - x0) / X                                      # eq 3.82
    assert p["dp"] == pytest.approx(dp, rel=1e-12)
    assert p["flow"] == pytest.approx(G * dp, rel=1e-9)            # log-log interpolation is exact for Q ~ dP
    assert p["cd"] == pytest.approx(G * dp / (19.4e-3 * x * np.sqrt(2 * dp / RHO)), rel=1e-9)
    assert p["reynolds"] == pytest.approx(4 * RHO * G * dp / (91.2e-3 * MU), rel=1e-9)


def test_operating_line_beyond_the_points_is_left_out(valve):
    assert reed_compact.equilibrium_points(_rows(0.3e-3, 2.5e-10, 0.001), valve) == []


def test_multiplier_table_finds_the_zero():
    rows = [{"opening": x, "dp": 1e3, "reynolds": 10.0, "multiplier": 0.8 - 500.0 * x} for x in (0.5e-3, 1.0e-3, 2.0e-3)]
    table = reed_compact.multiplier_table(rows, 0.835)
    assert table["X"][0] == 0.835 and table["opening"][0] == 0.0
    assert table["zero_opening"] == pytest.approx(1.6e-3, rel=1e-12)     # 0.8 - 500 x = 0


# ------------------------------------------------------------------------------ the run and its log
def _fake_solvers(monkeypatch, fail_at=None):
    """flow_sweep / displacement_sweep / reed_film replaced by closed forms (Q = G x^3 dP), counting calls;
    the pressure sweep at opening ``fail_at`` [m] raises (an interrupted run) after logging its first point."""
    from dataclasses import dataclass

    calls = {"pressure": [], "moving": []}

    @dataclass
    class P:
        opening: float
        dp: float
        flow: float
        multiplier: float

    @dataclass
    class M:
        opening: float
        speed: float
        fraction: float

    @dataclass
    class F:
        multiplier: float = 0.8356
        base_fraction: float = 0.824

    def pressure(valve, x, reynolds, progress=True, on_point=None, dp_max=None):
        calls["pressure"].append(x)
        out = []
        for dp in (1.0, 1e3):
            out.append(P(x, dp, 1e-3 * x**3 * dp, 0.8))
            on_point(out[-1])
            if fail_at is not None and abs(x - fail_at) < 1e-12:
                raise KeyboardInterrupt
        return out

    def moving(valve, x, speeds, progress=True):
        calls["moving"].append(x)
        return [M(x, u, 0.23) for u in (0.0, *speeds)]

    monkeypatch.setattr(reed_compact, "flow_sweep", pressure)
    monkeypatch.setattr(reed_compact, "displacement_sweep", moving)
    monkeypatch.setattr(reed_compact, "reed_film", lambda valve, x: F())
    return calls


def test_an_interrupted_characterisation_resumes_from_its_log(valve, tmp_path, monkeypatch):
    log = tmp_path / "points.jsonl"
    stop = valve.seat.stop_gap
    third = reed_compact.OPENING_FRACTIONS[2] * stop
    calls = _fake_solvers(monkeypatch, fail_at=third)
    with pytest.raises(KeyboardInterrupt):
        reed_compact.characterise(valve, progress=False, log=log)
    assert len(calls["pressure"]) == 3                  # two sweeps finished, the third cut after one point
    calls = _fake_solvers(monkeypatch)
    raw = reed_compact.characterise(valve, progress=False, log=log)
    # the two finished sweeps are read, the cut one and the rest are solved whole
    assert calls["pressure"] == pytest.approx([f * stop for f in reed_compact.OPENING_FRACTIONS[2:]])
    assert len(calls["moving"]) == len(reed_compact.DISPLACEMENT_FRACTIONS)
    assert len(raw["rows"]) == 2 * len(reed_compact.OPENING_FRACTIONS)
    assert sorted(r["opening"] for r in raw["rows"]) == pytest.approx(
        sorted(2 * [f * stop for f in reed_compact.OPENING_FRACTIONS]))
    # a third run solves nothing
    calls = _fake_solvers(monkeypatch)
    again = reed_compact.characterise(valve, progress=False, log=log)
    assert calls == {"pressure": [], "moving": []} and again["rows"] == raw["rows"]


def test_the_cost_estimate_counts_the_solves():
    c = reed_compact.cost_estimate()
    n_open, n_re = len(reed_compact.OPENING_FRACTIONS), reed_compact.SWEEP_POINTS
    n_move = len(reed_compact.DISPLACEMENT_FRACTIONS)
    assert c["stokes"] == n_open + n_move and c["newton"] == n_open * n_re + 2 * n_move
    lo, hi = c["wall_seconds"]
    assert 0 < lo < hi and c["cpu_seconds"] > 0


def test_the_pump_warns_beyond_the_computed_range():
    """fluid = "predicted" sets the range the forms were computed on; a run beyond it is warned."""
    from dataclasses import replace

    from lumped import load_model
    from lumped.validity import ValveRun, valve_warnings

    m = load_model("thesis-reed")
    run = ValveRun(position="delivery", kind="reed", opened=True, peak_opening=1.0e-3, min_opening=0.0,
                   seat_penetration=0.0, stop_penetration=0.0, max_reynolds=80.0, max_dp=1e5,
                   forward_volume=2e-6, backward_volume=1e-7, energy_loss=0.1)
    assert not [w for w in valve_warnings(m.delivery, run, m.oil) if w.code == "fluid_range"]   # empirical
    v = replace(m.delivery, fluid_opening_max=0.8e-3, fluid_reynolds_max=62.0)
    texts = [w.message for w in valve_warnings(v, run, m.oil) if w.code == "fluid_range"]
    assert len(texts) == 2 and "0.8 mm" in texts[0] and "62" in texts[1]
    inside = replace(run, peak_opening=0.5e-3, max_reynolds=30.0)
    assert not [w for w in valve_warnings(v, inside, m.oil) if w.code == "fluid_range"]


def test_eq_3_83_form_recovers_the_thesis_fit():
    """A table sampled from eq 3.83 itself (thesis coefficients, openings 0.1-1.2 mm) is fitted back within
    0.5 % of X with its zero at the thesis's 1.369 mm (within 3 %), no pole before it."""
    from lumped.valves.reed import pressure_load_multiplier

    c = (-52.28, 0.07158, 0.8145, -50.23, 0.08292)
    xs = np.linspace(0.1e-3, 1.2e-3, 12)
    X = [pressure_load_multiplier(x, 0.835, *c, 0.07158 / 52.28) for x in xs]
    fit = reed_compact.fit_multiplier({"opening": [0.0, *xs], "X": [0.835, *X]}, 0.835)
    assert fit["pole"] is None and fit["max_abs"] < 0.005
    assert fit["zero_opening"] == pytest.approx(0.07158 / 52.28, rel=0.03)


def test_eq_3_83_form_keeps_the_zero_beyond_the_computed_openings():
    """X that stays near 0.8 up to the largest opening: the fitted zero lies beyond it (the pump would
    otherwise take X = 0 where the flow gives 0.8)."""
    xs = [0.1e-3, 0.3e-3, 0.6e-3, 1.0e-3, 1.3e-3, 1.7e-3]
    X = [0.836, 0.833, 0.825, 0.80, 0.785, 0.772]
    fit = reed_compact.fit_multiplier({"opening": [0.0, *xs], "X": [0.8356, *X]}, 0.8356)
    assert fit["zero_opening"] > 1.7e-3 and fit["pole"] is None and fit["max_abs"] < 0.01


def test_the_thesis_reeds_forms_are_shipped(tmp_path, monkeypatch):
    """fluid = "predicted" on thesis-reed reads fea/fluid/data (an empty cache, no solve allowed): the
    forms replace Cd, X and f1, f2, and the range they were computed on comes with them."""
    import fea.fluid  # noqa: F401  (registers the predicted forms)
    from lumped import load_model
    from lumped.model.model_file import with_values

    monkeypatch.setenv("VALVELAB_CACHE_DIR", str(tmp_path))

    def no_solve(*a, **k):
        raise AssertionError("the shipped forms must be used, nothing computed")
    monkeypatch.setattr(reed_compact, "characterise", no_solve)
    monkeypatch.setattr(reed_compact, "reed_film", no_solve)
    m = with_values(load_model("thesis-reed"), {"valves.inlet.fluid": "predicted", "valves.delivery.fluid": "predicted"})
    for v in (m.inlet, m.delivery):
        assert v.fluid == "predicted" and 0.0 < v.f1 < 1.0 and 0.0 < v.f2 < 1.0
        assert (v.f1, v.f2) != (0.22, 0.35) and v.cd_lift_exponent != 0.0
        assert v.fluid_opening_max > 1e-3 and v.fluid_reynolds_max > 1.0
        assert v.multiplier_poiseuille == pytest.approx(0.8356, abs=1e-3)   # the film's plateau, F4 computed
        assert v.multiplier_zero > v.fluid_opening_max                     # the fit keeps X's zero beyond
    assert list(tmp_path.iterdir()) == []
