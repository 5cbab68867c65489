"""Cached, optionally parallel simulations of (run condition, model) pairs, warm-started from a neighbour."""

from __future__ import annotations

import math
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from studies.discrepancy.gap import CycleTrace
from studies.discrepancy.records import RunCondition, Simulator


class Simulations:
    """Cached, optionally parallel simulations (one cache entry per run condition and model).

    A simulator that declares ``warm_start`` is handed, with each job, the state at top dead centre of the
    nearest model already solved at the same condition (L1 distance of the logarithms of their parameters), chosen from the
    simulations of earlier batches only, so that the result does not depend on which worker ran what.
    ``stage`` labels the simulations for the cost accounting (``tally``: label -> [simulations, seconds]).
    """

    def __init__(self, simulator: Simulator, workers: int = 1):
        self.simulator = simulator
        self.workers = max(1, int(workers))
        self.cache: dict = {}
        self.count = 0
        self._pool = None
        self.warm = bool(getattr(simulator, "warm_start", False))
        self.stage = "other"
        self.tally: dict = {}
        self._index: dict = {}      # condition -> effect structure -> (parameter vectors, TDC states)
        self._seconds: dict = {}    # condition, and (condition, effect structure) -> seconds of the latest one

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._pool = None

    def _warm_state(self, job):
        """(TDC state, near) of a cached model near ``job``'s at its condition (None: none cached).

        Of the models with the same effects, the nearest in their parameters (L1 of the logarithms,
        :func:`_structure`) if it is within WARM_NEAR; else of the models whose effects are a subset of the
        job's (the baseline for a first candidate, the model it extends in a later round) the largest
        subset, nearest in the parameters they share; else the nearest of the same effects, else the latest
        of the structure nearest to it. Measured (thesis and bench pumps, one revolution from the state
        given): from a converged near neighbour within 0.2 um and 0.85 kPa RMS of the cyclic steady state ("near":
        the simulator runs pump_sim.WARM_REVOLUTIONS, two, since neighbours are chained); from the model it extends, or another, the simulator runs until the
        cycle settles (studies/discrepancy/pump_sim.py)."""
        cond, model = job
        key, vec = _structure(model)
        groups = self._index.get(cond)
        if not groups:
            return None
        same = None
        g = groups.get(key)
        if g is not None:
            vecs, states = g
            if vec.size == 0:
                return states[-1], True
            d = np.abs(np.asarray(vecs) - vec).sum(axis=1)
            i = int(np.argmin(d))
            if d[i] <= WARM_NEAR:
                return states[i], True
            same = states[i]
        mine = set(key)
        subsets = [k for k in groups if k != key and set(k) <= mine]
        if subsets:
            k = max(subsets, key=len)
            vecs, states = groups[k]
            if not k:
                return states[-1], False
            idx = [key.index(x) for x in k]
            d = np.abs(np.asarray(vecs) - vec[idx]).sum(axis=1)
            return states[int(np.argmin(d))], False
        if same is not None:
            return same, False
        best = min(groups, key=lambda k: len(mine.symmetric_difference(k)))
        return groups[best][1][-1], False

    def _remember(self, job, res):
        state = getattr(res, "state", None)
        if state is None:
            return
        cond, model = job
        key, vec = _structure(model)
        vecs, states = self._index.setdefault(cond, {}).setdefault(key, ([], []))
        vecs.append(vec)
        states.append(state)

    def _start_pool(self) -> ProcessPoolExecutor:
        """The worker pool, started once the simulator has made itself ready (its ``prepare``, if it declares
        one: the fast path's compiled code loaded from numba's cache, 0.3 s a process), so that the workers,
        forked from this process, inherit it instead of each loading it again. The pool is kept for the
        whole search (:meth:`__exit__` shuts it down)."""
        prepare = getattr(self.simulator, "prepare", None)
        if callable(prepare):
            prepare()
        return ProcessPoolExecutor(max_workers=self.workers)

    def _longest_first(self, todo: list) -> list[int]:
        """The indices of a batch's jobs in the order they go to the workers: the longest expected first (the
        seconds of the latest simulation of the same effects at that condition, else of any at it), so that
        the workers finish together instead of one waiting on a long job handed out last (longest processing
        time first). The results do not depend on the order: each job's warm start is chosen beforehand from
        earlier batches only."""
        def expected(i):
            cond, model = todo[i]
            return self._seconds.get((cond, _structure(model)[0]), self._seconds.get(cond, 0.0))

        return sorted(range(len(todo)), key=expected, reverse=True)

    def many(self, jobs: list[tuple[RunCondition, tuple]]) -> list[CycleTrace | None]:
        """Simulations of (condition, model) pairs; None where the model failed."""
        todo = []
        for job in jobs:
            if job not in self.cache and job not in todo:
                todo.append(job)
        if todo:
            t0 = time.perf_counter()
            warm = [self._warm_state(j) if self.warm else None for j in todo]
            if self.workers > 1 and len(todo) > 1:
                if self._pool is None:
                    self._pool = self._start_pool()
                order = self._longest_first(todo)
                done = self._pool.map(_safe_simulate, [self.simulator] * len(todo), [todo[i] for i in order],
                                      [warm[i] for i in order])
                results = [None] * len(todo)
                for i, res in zip(order, done):
                    results[i] = res
            else:
                results = [_safe_simulate(self.simulator, j, w) for j, w in zip(todo, warm)]
            for job, res in zip(todo, results):
                self.cache[job] = res
                self._remember(job, res)
                if hasattr(res, "seconds"):
                    self._seconds[job[0]] = self._seconds[(job[0], _structure(job[1])[0])] = res.seconds
            self.count += len(todo)
            t = self.tally.setdefault(self.stage, [0, 0.0])
            t[0] += len(todo)
            t[1] += time.perf_counter() - t0
        return [self.cache[j] for j in jobs]


