"""Objectives, constraints and the Pareto front of an optimisation, in the optimisers' convention.

The optimisers minimise: a design's objective vector F holds each objective's value, negated
for a maximised one (:func:`objective_vector`); its constraint vector G holds each constraint's
normalised violation, g <= 0 when met (:func:`constraint_vector`), and one last entry for the
evaluation's success. A failed design gets F = :data:`FAILED_F` and can never be on a front.
"""

from __future__ import annotations

import numpy as np

#: objective value of an infeasible (failed) design: never on a front
FAILED_F = 1e12


def signs(objectives) -> np.ndarray:
    """The sign of each objective in F: -1 for a maximised output, +1 for a minimised one.

    Parameters
    ----------
    objectives : sequence of Objective

    Returns
    -------
    numpy.ndarray
        Objective value = F x sign.
    """
    return np.array([-1.0 if o.sense == "max" else 1.0 for o in objectives])


def objective_vector(objectives, rec: dict) -> list[float]:
    """A design's objective vector F (minimised).

    Parameters
    ----------
    objectives : sequence of Objective
    rec : dict
        The design's record (``ok``, ``objectives``: {output: value aggregated over the points}).

    Returns
    -------
    list of float
        Each objective in its output's unit, negated when maximised; :data:`FAILED_F` each for a failed design.
    """
    if not rec["ok"]:
        return [FAILED_F] * len(objectives)
    return [(-1.0 if o.sense == "max" else 1.0) * rec["objectives"][o.output] for o in objectives]


def constraint_vector(constraints, rec: dict) -> list[float]:
    """A design's constraint vector G (g <= 0 when met).

    Parameters
    ----------
    constraints : sequence of Constraint
    rec : dict
        The design's record (``ok``, ``constraints``: {output: worst value, or (min, max) over the points}).

    Returns
    -------
    list of float
        Per constraint the violation relative to its limit, max((v m - high) / |high|, (low - v m) / |low|)
        with m the loop margin (the loop tightens the limits; the final check uses them as given); 1 for
        a missing value or a failed design; last, -1 for a successful evaluation, +1 for a failed one.
    """
    g = []
    for c in constraints:
        v = rec["constraints"].get(c.output)
        if v is None or not rec["ok"]:
            g.append(1.0)
            continue
        lo_v, hi_v = v if isinstance(v, tuple) else (v, v)
        parts = []
        if c.high is not None:   # tightened by the loop margin (the final check uses the limit itself)
            parts.append((hi_v * c.loop_margin - c.high) / max(abs(c.high), 1e-300))
        if c.low is not None:
            parts.append((c.low - lo_v * c.loop_margin) / max(abs(c.low), 1e-300))
        g.append(max(parts))
    g.append(-1.0 if rec["ok"] else 1.0)
    return g


def violations(constraints, values: dict) -> list[str]:
    """The constraints a design breaks, as text.

    Parameters
    ----------
    constraints : sequence of Constraint
    values : dict
        {output: worst value, or (min, max)} of the design.

    Returns
    -------
    list of str
        ``"seat_impact_m_s = 1.2 > 1"`` style entries (``"...: missing"`` for a missing value).
    """
    out = []
    for c in constraints:
        v = values.get(c.output)
        if v is None:
            out.append(f"{c.output}: missing")
            continue
        lo_v, hi_v = v if isinstance(v, tuple) else (v, v)
        if c.high is not None and hi_v > c.high:
            out.append(f"{c.output} = {hi_v:.4g} > {c.high:.4g}")
        if c.low is not None and lo_v < c.low:
            out.append(f"{c.output} = {lo_v:.4g} < {c.low:.4g}")
    return out


def non_dominated(F: np.ndarray) -> np.ndarray:
    """The rows of F (minimised) that no other row dominates.

    Parameters
    ----------
    F : numpy.ndarray
        (designs, objectives).

    Returns
    -------
    numpy.ndarray of bool
        True for a row on the front.

    Examples
    --------
    >>> non_dominated(np.array([[1.0, 2.0], [2.0, 1.0], [2.0, 2.0]])).tolist()
    [True, True, False]
    """
    n = len(F)
    keep = np.ones(n, bool)
    for i in range(n):
        dom = np.all(F <= F[i], axis=1) & np.any(F < F[i], axis=1)
        keep[i] = not dom.any()
    return keep


def dominates(a: dict, b: dict, objectives) -> bool:
    """Whether design a dominates design b.

    Parameters
    ----------
    a, b : dict
        {output: value} of the two designs.
    objectives : sequence of Objective
        Which outputs and senses count.

    Returns
    -------
    bool
        a is at least as good in every objective and better in one.
    """
    fa = np.array([(-1 if o.sense == "max" else 1) * a[o.output] for o in objectives])
    fb = np.array([(-1 if o.sense == "max" else 1) * b[o.output] for o in objectives])
    return bool(np.all(fa <= fb) and np.any(fa < fb))
