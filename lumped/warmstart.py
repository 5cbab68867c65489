"""Warm starts for studies: the solved designs' states at TDC, and the closest one to start the next design.

A study that simulates many designs (a sweep's batch, an optimiser's population, Monte Carlo
draws, a tolerance ladder) keeps a :class:`WarmStarts` pool: after each design it adds the
design's features (numbers that place it among the others, scaled by the study: e.g. each
input over its range) and ``PumpResult.tdc_state``; before the next it asks for the state of the
nearest design solved so far (:meth:`WarmStarts.nearest`), which :func:`lumped.cycle.simulate`
takes as ``initial_state``. With :meth:`lumped.revolutions.StopRule.steady` the run then stops as
soon as the cyclic steady-state test passes, usually after two revolutions instead of three
from today's start (the first revolution from today's start is 3-10 % off in delivery).
:func:`chain_order` orders a batch so that each design follows a close one.

The answer of a warm-started design differs from a cold-started one by what the steady-state
test leaves: within its tolerance (``PumpResult.cycle_change``, ``steady_tol``), and in practice
within the integrator's noise (tests/test_warm_start.py checks both against 40-revolution runs).
"""

from __future__ import annotations

import math

import numpy as np


class WarmStarts:
    """A pool of solved designs: their features (a vector each), an optional group and their TDC state.

    ``nearest(features, group)`` returns the state of the design nearest in Euclidean distance among
    those of the same group (None when there is none, or none within ``max_distance``). The pool keeps
    the last ``limit`` designs.
    """

    def __init__(self, max_distance: float = math.inf, limit: int = 100_000):
        self.max_distance = float(max_distance)
        self.limit = int(limit)
        self._groups: dict = {}          # group -> (features list, states list)

    def __len__(self) -> int:
        return sum(len(f) for f, _ in self._groups.values())

    def add(self, features, state, group=None) -> None:
        """Record a solved design (``state``: its ``PumpResult.tdc_state``; None is ignored)."""
        if state is None:
            return
        feats, states = self._groups.setdefault(group, ([], []))
        feats.append(np.asarray(features, dtype=float).ravel())
        states.append(state)
        if len(feats) > self.limit:
            del feats[0], states[0]

    def nearest(self, features, group=None):
        """The TDC state of the solved design nearest to ``features`` in ``group`` (None if none)."""
        entry = self._groups.get(group)
        if not entry or not entry[0]:
            return None
        feats, states = entry
        x = np.asarray(features, dtype=float).ravel()
        d = np.linalg.norm(np.asarray(feats) - x, axis=1)
        i = int(np.argmin(d))
        return states[i] if d[i] <= self.max_distance else None


def chain_order(features, groups=None) -> list[int]:
    """An order of the points (rows of ``features``) in which each follows a near one: within each group
    (in order of first appearance), a greedy nearest-neighbour chain from the group's first point."""
    X = np.asarray(features, dtype=float)
    n = len(X)
    if n == 0:
        return []
    X = X.reshape(n, -1)
    groups = [None] * n if groups is None else list(groups)
    order: list[int] = []
    for g in dict.fromkeys(groups):
        idx = [i for i in range(n) if groups[i] == g]
        left = np.array(idx)
        cur = left[0]
        order.append(int(cur))
        left = left[1:]
        while len(left):
            d = np.sum((X[left] - X[cur]) ** 2, axis=1)
            j = int(np.argmin(d))
            cur = left[j]
            order.append(int(cur))
            left = np.delete(left, j)
    return order
