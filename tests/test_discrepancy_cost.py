"""What the discrepancy search saves on its cost does not change what it computes.

On the cheap stand-in pump (tests/standin.py): the fit residuals kept for a model (problem.RESIDUAL_MEMO) are
those a fresh problem computes, handed out as copies, recomputed once forgotten; the worker pool is started after
the simulator has made itself ready, and the workers (forked) inherit that.
"""

import os

import numpy as np

import standin
from lumped.model.effects import Applied
from studies.discrepancy import problem as problem_mod
from studies.discrepancy.gap import CycleTrace
from studies.discrepancy.records import RunCondition
from studies.discrepancy.simulations import Simulations
from studies.discrepancy.synth import Noise, synthesize
from studies.discrepancy.workflow import Settings, Workflow

from test_discrepancy_machinery import THESIS_DISC


def _problem():
    runs, _ = synthesize(standin.simulate, "disc", THESIS_DISC,
                         (Applied.of("seat_compliance", "delivery", {"k_seat": 1.5e6}),), Noise(), seed=0)
    return Workflow(runs, standin.simulate, standin.LIB, Settings(), progress=False).problem


def _seat(k):
    return (Applied.of("seat_compliance", "delivery", {"k_seat": k}),)


def test_kept_residuals_are_a_fresh_computation_handed_out_as_copies(monkeypatch):
    pb, fresh = _problem(), _problem()
    calls = []
    real = problem_mod.Problem.sensor_nuisance
    monkeypatch.setattr(problem_mod.Problem, "sensor_nuisance", lambda self, sims: calls.append(1) or real(self, sims))
    r1, n1 = pb.fit_residuals(_seat(2e6))
    sims_after_first, fits_after_first = pb.sims.count, len(calls)
    r1[:] = 0.0                                              # the caller's copy: the kept one is untouched
    r2, n2 = pb.fit_residuals(_seat(2e6))
    assert pb.sims.count == sims_after_first and len(calls) == fits_after_first    # nothing recomputed
    r3, n3 = fresh.fit_residuals(_seat(2e6))
    np.testing.assert_array_equal(r2, r3)
    assert n2 == n3 and n1 == n3
    assert np.any(r2 != 0.0)
    # evaluate() of the same model reuses its sensor fit, and gives what a fresh problem's evaluate gives
    n_calls = len(calls)
    ev = pb.evaluate(_seat(2e6))
    assert len(calls) == n_calls
    ev_fresh = _problem().evaluate(_seat(2e6))
    assert ev.nuisance == ev_fresh.nuisance and ev.fit_cost == ev_fresh.fit_cost and ev.held_cost == ev_fresh.held_cost


def test_residuals_are_forgotten_beyond_the_memo_and_recomputed_alike(monkeypatch):
    monkeypatch.setattr(problem_mod, "RESIDUAL_MEMO", 3)
    pb = _problem()
    first, _ = pb.fit_residuals(_seat(1e6))
    for k in (2e6, 3e6, 4e6):
        pb.fit_residuals(_seat(k))
    assert len(pb._residuals) == 3 and _seat(1e6) not in pb._residuals
    again, _ = pb.fit_residuals(_seat(1e6))
    np.testing.assert_array_equal(first, again)
    assert _seat(1e6) in pb._residuals and len(pb._residuals) == 3


def _failing(cond, effects, warm=None):
    raise RuntimeError("no convergence (test)")


def test_a_kept_failure_still_says_why():
    runs, _ = synthesize(standin.simulate, "disc", THESIS_DISC, (), Noise(), seed=0)
    pb = Workflow(runs, _failing, standin.LIB, Settings(), progress=False).problem
    assert pb.fit_residuals(_seat(2e6))[0] is None
    pb.last_failure = None
    assert pb.fit_residuals(_seat(2e6))[0] is None
    assert "no convergence (test)" in pb.last_failure


#: set by PreparedSimulator.prepare in the process that calls it
_PREPARED = {"pid": None}


class PreparedSimulator:
    """A simulator whose ``prepare`` marks this process; each revolution says whether its process was marked."""

    def prepare(self):
        _PREPARED["pid"] = os.getpid()
        return 0.0

    def __call__(self, cond, effects):
        crank = np.linspace(0.0, 359.0, 360)
        mark = 1.0 if _PREPARED["pid"] is not None else 0.0
        return CycleTrace(crank, {"inlet": np.full(360, mark), "delivery": np.full(360, float(os.getpid()))}, 1e-6)


def test_the_workers_are_forked_after_the_simulator_is_ready():
    _PREPARED["pid"] = None
    sims = Simulations(PreparedSimulator(), workers=2)
    conds = [RunCondition(f"r{i}", "disc", 600.0 + i, 2.8e6, None) for i in range(6)]
    try:
        out = sims.many([(c, ()) for c in conds])
    finally:
        sims.__exit__()
    assert _PREPARED["pid"] == os.getpid()                      # prepared here, once, before the pool
    assert all(o.positions["inlet"][0] == 1.0 for o in out)     # ... and every worker inherited it
    assert any(o.positions["delivery"][0] != os.getpid() for o in out)   # the revolutions ran in the workers


class SlowAt:
    """A simulator that takes longer at the condition named "slow" (a revolution of 0.2 s against 0.01 s)."""

    def __call__(self, cond, effects):
        import time

        time.sleep(0.2 if cond.name == "slow" else 0.01)
        crank = np.linspace(0.0, 359.0, 360)
        k = sum(v for a in effects for _, v in a.values)
        return CycleTrace(crank, {"inlet": np.full(360, cond.speed_rpm + k), "delivery": np.zeros(360)}, 1e-6)


def test_a_batch_goes_to_the_workers_longest_first_with_the_same_results():
    conds = [RunCondition(n, "disc", 600.0 + i, 2.8e6, None) for i, n in enumerate(("a", "b", "slow", "c"))]
    model = (Applied.of("seat_compliance", "delivery", {"k_seat": 1e6}),)
    par, ser = Simulations(SlowAt(), workers=2), Simulations(SlowAt(), workers=1)
    try:
        par.many([(c, ()) for c in conds])
        # the slow condition's last seconds known: it goes first, of the same effects or of any
        assert par._longest_first([(c, ()) for c in conds])[0] == 2
        assert par._longest_first([(c, model) for c in conds])[0] == 2
        got = par.many([(c, model) for c in conds])
    finally:
        par.__exit__()
    want = ser.many([(c, model) for c in conds])
    assert [g.positions["inlet"][0] for g in got] == [w.positions["inlet"][0] for w in want]
    assert got[2].seconds >= 0.2 and got[0].seconds < 0.2
