"""The search machinery on a cheap stand-in pump (tests/standin.py): hidden effects are found.

The physics acceptance tests with valvelab's pump model are in test_discrepancy_pump.py;
these check the fitting, nuisance handling, held-out scoring, significance and
stopping logic in a fraction of a second per simulation.
"""

import json
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

import standin
from lumped.model.effects import Applied, Effect, Library, Parameter
from studies.discrepancy.backward import backward
from studies.discrepancy.fitting import box_search
from studies.discrepancy.selection import verdict
from studies.discrepancy.workflow import CandidateFit, Settings, Workflow, conditions, split
from studies.discrepancy.synth import Condition, Noise, synthesize

THESIS_DISC = [Condition(593, 2.76e6, "inlet"), Condition(593, 2.79e6, "delivery"),
               Condition(743, 2.81e6, "inlet"), Condition(743, 2.75e6, "delivery"),
               Condition(591, 3.67e6, "inlet"), Condition(591, 3.78e6, "delivery")]


def find(truth, seed=0, conds=THESIS_DISC, library=standin.LIB, **settings):
    runs, _ = synthesize(standin.simulate, "disc", conds, truth, Noise(), seed=seed)
    return Workflow(runs, standin.simulate, library, Settings(**settings), progress=False).run().as_contract()


def test_conditions_and_split_follow_the_thesis_runs():
    runs, _ = synthesize(standin.simulate, "disc", THESIS_DISC, (), Noise(), seed=0)
    groups = conditions(runs)
    assert [len(g) for g in groups] == [2, 2, 2]
    fit, held = split(runs)
    assert {r.speed_rpm for r in held} == {593.0} and len(fit) == 4


@pytest.mark.parametrize("seed", [0, 1])
def test_hidden_seat_compliance_found_and_recovered(seed):
    out = find((Applied.of("seat_compliance", "delivery", {"k_seat": 1.5e6}),), seed=seed)
    assert out["effects_added"] == ["seat_compliance"] and out["targets"]["seat_compliance"] == "delivery"
    assert out["parameters"]["seat_compliance"]["k_seat"] == pytest.approx(1.5e6, rel=0.2)
    assert out["held_out"]["position_rms_reduction_pct"] >= 70
    assert any("delivery valve sits" in s and "below" in s for s in out["disagreements"])


def test_one_parameter_fit_brackets_both_sides_of_the_best_grid_point():
    # k_seat = 1.2e6 lies just above the coarse grid point 1e6 (bounds 1e5-1e10, six points):
    # the fine grid's middle point falls on 1e6 again, and Brent must still search above it
    out = find((Applied.of("seat_compliance", "delivery", {"k_seat": 1.2e6}),), seed=0)
    assert out["effects_added"] == ["seat_compliance"]
    assert out["parameters"]["seat_compliance"]["k_seat"] == pytest.approx(1.2e6, rel=0.08)


def test_several_parameter_fit_is_not_stalled_by_a_rippled_cost():
    # the pump's cost is rippled: ~2 gap units for a change of 1e-5 of a range (the fast path's
    # disc lift-off jitters by degrees, README "Pump speed"). A two-parameter valley with such
    # ripple: least squares from the start stalls short of it (the flow force's jet angle and
    # oil-column length did); the grid over the plausible box and the pattern search must reach it
    runs, _ = synthesize(standin.simulate, "disc", THESIS_DISC, (), Noise(), seed=0)
    wf = Workflow(runs, standin.simulate, standin.LIB, Settings(), progress=False)
    params = [Parameter("a", "-", 1.0, (1e-2, 1e2), (1e-1, 1e1), "test"),
              Parameter("b", "-", 1.0, (1e-2, 1e2), (1e-1, 1e1), "test")]
    best = (0.41, 0.63)                        # units: inside the plausible box (0.25-0.75)

    def cost(model):
        u = model[0]
        ripple = 4.0 * ((1e6 * u[0] + 3e6 * u[1]) % 1.0)               # 0-4 units, a sawtooth
        return 60.0 + 20.0 * (u[0] - best[0]) ** 2 + 1700.0 * (u[1] - best[1]) ** 2 + ripple

    calls = []
    ob = SimpleNamespace(model_of=lambda x: (tuple(x),), cost=lambda m: calls.append(m) or cost(m),
                         relinearize=lambda u, stage: False, simulate=lambda points: None)  # no simulation needed
    u, hopeless = box_search(wf.problem, params, np.array([0.5, 0.5]), ob)
    assert not hopeless
    assert abs(u[1] - best[1]) < 0.03 and abs(u[0] - best[0]) < 0.2   # least squares from (0.5, 0.5): 0.038
    assert cost((tuple(u),)) < 62.0
    assert len(calls) <= 1 + 25 + 3 * 8                               # grid, then three pattern levels


