"""The baseline nuisances (the discharge-coefficient factor) profiled out of a candidate's fit to first order.

A candidate's search would cost a nuisance fit at every value tried; instead the fit residuals r0 of a model
are moved by J d, with J the residuals' Jacobian in the nuisance values (forward differences, one simulation
per fitting run and parameter) and d the least-squares shift, kept inside the nuisance's bounds
(:func:`profile`). The Jacobian is taken where the profile is linearised (:func:`at_origin`): at the
nuisances' fitted values, or at their prior where a value sits near a bound.
"""

from __future__ import annotations

import math

import numpy as np

from studies.discrepancy.records import with_value

#: a nuisance fitted within this fraction of its range from a bound is linearised at its prior (:func:`at_origin`):
#: for the Cd factor's 0.90-1.10, a factor more than 4 % from 1
ORIGIN_EDGE = 0.3


def nuisance_index(pb, model: tuple) -> list:
    """(position in ``model``, parameter) of every baseline-nuisance parameter the model carries."""
    return [(i, p) for i, a in enumerate(model) if a.name in pb.nuisance_effects
            for p in pb.nuisance_effects[a.name][0].parameters]


def at_prior(pb, model: tuple) -> tuple:
    """``model`` with its baseline nuisances at their prior (the Cd factor at 1): the second origin of a
    candidate's profile (search._second_start); its own origin (:func:`at_origin` keeps a prior)."""
    return tuple(a.with_values({p.name: p.prior for p in pb.nuisance_effects[a.name][0].parameters})
                 if a.name in pb.nuisance_effects else a for a in model)


def at_origin(pb, model: tuple) -> tuple:
    """``model`` with its baseline nuisances where the profile is linearised: at their fitted values, or at
    their prior where a value lies within ORIGIN_EDGE of its range from a bound.

    The Cd factor moves the residuals nonlinearly over a few per cent, so the profile is linearised where the
    factor was fitted; a factor far from its prior is no origin to trust: pinned near its bound (a soft seat's
    lost delivery bought by Cd 0.90) or 5-7 % off where a missing effect trades with it (a reed's fluid
    damping, Cd 0.94-0.95), the linear profile cannot carry it back and the effect that would is screened out
    (docs/discrepancy.md, "Settings and why")."""
    out = []
    for a in model:
        if a.name in pb.nuisance_effects:
            vals = a.value_dict
            new = {}
            for p in pb.nuisance_effects[a.name][0].parameters:
                lo, hi = p.bounds
                v = vals[p.name]
                new[p.name] = v if min(v - lo, hi - v) > ORIGIN_EDGE * (hi - lo) else p.prior
            a = a.with_values(new)
        out.append(a)
    return tuple(out)


def nuisance_jacobian(pb, model: tuple) -> np.ndarray | None:
    """d(fit residuals)/d(nuisance values) of ``model`` by forward differences of
    ``Settings.nuisance_step`` of each range (one simulation per fitting run and parameter)."""
    idx = nuisance_index(pb, model)
    r0 = pb.residual_vector(model)
    if r0 is None or not idx:
        return None
    cols = []
    for i, p in idx:
        h = pb.settings.nuisance_step * (p.bounds[1] - p.bounds[0])
        r = pb.residual_vector(with_value(model, i, p.name, model[i].value_dict[p.name] + h))
        if r is None:
            return None
        cols.append((r - r0) / h)
    return np.column_stack(cols)


def profile(pb, model: tuple, jac: np.ndarray | None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Fit residuals with the baseline nuisances of ``model`` profiled out to first order, and the
    nuisance shift that does it: r0 + J d with d minimising it (kept inside the bounds).

    ``jac`` (:func:`nuisance_jacobian`) is taken at the base (:func:`base_jacobian`) and again at the best point
    of the candidate's coarse search (:func:`studies.discrepancy.fitting.fit`), with the nuisances at
    :func:`at_origin`: the search follows the candidate's own valley with the Cd factor at its best, not the one
    a Cd factor fitted without the candidate leaves (a soft seat, an added mass, a leak all trade with Cd).
    """
    r0 = pb.residual_vector(model)
    idx = nuisance_index(pb, model)
    if r0 is None or not idx or jac is None or jac.shape[0] != r0.size:
        return r0, None
    d = np.linalg.lstsq(jac, -r0, rcond=None)[0]
    for k, (i, p) in enumerate(idx):
        v = model[i].value_dict[p.name]
        d[k] = float(np.clip(v + d[k], *p.bounds)) - v
    return r0 + jac @ d, d


def profiled_model(pb, model: tuple, jac: np.ndarray | None) -> tuple:
    """``model`` with its nuisances moved by the first-order profile shift (itself if none)."""
    _, d = profile(pb, model, jac)
    if d is None:
        return model
    for k, (i, p) in enumerate(nuisance_index(pb, model)):
        model = with_value(model, i, p.name, model[i].value_dict[p.name] + d[k])
    return model


def profiled_cost(pb, model: tuple, jac: np.ndarray | None) -> float:
    """The fit cost of ``model`` with its nuisances profiled by ``jac`` (inf if a simulation failed)."""
    r, _ = profile(pb, model, jac)
    return math.inf if r is None else float(r @ r)


def base_jacobian(pb, current: tuple) -> np.ndarray | None:
    """The nuisance Jacobian of ``current`` with its nuisances at their origin, taken once per model: every
    candidate's coarse grid is profiled with it (the Jacobian is taken again at the best coarse point)."""
    if not nuisance_index(pb, current):
        return None
    key = at_origin(pb, current)
    if key not in pb.jacobians:
        stage = pb.sims.stage
        pb.sims.stage = "base jacobian"
        pb.jacobians[key] = nuisance_jacobian(pb, key)
        pb.sims.stage = stage
    return pb.jacobians[key]


def candidate_cost(pb, current: tuple, candidate) -> float:
    """The fit cost of ``current`` with ``candidate`` added, the nuisances profiled with the base Jacobian."""
    jac = base_jacobian(pb, current)
    model = at_origin(pb, current) + (candidate,)
    if jac is None:
        return pb.fit_objective(model)[0]
    return profiled_cost(pb, model, jac)


def screen_base(pb, current: tuple) -> float:
    """The cost the screening compares with: ``current`` with its nuisances profiled from their origin by the
    base Jacobian (as every candidate's grid is)."""
    jac = base_jacobian(pb, current)
    if jac is None:
        return pb.fit_objective(current)[0]
    return profiled_cost(pb, at_origin(pb, current), jac)


def nuisance_widths(pb, model: tuple) -> dict:
    """For each nuisance parameter of ``model``: the change that raises the fit cost by one gap unit,
    the others held (a parabola through the fitted value and +-1 % of the nuisance range)."""
    out = {}
    c0 = pb.fit_objective(model)[0]
    for i, a in enumerate(model):
        if a.name not in pb.nuisance_effects:
            continue
        for p in pb.nuisance_effects[a.name][0].parameters:
            v = a.value_dict[p.name]
            h = 0.01 * (p.bounds[1] - p.bounds[0])
            cs = [pb.fit_objective(with_value(model, i, p.name, v + dv))[0] for dv in (-h, h)]
            curv = (cs[0] - 2 * c0 + cs[1]) / h**2        # d2C/dv2 = 2 a for C = c0 + a (v - v0)^2
            out[f"{a.name}.{p.name}"] = math.sqrt(2.0 / curv) if curv > 0 and math.isfinite(curv) else None
    return out