#: a model of the same effects within this L1 distance of the logarithms of its parameters is a near neighbour
#: (a factor 1.1 in one parameter): the simulator runs two revolutions from its state; farther, the
#: simulator runs until the cycle settles (Simulations._warm_state). A leak relaxes the cylinder's mass slowly:
#: one revolution from a neighbour 1.1x away leaves 0.5-0.85 kPa RMS, 1.65x away 5-9 kPa, 3x away 45-85 kPa
#: (a squeeze film's or a seat's neighbours: within 0.4 kPa and 2 um at 3x)
WARM_NEAR = 0.1


def _structure(model: tuple) -> tuple[tuple, np.ndarray]:
    """A model's effect structure ((name, target, parameter), ...) and its parameter values as a vector
    (logarithms of the positive ones): models of one structure are compared by the L1 distance of these."""
    items = sorted((a.name, a.target, k, v) for a in model for k, v in a.values)
    key = tuple(i[:3] for i in items)
    vec = np.array([math.log(v) if v > 0 else v for *_, v in items], dtype=float)
    return key, vec


def _safe_simulate(simulator, job, warm=None):
    """``simulator`` on ``job`` (from ``warm``): its CycleTrace, with the seconds it took (``seconds``), or a
    SimulationFailure."""
    cond, model = job
    t0 = time.perf_counter()
    try:
        out = simulator(cond, model, warm) if warm is not None else simulator(cond, model)
    except (ArithmeticError, ValueError, RuntimeError) as exc:  # a model that fails is a bad fit, not a crash
        return SimulationFailure(f"{type(exc).__name__}: {exc}")
    if not all(np.all(np.isfinite(x)) for x in out.positions.values()) or not math.isfinite(out.delivery_m3_per_rev):
        return SimulationFailure("non-finite result")
    try:
        object.__setattr__(out, "seconds", time.perf_counter() - t0)
    except (AttributeError, TypeError):     # a simulator's own result type without a __dict__
        pass
    return out


@dataclass(frozen=True)
class SimulationFailure:
    reason: str