def test_nothing_hidden_nothing_added():
    out = find((), seed=3)
    assert out["effects_added"] == []
    # the discharge-coefficient nuisance stays near 1 (the data have no Cd error) ...
    assert out["baseline_nuisances"]["discharge_scale"]["values"]["scale"] == pytest.approx(1.0, abs=0.01)
    # ... and without nuisances the final model is the baseline itself
    plain = find((), seed=3, nuisance_effects=())
    assert plain["effects_added"] == [] and plain["baseline_nuisances"] == {}
    assert plain["gap_after"] == plain["gap_before"]


def test_two_hidden_effects_both_named(tmp_path):
    from studies.discrepancy.report import write_report

    truth = (Applied.of("seat_compliance", "inlet", {"k_seat": 3e6}),
             Applied.of("piston_leakage", "pump", {"leak_per_mpa": 0.02}))
    runs, _ = synthesize(standin.simulate, "disc", THESIS_DISC, truth, Noise(), seed=4)
    outcome = Workflow(runs, standin.simulate, standin.LIB, Settings(), progress=False).run()
    out = outcome.as_contract()
    rep = write_report(tmp_path / "rep", outcome, runs, out)
    assert "# The backward step" in (rep / "ranking.md").read_text()       # the removals tried, both kept
    assert "dropped again" not in (rep / "disagreements.txt").read_text()
    assert sorted(out["effects_added"]) == ["piston_leakage", "seat_compliance"]
    assert out["targets"]["seat_compliance"] == "inlet"
    # the backward step took each out once (the first after the second was added, the second at the end)
    # and kept both
    assert {r["effect"] for r in out["backward"]} == {"piston_leakage", "seat_compliance"}
    assert not any(r["dropped"] for r in out["backward"]) and out["effects_dropped"] == []
    assert out["parameters"]["piston_leakage"]["leak_per_mpa"] == pytest.approx(0.02, rel=0.2)


def test_model_error_outside_the_library_is_not_dressed_up_as_an_effect():
    # the discharge coefficient is 3 % off in the "truth"; no candidate models that
    out = find((Applied.of("discharge_scale", "pump", {"scale": 1.03}),), seed=5)
    assert out["effects_added"] == []


def test_large_sensor_nuisances_are_not_effects():
    runs, truth = synthesize(standin.simulate, "disc", THESIS_DISC, (),
                             Noise(scale_error=(0.03, -0.03), time_offset_s=4e-4), seed=6)
    out = Workflow(runs, standin.simulate, standin.LIB, Settings(), progress=False).run().as_contract()
    assert out["effects_added"] == []
    assert out["nuisance"]["before"]["scale_inlet"] == pytest.approx(1.03, abs=0.003)
    assert out["nuisance"]["before"]["time_offset_s"] == pytest.approx(4e-4, abs=2e-5)


def test_a_new_effect_is_one_entry(monkeypatch):
    # registering one Effect is all it takes: the simulator applies it, the workflow searches it
    monkeypatch.setattr(standin, "LIB", Library(dict(standin.LIB.effects)))
    standin.LIB.register(Effect("air_twin", "same as entrained air under another name",
                                (Parameter("R", "-", 0.01, (1e-4, 0.2), (1e-4, 0.1), "test"),),
                                lambda p, v, t: replace(p, air=v["R"]), targets=("pump",)))
    out = find((Applied.of("entrained_air", "pump", {"R": 0.01}),), seed=7, library=standin.LIB, max_rounds=1)
    names = {row["effect"] for row in out["ranking"]}
    assert "air_twin" in names
    # the same model under two names: the data cannot say which, so neither is named and both are reported
    assert out["effects_added"] == []
    assert [sorted(g["effects"]) for g in out["indistinguishable"]] == [["air_twin", "entrained_air"]]


def test_implausible_fit_is_never_added():
    # the truth lies beyond the plausible range of the only matching candidate
    out = find((Applied.of("closing_lag", "both", {"lag_deg": 60.0}),), seed=8)
    row = next(r for r in out["ranking"] if r["effect"] == "closing_lag")
    assert not row["plausible"] and "plausible" in row["why_not_plausible"]
    assert "closing_lag" not in out["effects_added"]


