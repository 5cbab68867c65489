"""Warm starts for studies: the solved designs' states at TDC, and the closest one to start the next design.

A study that simulates many designs (a sweep's batch, an optimiser's population, Monte Carlo
draws, a tolerance ladder) keeps a :class:`WarmStarts` pool: after each design it adds the
design's features (numbers that place it among the others, scaled by the study: e.g. each
input over its range) and ``PumpResult.tdc_state``; before the next it asks for the state of the
nearest design solved so far (:meth:`WarmStarts.nearest`), which :func:`lumped.run.simulate.simulate`
takes as ``initial_state``. With :meth:`lumped.run.revolutions.StopRule.steady` the run then stops as
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
    those of the same group (None when there is none, or none within ``max_distance``);
    ``predict(features, group)`` a state predicted from the nearest designs by a local linear fit
    (:meth:`predict`), or the nearest one's where that is not possible. The pool keeps the last
    ``limit`` designs.
    """

    def __init__(self, max_distance: float = math.inf, limit: int = 100_000):
        self.max_distance = float(max_distance)
        self.limit = int(limit)
        self._groups: dict = {}          # group -> [features array (rows, grown by doubling), count, states]

    def __len__(self) -> int:
        return sum(g[1] for g in self._groups.values())

    def add(self, features, state, group=None) -> None:
        """Record a solved design (``state``: its ``PumpResult.tdc_state``; None is ignored)."""
        if state is None:
            return
        x = np.asarray(features, dtype=float).ravel()
        g = self._groups.get(group)
        if g is None or g[0].shape[1] != len(x):
            g = self._groups[group] = [np.empty((16, len(x))), 0, []]
        if g[1] == len(g[0]):
            g[0] = np.concatenate([g[0], np.empty_like(g[0])])
        g[0][g[1]] = x
        g[1] += 1
        g[2].append(state)
        if g[1] > self.limit:             # forget the oldest
            g[0] = g[0][1:].copy()
            g[1] -= 1
            del g[2][0]

    def nearest(self, features, group=None):
        """The TDC state of the solved design nearest to ``features`` in ``group`` (None if none)."""
        g = self._groups.get(group)
        if not g or not g[1]:
            return None
        x = np.asarray(features, dtype=float).ravel()
        if len(x) != g[0].shape[1]:
            return None
        d = np.einsum("ij,ij->i", g[0][:g[1]] - x, g[0][:g[1]] - x)
        i = int(np.argmin(d))
        return g[2][i] if d[i] <= self.max_distance ** 2 else None

    def predict(self, features, group=None):
        """The TDC state for a design at ``features``: a weighted linear fit (in each state's units,
        :meth:`lumped.run.revolutions.TdcState.normalized`) through the 2 d + 2 nearest solved designs of the
        group (d features), evaluated at ``features``; the nearest design's state where fewer than d + 2
        share its layout, or where the fit leaves their range by more than its width (an extrapolation
        not to trust). On an optimiser-like population the first revolution's delivery is then an order
        of magnitude closer to the cycle than from the nearest design's state, and most designs stop
        after two revolutions (benchmarks/periodic_solver.py, docs/performance.md)."""
        g = self._groups.get(group)
        if not g or not g[1]:
            return None
        x = np.asarray(features, dtype=float).ravel()
        if len(x) != g[0].shape[1]:
            return None
        F = g[0][:g[1]]
        d2 = np.einsum("ij,ij->i", F - x, F - x)
        order = np.argsort(d2)
        first = g[2][int(order[0])]
        if d2[order[0]] > self.max_distance ** 2:
            return None
        k_min, k = len(x) + 2, 2 * len(x) + 2
        idx = [int(i) for i in order[:k] if g[2][int(i)].signature == first.signature]
        if len(idx) < k_min or d2[idx[0]] == 0.0:
            return first
        Y = np.array([_normalized(g[2][i]) for i in idx])
        A = np.column_stack([np.ones(len(idx)), F[idx] - x])
        w = 1.0 / (np.sqrt(d2[idx]) + 1e-12)
        coef, *_ = np.linalg.lstsq(A * w[:, None], Y * w[:, None], rcond=None)
        pred = coef[0]
        lo, hi = Y.min(axis=0), Y.max(axis=0)
        if not np.all(np.isfinite(pred)) or np.any(pred < lo - (hi - lo)) or np.any(pred > hi + (hi - lo)):
            return first
        return first.with_normalized(pred)


def _normalized(state) -> np.ndarray:
    # kept on the state: a pool asks for each solved design's normalized state many times
    cached = state.__dict__.get("_normalized")
    if cached is None:
        cached = state.normalized()
        object.__setattr__(state, "_normalized", cached)
    return cached


def chain_order(features, groups=None) -> list[int]:
    """An order of the points in which each follows a near one (a chain of warm starts).

    Within each group (in order of first appearance) of the points (rows of ``features``), a greedy
    nearest-neighbour chain from the group's first point.

    Examples
    --------
    >>> chain_order([[0.0], [10.0], [1.0], [11.0], [2.0]])
    [0, 2, 4, 1, 3]
    """
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


def fast_start(model, speed_rpm=None, load_pressure=None, **kw):
    """The TDC state the fast path (compiled Rodas4P/5P) reaches at cyclic steady state: where a reference run
    (scipy Radau) of the same pump starts, its first revolution then within the two steppers' difference
    (~1e-4 in delivery) of its own cycle. ``kw``: simulate's ``air_content``, ``circuit``, ``needle_area``,
    ``contact_atol``. None where the fast path cannot run the model (a whole FE reed: reference only)."""
    from geometry.errors import InputError
    from lumped.run.simulate import simulate
    from lumped.run.revolutions import StopRule

    try:
        return simulate(model, speed_rpm, load_pressure, method="fast", stop=StopRule.steady(max_revolutions=20),
                        **kw).tdc_state
    except InputError:
        return None
