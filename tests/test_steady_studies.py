"""The studies' steady-state stop and warm starts: sweeps' batches, Monte Carlo draws, validate's reference runs,
and the caches that serve them, each against an independent run (40 revolutions from today's start, the
cold run, the uncached computation)."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.errors import InputError
from lumped import simulate
from studies.sweeps import sweep
from studies.sweeps.locality import features, locality_order
from studies.sweeps.pump import build_model


def _batch(n=24, seed=2):
    rng = np.random.default_rng(seed)
    return [(i, {"valve": ("disc", "reed")[i % 2], "speed_rpm": float(rng.uniform(450, 950)),
                 "load_pressure": float(rng.uniform(1.5e6, 4.5e6)), "air_content": float(rng.uniform(0, 0.03))})
            for i in range(n)]


def test_a_warm_started_batch_equals_40_revolution_runs():
    """A sweep batch as a worker runs it (nearest-neighbour chain, each design from its neighbours' state, until
    steady): every delivery within 1e-4 (plus the integrator's own spread) of 40 revolutions from today's start,
    most designs after two revolutions, the first of each valve type from today's start."""
    batch = _batch()
    rows = {r["design_id"]: r for r in sweep.evaluate_batch("pump", {}, batch)}
    assert all(r["status"] == "ok" for r in rows.values())
    assert sum(not r["warm_started"] for r in rows.values()) == 2          # one cold start per valve type
    assert np.mean([r["revolutions_run"] for r in rows.values()]) < 2.5
    for i, d in batch:
        long = simulate(build_model(d), d["speed_rpm"], d["load_pressure"], air_content=d["air_content"],
                        revolutions=40)
        tail = np.array(long.deliveries[-10:])
        noise = np.ptp(tail) / tail.mean()
        assert abs(rows[i]["delivery_m3_per_rev"] / long.delivery_per_rev - 1) <= 1e-4 + noise, d


def test_sweep_revolution_inputs():
    """``revolutions`` alone is a fixed count (the first sweep files), ``warm_start = false`` starts cold."""
    batch = _batch(4)
    fixed = sweep.evaluate_batch("pump", {"revolutions": 3, "warm_start": False}, batch)
    assert all(r["revolutions_run"] == 3 and not r["warm_started"] for r in fixed)
    least = sweep.evaluate_batch("pump", {"revolutions": 3, "max_revolutions": 6}, batch)
    assert all(3 <= r["revolutions_run"] <= 6 for r in least)


def test_close_designs_stop_after_one_revolution_within_the_integrators_error():
    """A batch of close designs (a sweep's dense corner): the warm-started ones mostly stop after one revolution
    (the one-revolution test), each delivery within the steady tolerance (1e-3) of a sharp reference (rtol 1e-5,
    12 revolutions), as close to it as the same batch run with two revolutions at least; ``one_revolution =
    false`` gives two at least, a non-boolean exits as an input error."""
    rng = np.random.default_rng(5)
    batch = [(i, {"valve": "disc", "speed_rpm": float(rng.uniform(590, 610)),
                  "load_pressure": float(rng.uniform(2.7e6, 2.8e6)), "air_content": 0.01}) for i in range(12)]
    one = {r["design_id"]: r for r in sweep.evaluate_batch("pump", {}, batch)}
    two = {r["design_id"]: r for r in sweep.evaluate_batch("pump", {"one_revolution": False}, batch)}
    assert sum(r["revolutions_run"] == 1 for r in one.values()) >= 8
    assert all(r["revolutions_run"] >= 2 for r in two.values())
    err1, err2 = [], []
    for i, d in batch:
        sharp = simulate(build_model(d), d["speed_rpm"], d["load_pressure"], air_content=d["air_content"],
                         revolutions=12, rtol=1e-5).delivery_per_rev
        err1.append(abs(one[i]["delivery_m3_per_rev"] / sharp - 1))
        err2.append(abs(two[i]["delivery_m3_per_rev"] / sharp - 1))
    assert max(err1) < 1e-3 and max(err2) < 1e-3
    assert np.median(err1) <= 2 * np.median(err2) + 1e-5
    with pytest.raises(InputError, match="one_revolution"):
        from studies.sweeps.pump import check
        check("one_revolution", 1)


def test_locality_order_keeps_neighbours_together_and_groups_apart():
    rng = np.random.default_rng(0)
    designs = [{"x": float(x), "y": float(y), "kind": k} for x, y, k in zip(rng.random(256), rng.random(256),
                                                                            rng.choice(["a", "b"], 256))]
    X, groups = features(designs)
    order = locality_order(X, groups, leaf=16)
    assert sorted(order) == list(range(256))
    kinds = [designs[i]["kind"] for i in order]
    assert kinds == sorted(kinds, key=lambda k: kinds.index(k))        # one group after the other
    # consecutive designs are near: the mean step between them is a third of the sampled order's
    def step(o):
        return np.mean([np.linalg.norm(X[a] - X[b]) for a, b in zip(o, o[1:]) if groups[a] == groups[b]])

    assert step(order) < step(list(range(256))) / 3


def test_monte_carlo_draws_warm_equal_cold():
    """Draws of u_input run to steady state from their neighbours' state give the outputs of each draw run on its
    own from today's start, to 1e-5."""
    from dataclasses import replace

    from lumped.model.model_file import load_model, with_values
    from lumped.model.uncertainty import check_reach, numeric_keys, sample_values
    from studies.validation.input_uncertainty import MC_ATOL, MC_RTOL, evaluate_draws
    from studies.validation.numerical import OUTPUTS, output_values

    model = load_model("thesis-disc")
    decls = tuple(model.uncertainties)
    check_reach(model, decls)
    bare = replace(model, uncertainties=())
    keys = numeric_keys(bare)
    zs = list(np.random.default_rng(4).normal(size=(6, len(decls))) * 0.5)
    warm = evaluate_draws(bare, 593.0, 2.76e6, decls, keys, zs, {"revolutions": 2, "max_revolutions": 12},
                          outputs=("delivery_cc_per_rev",))
    for z, w in zip(zs, warm):
        cold = simulate(with_values(bare, sample_values(bare, decls, z, keys)), 593.0, 2.76e6,
                        method="fast", rtol=MC_RTOL, atol=MC_ATOL, revolutions=8)
        ref = output_values(cold, {"delivery_cc_per_rev": OUTPUTS["delivery_cc_per_rev"]})["delivery_cc_per_rev"]
        assert w["delivery_cc_per_rev"] == pytest.approx(ref, rel=1e-5)


def test_validation_case_from_the_fast_cycle_equals_the_cold_reference():
    """A validation case's reference run started from the fast path's cycle (three revolutions) delivers what five
    revolutions from today's start deliver, to 1e-7."""
    from studies.validation.chain import LEGACY, cases, run_case

    case = cases(valve="disc")[0]
    warm = run_case(case, trace=False)
    cold = run_case(case, trace=False, settings=LEGACY, warm=False)
    assert warm.start == "warm" and cold.start == "cold" and warm.revolutions == 3 and cold.revolutions == 5
    assert warm.delivery_per_rev == pytest.approx(cold.delivery_per_rev, rel=1e-7)


def test_packed_valve_block_cache_gives_the_uncached_block():
    from lumped.solver.layout import _valve_block, pack
    from lumped.model.model_file import load_model

    for name in ("thesis-disc", "thesis-reed"):
        m = load_model(name)
        a = pack(m, 600.0, 2.8e6)
        _valve_block.cache_clear()
        b = pack(m, 600.0, 2.8e6)
        assert np.array_equal(a, b)
        for v in (m.inlet, m.delivery):
            idx, vals, tail = _valve_block(v, m.oil)
            idx2, vals2, tail2 = _valve_block.__wrapped__(v, m.oil)
            assert np.array_equal(vals, vals2) and (tail is None) == (tail2 is None)


def test_stress_at_the_stop_reuses_the_solid_solve():
    """The solid FEA's stress at the stop after its kappa solve (the same 1 Pa solution scaled) equals the stress
    computed on its own (coarse mesh: seconds)."""
    from fea import solid
    from fea.reed_stress import max_opening_stress
    from geometry import load_reed

    reed = load_reed("stepped1")
    solid._LAST_STATIC.clear()
    alone = max_opening_stress(reed, x_stop=1e-3, mesh_size=2e-3)
    solid.solve(reed, mesh_size=2e-3, layers=1)
    assert solid.last_static(reed, 2e-3, 1, solid.is_symmetric(reed)) is not None
    reused = max_opening_stress(reed, x_stop=1e-3, mesh_size=2e-3)
    assert reused.max_von_mises_away_from_clamp == pytest.approx(alone.max_von_mises_away_from_clamp, rel=1e-9)
    assert reused.pressure == pytest.approx(alone.pressure, rel=1e-9)