def test_parameter_bounds_and_plausibility():
    p = Parameter("k", "N/m", 1e6, (1e5, 1e9), (2e5, 5e8), "test")
    assert p.from_unit(p.to_unit(3.3e6)) == pytest.approx(3.3e6)
    assert p.plausibility(1e6) is None
    assert "bound" in p.plausibility(1.0001e5)
    assert "plausible" in p.plausibility(1.5e5)
    with pytest.raises(ValueError):
        Parameter("k", "N/m", 1e4, (1e5, 1e9), (1e5, 1e9), "test")
    lib = Library()
    e = Effect("x", "", (p,), lambda a, v, t: a)
    lib.register(e)
    with pytest.raises(ValueError):
        lib.register(e)
    assert math.isclose(Applied.of("x", "both", {"k": 2.0}).value_dict["k"], 2.0)


def test_a_candidate_the_model_cannot_simulate_is_reported_not_fatal(monkeypatch):
    import json

    def broken(p, v, t):
        raise RuntimeError("integrator failed")

    monkeypatch.setattr(standin, "LIB", Library(dict(standin.LIB.effects)))
    standin.LIB.register(Effect("broken", "always fails", (Parameter("a", "-", 1.0, (0.1, 10.0), (0.1, 10.0), "t"),),
                                broken, targets=("pump",)))
    out = find((Applied.of("seat_compliance", "delivery", {"k_seat": 1.5e6}),), seed=9, library=standin.LIB,
               max_rounds=1)
    assert out["effects_added"] == ["seat_compliance"]
    row = next(r for r in out["ranking"] if r["effect"] == "broken")
    assert row["failed"] and not row["accepted"]
    json.dumps(out, allow_nan=False)   # no infinities leak into the JSON


def test_confusion_tool_synthesises_and_fits_with_the_valves_asked_for(monkeypatch, capsys):
    """`python -m studies.discrepancy.confusion --valve reed` must build and fit reed datasets with the
    reed pump (it once used the disc pump for every --valve, so reed effects did nothing)."""
    from studies.discrepancy import confusion

    seen = []

    def fake_run_case(case, spec, valve, seed, sim, settings, **kw):
        seen.append((valve, sim.simulate.model.label))
        return {"case": case, "seed": seed, "found": [], "expected": [], "correct": True}

    monkeypatch.setattr(confusion, "run_case", fake_run_case)
    for valve in ("reed", "disc"):
        case = next(iter(confusion.CASES[valve]))
        assert confusion.main(["--valve", valve, "--seeds", "1", "--cases", case]) == 0
    capsys.readouterr()
    assert seen == [("reed", "reed"), ("disc", "disc")]


def _candidate(fit_after: float, held_before: float, held_after: float) -> CandidateFit:
    return CandidateFit("piston_leakage", "pump", {}, {}, fit_cost=fit_after, held_cost=held_after, delta_bic=-100.0,
                        plausible_reason=None, n_sims=0, base_fit_cost=100.0, base_held_cost=held_before)


@pytest.mark.parametrize("fit_after, held_after, added", [
    (93.3, 1.30, True),       # the reed's 25 um leak (seed 3): the fit 6.7 % better, 33 % held-out gain
    (97.2, 1.30, False),      # the same held-out gain with the fit 2.8 % better (a wrong seat compliance)
    (93.3, 1.50, False),      # fit 6.7 % better, 22 % held out: below the relative threshold
])
def test_decisive_fit_evidence_lowers_the_held_out_floor(fit_after, held_after, added):
    """A held-out gain of 0.63 units (1.93 -> 1.30) is below the 1.5-unit floor a Cd nuisance sets, yet
    with the fit 5 % better or more (Settings.decisive_fit_improvement) it is enough; the relative
    threshold (30 %) holds in every case, and a floor the user set applies as set."""
    why = verdict(_candidate(fit_after, 1.93, held_after), Settings(), 1.5)     # 1.5: the floor with a Cd nuisance
    assert (why is None) == added, why
    assert verdict(_candidate(fit_after, 1.93, held_after), Settings(min_abs_improvement=1.5), 1.5) is not None


@pytest.mark.parametrize("target", ["delivery", "both"])
def test_an_effect_is_placed_on_the_valve_the_data_say(target):
    """An effect with a placement (squeeze film, flow force) is fitted on both valves and on each alone: a lag
    hidden on the delivery valve only is named there, one on both valves on both."""
    out = find((Applied.of("opening_lag", target, {"lag_deg": 12.0}),), seed=11)
    assert out["effects_added"] == ["opening_lag"] and out["targets"]["opening_lag"] == target
    assert out["parameters"]["opening_lag"]["lag_deg"] == pytest.approx(12.0, rel=0.1)


