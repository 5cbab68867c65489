"""Neighbours among a study's designs: features, a space-filling order for batches, the warm start of a design.

A design is a dict of inputs. Its *features* are its numeric inputs, each scaled to [0, 1] over the
designs at hand (in log space when all values are positive and span more than a decade); its
*group* is the tuple of its other inputs (strings, booleans: a valve type, a model file), since
only designs of one group share a state layout. :func:`locality_order` orders designs so that
consecutive slices (the batches a sweep sends to a worker) hold near designs: a k-d split, each
time along the feature of widest spread. :class:`WarmSlot` is what a sweep model's ``evaluate``
receives as ``warm``: the state of the nearest design solved so far in its batch
(:class:`lumped.run.warmstart.WarmStarts`), and the place to leave its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def features(designs: list[dict], skip=()) -> tuple[np.ndarray, list]:
    """(features, groups) of designs: a row of scaled numeric inputs each, and the tuple of the others."""
    names = []
    for d in designs:
        for k in d:
            if k not in names and k not in skip:
                names.append(k)
    numeric = [k for k in names if all(_is_number(d.get(k)) and math.isfinite(float(d[k])) for d in designs)]
    other = [k for k in names if k not in numeric]
    X = np.zeros((len(designs), len(numeric)))
    for j, k in enumerate(numeric):
        x = np.array([float(d[k]) for d in designs])
        lo, hi = x.min(), x.max()
        if lo > 0 and hi / lo > 10:
            x, lo, hi = np.log(x), math.log(lo), math.log(hi)
        X[:, j] = (x - lo) / (hi - lo) if hi > lo else 0.0
    groups = [tuple((k, repr(d.get(k))) for k in other) for d in designs]
    return X, groups


def locality_order(X: np.ndarray, groups=None, leaf: int = 16) -> list[int]:
    """Indices of the rows of X, group by group, in the order of a k-d split (median along the feature of
    widest spread, down to ``leaf`` points): consecutive indices are near each other."""
    n = len(X)
    groups = [None] * n if groups is None else list(groups)
    X = np.asarray(X, dtype=float).reshape(n, -1)
    out: list[int] = []

    def split(idx: np.ndarray) -> None:
        if len(idx) <= leaf or X.shape[1] == 0:
            out.extend(int(i) for i in idx)
            return
        spread = X[idx].max(axis=0) - X[idx].min(axis=0)
        j = int(np.argmax(spread))
        if spread[j] == 0.0:
            out.extend(int(i) for i in idx)
            return
        idx = idx[np.argsort(X[idx, j], kind="stable")]
        half = len(idx) // 2
        split(idx[:half])
        split(idx[half:])

    for g in dict.fromkeys(groups):
        split(np.array([i for i in range(n) if groups[i] == g], dtype=int))
    return out


@dataclass
class WarmSlot:
    """One design's access to its batch's pool of solved designs (``pool``: lumped.WarmStarts)."""

    pool: object
    features: np.ndarray
    group: object

    def state(self):
        """The TDC state predicted from the nearest solved designs of the same group (None: start cold;
        :meth:`lumped.run.warmstart.WarmStarts.predict`)."""
        return self.pool.predict(self.features, self.group)

    def solved(self, state) -> None:
        """Leave this design's TDC state (``PumpResult.tdc_state``) for the designs after it."""
        self.pool.add(self.features, state, self.group)