def test_a_large_gap_is_never_silent():
    """A discharge coefficient 25 % off (beyond the nuisance's 10 %; no candidate models it): nothing may be
    named, and the report must say how large the gap left is, where, what the best candidates explain of it,
    and that the Cd factor sits at its bound."""
    out = find((Applied.of("discharge_scale", "pump", {"scale": 1.25}),), seed=12)
    u = out["unexplained"]
    assert u["large"] and u["cost"]["after"] > u["cost"]["limit"]
    assert u["sentences"] and u["sentences"][0].startswith("the model leaves a large gap")
    assert u["by_signal"] and max(u["by_signal"].values()) > 0
    assert any("sits at its bound" in s for s in u["nuisances_at_bound"])
    # clean data: nothing large, nothing said
    clean = find((), seed=12)["unexplained"]
    assert not clean["large"] and clean["sentences"] == []


@pytest.mark.parametrize("gain, worse, added", [(13800.0, 2.16, True), (100.0, 7.0, False), (30.0, 1.6, False)])
def test_a_kind_of_evidence_may_get_a_little_worse_for_a_large_gain(gain, worse, added):
    """The squeeze film of the issue removed ~13,800 units and left the delivery 2.16 units worse: accepted
    (no model is the truth); a candidate that gains 100 units and costs 7 of delivery trades one kind of
    evidence for another (a leak standing in for a Cd error); a small gain may not worsen a kind by a unit."""
    f = _candidate(100.0 - 0.06 * gain, 100.0, 1.0)
    f.base_fit_parts = {"position": gain, "delivery": 0.0, "pressure": 0.0}
    f.fit_parts = {"position": 0.0, "delivery": worse, "pressure": 0.0}
    f.base_held_parts = f.held_parts = {"position": 1.0, "delivery": 0.0, "pressure": 0.0}
    why = verdict(f, Settings(), 1.5)
    assert (why is None) == added, why


def test_a_fit_at_the_edge_of_the_plausible_range_is_not_plausible():
    """A box search bounded by the plausible range can end on its edge (the issue's flow force: L_t 1.32 mm
    at a plausible minimum of 1.30 mm): that is a fit wanting to go beyond it, not a plausible value."""
    p = Parameter("L_t", "m", 5.2e-3, (2.6e-4, 0.104), (1.3e-3, 2.08e-2), "test")
    assert p.plausibility(5.2e-3) is None
    assert "edge" in p.plausibility(1.302e-3)
    assert "edge" in p.plausibility(2.07e-2)
    assert "outside" in p.plausibility(1.2e-3)


def test_warm_starts_come_from_the_nearest_model_of_the_same_effects_or_the_one_it_extends():
    from studies.discrepancy.workflow import RunCondition, Simulations
    from studies.discrepancy.gap import CycleTrace

    class Sim:
        warm_start = True

        def __call__(self, cond, model, warm=None):
            out = CycleTrace(np.arange(0.0, 360.0, 1.0), {"inlet": np.zeros(360), "delivery": np.zeros(360)}, 1e-6)
            object.__setattr__(out, "state", np.array([float(len(model))] + [v for a in model for _, v in a.values]))
            return out

    c = RunCondition("r", "disc", 600.0, 2.8e6, None)
    sims = Simulations(Sim())
    cd = Applied.of("discharge_scale", "both", {"scale": 1.0})
    seat = lambda k: Applied.of("seat_compliance", "inlet", {"k_seat": k})
    sims.many([(c, (cd,)), (c, (cd, seat(1e6))), (c, (cd, seat(1e8)))])
    state, near = sims._warm_state((c, (cd, seat(1.05e6))))
    assert near and state[-1] == 1e6                       # the same effects, a factor 1.05 away
    state, near = sims._warm_state((c, (cd, seat(3e7))))
    assert not near and list(state) == [1.0, 1.0]          # farther than WARM_NEAR: from the model it extends
    state, near = sims._warm_state((c, (cd, Applied.of("piston_leakage", "pump", {"clearance": 4e-5}))))
    assert not near and list(state) == [1.0, 1.0]          # another effect: from the model it extends


def test_confusion_tables_merge_seeds_run_apart(tmp_path, capsys):
    """--tables --merge: the datasets of several saved runs counted as one study (seeds run apart): the counts
    add up and every case's row holds the datasets of both files."""
    from studies.discrepancy.confusion import main

    def result(case, seed, found, expected):
        return {"case": case, "seed": seed, "found": found, "expected": expected, "correct": found == expected,
                "targets": {n: "pump" for n in found}, "relative_errors": {}, "held_out_cost": [10.0, 1.0],
                "held_out_cost_reduction_pct": 90.0 if found else None,
                "unexplained": {"large": False, "sentences": []}, "workflow_seconds": 1.0 + seed,
                "workflow_cpu_seconds": 1.0, "load_average": 1.0}

    files = []
    for seeds in ((1,), (2, 3)):
        rs = [result("piston_leakage", s, ["piston_leakage"] if s != 3 else [], ["piston_leakage"]) for s in seeds]
        rs += [result("none", s, [], []) for s in seeds]
        p = tmp_path / f"s{seeds[0]}.json"
        p.write_text(json.dumps({"summary": {"label": "pump (disc), library"}, "matrix": {}, "results": rs}))
        files.append(str(p))
    assert main(["--tables", *files, "--merge"]) == 0
    out = capsys.readouterr().out
    assert "**pump (disc), library**: 5/6 named exactly" in out and "0 false positives on 3 clean" in out
    assert "| piston_leakage | 2/3 |" in out and "| none | 3/3 |" in out


def test_the_backward_step_drops_an_effect_the_others_made_redundant():
    """An effect added before the right one (a stand-in) is dropped once the right one is in: taken out, the
    others refitted, the acceptance rule would not add it back; effects that are there both stay."""
    truth = (Applied.of("seat_compliance", "inlet", {"k_seat": 3e6}),
             Applied.of("piston_leakage", "pump", {"leak_per_mpa": 0.02}))
    runs, _ = synthesize(standin.simulate, "disc", THESIS_DISC, truth, Noise(), seed=4)
    wf = Workflow(runs, standin.simulate, standin.LIB, Settings(), progress=False)
    cd = Applied.of("discharge_scale", "pump", {"scale": 1.0})
    # both hidden effects in the model: neither is dropped (each loses the held-out gap when taken out)
    rows, dropped = [], set()
    model = (cd, truth[0], truth[1])
    current, _ = backward(wf.problem, model, wf.evaluate(model), 2, rows, dropped, None)
    assert sorted(a.name for a in current) == ["discharge_scale", "piston_leakage", "seat_compliance"]
    assert not dropped and len(rows) == 2 and not any(r["dropped"] for r in rows)
    # a closing lag added before them (it stands in for nothing here): dropped, the two kept
    rows, dropped = [], set()
    model = (cd, Applied.of("closing_lag", "both", {"lag_deg": 0.5}), truth[0], truth[1])
    current, ev = backward(wf.problem, model, wf.evaluate(model), 3, rows, dropped, "piston_leakage")
    assert sorted(a.name for a in current) == ["discharge_scale", "piston_leakage", "seat_compliance"]
    assert dropped == {"closing_lag"}
    gone = [r for r in rows if r["dropped"]]
    assert [r["effect"] for r in gone] == ["closing_lag"] and gone[0]["why_dropped"]
    assert ev.held_cost <= gone[0]["held_out_cost"]          # the model without it explains the held-out runs


def test_confusion_tables_set_a_low_held_out_reduction_against_the_clean_dataset_of_its_seed():
    """A right name with a held-out reduction below 70 % is listed beside what the clean dataset of the same seed
    and data form leaves (the part no candidate takes): (100 - 40) of (100 - 40) = 100 % of the part above it."""
    from studies.discrepancy.confusion import low_reductions

    def result(case, seed, found, held):
        return {"case": case, "seed": seed, "found": found, "expected": found, "correct": True,
                "held_out_cost": held, "held_out_cost_reduction_pct": 100 * (1 - held[1] / held[0]) if found else None}

    rs = [result("piston_leakage [sensor]", 1, ["piston_leakage"], [100.0, 40.0]),
          result("none [sensor]", 1, [], [40.0, 40.0]), result("piston_leakage", 1, ["piston_leakage"], [50.0, 1.0])]
    text = low_reductions(rs)
    assert text.count("\n") == 0 and "piston_leakage [sensor], seed 1: held-out cost 100 -> 40 (60 %)" in text
    assert "leaves 40 held out, so 100 % of the part above it is explained" in text
