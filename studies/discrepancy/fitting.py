"""Fitting a candidate effect's parameters on the fitting runs, and refitting the effects of a model.

:func:`fit` searches one effect on top of a base model in unit coordinates of its parameters' search bounds
(log where declared): one parameter by a coarse grid over its plausible range, a finer grid around the best
point and Brent's method; several by a grid over the plausible box and a pattern search (:func:`box_search`).
The baseline nuisances are profiled out to first order at every value tried (``studies.discrepancy.profile``).
:func:`refine` refits the added effects one at a time, :func:`polish` several jointly by least squares.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, minimize_scalar
from scipy.stats import qmc

from lumped.model.effects import Applied, Effect
from studies.discrepancy import profile as prof
from studies.discrepancy.gap import Nuisance
from studies.discrepancy.records import with_value


#: the plausibility rule's tolerance: within this fraction of a range from a bound or an edge is "at" it
#: (lumped.model.effects.Parameter.plausibility's default)
BOUND_TOL = 0.01


@dataclass(frozen=True, eq=False)
class FitOptions:
    """How :func:`fit` searches.

    ``start``: the values to start from (default the prior). ``narrow``: a local refit around ``start`` (that
    many units of each parameter's search range either side). ``profile``: the baseline nuisances of the base
    profiled out at every value tried (the cost returned is then the profiled one). ``reject_margin``: a
    candidate none of whose coarse grid points costs that much less than the base (profiled the same way) is
    hopeless and not refined. ``coarse_only``: the best point of the coarse grid (3 x 3 for several
    parameters), not refined: the screening. ``jacobian``: the nuisance Jacobian to start from (the round's,
    taken at the base) instead of one taken at the candidate's start; it is taken again at the best coarse
    point either way. ``dense``: a coarse grid of Settings.n_grid_dense points for an effect declared
    ``tight_tolerance`` (its cost may be low only in a needle). ``plausible_only``: a ``narrow`` refit kept
    strictly inside the plausible range (:func:`acceptable_units`): the refit of an effect already added.
    """

    start: dict | None = None
    narrow: float | None = None
    profile: bool = False
    reject_margin: float | None = None
    coarse_only: bool = False
    jacobian: np.ndarray | None = None
    dense: bool = False
    plausible_only: bool = False


@dataclass(frozen=True, eq=False)
class FitResult:
    """A fit's best values, its cost (profiled where asked), the sensor nuisances there, the simulations it
    ran, whether it was hopeless, and the nuisance Jacobian the profile ended with."""

    values: dict
    cost: float
    nuisance: Nuisance
    n_sims: int
    rejected: bool
    jacobian: np.ndarray | None


class Objective:
    """The cost of a candidate's values on top of ``base``: the fit cost, with the nuisances profiled by the
    Jacobian ``jac`` when ``profile`` (taken again by :meth:`relinearize`)."""

    def __init__(self, pb, base: tuple, effect: Effect, target: str, params, profile: bool, jac):
        self.pb, self.base, self.effect, self.target, self.params = pb, base, effect, target, params
        self.profile, self.jac = profile, jac
        self.held = pb.held_values(effect.name, target)

    def model_of(self, units) -> tuple:
        """The base with the candidate at ``units`` (unit coordinates of its free parameters; the held ones
        where they are held)."""
        vals = {**self.held, **{p.name: p.from_unit(u) for p, u in zip(self.params, units)}}
        return self.base + (Applied.of(self.effect.name, self.target, vals),)

    def cost(self, model) -> float:
        """The (profiled) fit cost of ``model``."""
        if not self.profile:
            return self.pb.fit_objective(model)[0]
        return prof.profiled_cost(self.pb, model, self.jac)

    def relinearize(self, units, stage: str) -> bool:
        """The profile linearised again at ``units`` (True if it was): where the candidate changes how the
        nuisance acts (an added mass retunes the reed, and a Cd factor then moves other residuals), the
        start's linearisation would bias the search."""
        if not self.profile:
            return False
        self.pb.sims.stage = f"{stage}/jacobian"
        new = prof.nuisance_jacobian(self.pb, self.model_of(units))
        if new is None:
            return False
        self.jac = new
        return True

    def simulate(self, points):
        """The fitting runs of every point of ``points`` (unit coordinates) simulated in one batch."""
        pb = self.pb
        pb.sims.many([(pb.conds[r.name], self.model_of(list(u))) for u in points for r in pb.fit_runs])


def fit(pb, base: tuple, effect: Effect, target: str, opts: FitOptions = FitOptions()) -> FitResult:
    """Fit ``effect`` at ``target`` on top of ``base`` (:class:`FitOptions` says how)."""
    n0 = pb.sims.count
    held = pb.held_values(effect.name, target)   # pulled inside its range when added (edge.py): not refitted
    params = [p for p in effect.parameters_for(pb.context, target) if p.name not in held]
    profile = opts.profile and bool(prof.nuisance_index(pb, base))
    jac = None
    stage = pb.sims.stage
    if profile:   # linearised at the nuisances' origin and the candidate's start (studies.discrepancy.profile)
        base = prof.at_origin(pb, base)
        s0 = {**(opts.start or effect.prior_values(pb.context, target)), **held}
        pb.sims.stage = f"{stage}/jacobian"
        jac = opts.jacobian if opts.jacobian is not None else \
            prof.nuisance_jacobian(pb, base + (Applied.of(effect.name, target, s0),))
    ob = Objective(pb, base, effect, target, params, profile, jac)
    reject_above = None
    if opts.reject_margin is not None and opts.narrow is None:
        base_cost = prof.profiled_cost(pb, base, jac) if profile else pb.fit_objective(base)[0]
        reject_above = base_cost - opts.reject_margin
    rejected = False
    if not params:   # a pure switch: nothing to fit
        units = []
    elif len(params) == 1:
        units, rejected = _line_search(ob, opts, reject_above, stage)
    else:
        x0 = np.array([p.to_unit((opts.start or effect.prior_values(pb.context, target))[p.name]) for p in params])
        units, rejected = box_search(pb, params, x0, ob, opts, reject_above, stage)
        units = list(units)
    pb.sims.stage = f"{stage}/final"
    if opts.coarse_only or rejected:
        cost, nuis = ob.cost(ob.model_of(units)), Nuisance()      # from the cache: nothing new simulated
    else:
        cost, nuis = pb.fit_objective(ob.model_of(units))
        if profile:
            cost = ob.cost(ob.model_of(units))
    vals = {**held, **{p.name: p.from_unit(u) for p, u in zip(params, units)}}
    pb.sims.stage = stage
    return FitResult(vals, cost, nuis, pb.sims.count - n0, rejected, ob.jac)


def _line_search(ob: Objective, opts: FitOptions, reject_above, stage: str) -> tuple[list, bool]:
    """(best unit, hopeless) of a one-parameter fit: a coarse grid over the plausible range (or three points
    around the start, ``narrow``), a finer grid around its best point (:func:`_fine_grid`), then Brent's method.

    Grids are simulated in one batch each (parallel), then evaluated from the cache."""
    pb, st = ob.pb, ob.pb.settings
    p = ob.params[0]
    if opts.narrow is None:
        # over the plausible range: a value beyond it is never added, and the models far beyond it are the
        # slowest to simulate (a squeeze film 16x eq 2.15's sticks and creeps)
        lo, hi = (min(max(p.to_unit(x), 0.0), 1.0) for x in p.plausible)
        n = st.n_grid_dense if (opts.dense and ob.effect.tight_tolerance) else st.n_grid
        grid = np.linspace(lo, hi, n) if hi > lo else np.linspace(0.0, 1.0, n)
    else:
        u0 = p.to_unit(opts.start[p.name])
        lo, hi = _narrow_box(p, opts)
        grid = np.unique(np.clip(np.array([u0 - opts.narrow, u0, u0 + opts.narrow]), lo, hi))
    pb.sims.stage = f"{stage}/{'narrow' if opts.narrow is not None else 'grid'}"
    ob.simulate([[u] for u in grid])
    costs = [ob.cost(ob.model_of([u])) for u in grid]
    rejected = False
    if opts.narrow is None:
        grid, costs, rejected = _fine_grid(ob, grid, costs, reject_above, opts.coarse_only, stage)
    i = int(np.argmin(costs))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    best_u, best_c = float(grid[i]), costs[i]
    if hi > lo and not rejected and not opts.coarse_only:
        pb.sims.stage = f"{stage}/brent"
        res = minimize_scalar(lambda u: ob.cost(ob.model_of([u])), bounds=(lo, hi), method="bounded",
                              options={"xatol": st.brent_xatol, "maxiter": st.brent_maxiter})
        if res.fun < best_c:
            best_u, best_c = float(res.x), float(res.fun)
    return [best_u], rejected


def _narrow_box(p, opts: FitOptions) -> tuple[float, float]:
    """The unit coordinates a narrow refit of ``p`` may take: the search bounds, or strictly inside the
    acceptable zone with ``opts.plausible_only``."""
    if not opts.plausible_only:
        return 0.0, 1.0
    a, b = acceptable_units(p)
    return a + 1e-6, b - 1e-6


def _fine_grid(ob: Objective, grid, costs: list, reject_above, coarse_only: bool, stage: str):
    """(grid, costs, hopeless) after the coarse grid: hopeless when neither its best point nor the midpoints
    beside it beat ``reject_above``; else, unless ``coarse_only``, the profile linearised again at the best
    point and Settings.n_fine points added between its neighbours. The fine grid guards against the ripples
    an oscillating valve puts into the cost (a phase that slips by a cycle); an odd n_fine puts a fine point
    on the best coarse one, which is dropped (a duplicate would collapse Brent's bracket to one side)."""
    pb = ob.pb
    pb.sims.stage = f"{stage}/fine"
    i = int(np.argmin(costs))
    if reject_above is not None and costs[i] >= reject_above:
        # before calling it hopeless, the midpoints beside the best grid point: a leak's cost goes with c^6 and
        # its valley (a factor ~1.3 wide in c) fits between two grid points
        mids = np.unique([(grid[j] + grid[i]) / 2 for j in (i - 1, i + 1) if 0 <= j < grid.size])
        ob.simulate([[u] for u in mids])
        extra = [ob.cost(ob.model_of([u])) for u in mids]
        grid = np.concatenate([grid, mids])
        costs = list(costs) + extra
        order = np.argsort(grid)
        grid, costs = grid[order], [costs[k] for k in order]
        i = int(np.argmin(costs))
        if costs[i] >= reject_above:
            return grid, costs, True
    if coarse_only:
        return grid, costs, False
    if ob.relinearize([grid[i]], stage):
        costs = [ob.cost(ob.model_of([u])) for u in grid]     # simulated already
        i = int(np.argmin(costs))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    fine = np.linspace(a, b, pb.settings.n_fine + 2)[1:-1]
    fine = fine[np.min(np.abs(fine[:, None] - grid[None, :]), axis=1) > 1e-9]
    grid = np.sort(np.concatenate([grid, fine]))
    ob.simulate([[u] for u in fine])
    return grid, [ob.cost(ob.model_of([u])) for u in grid], False


def box_search(pb, params, x0: np.ndarray, ob, opts: FitOptions = FitOptions(), reject_above=None,
               stage: str = "") -> tuple[np.ndarray, bool]:
    """(best point in unit coordinates, hopeless) of a several-parameter fit: a grid over the plausible box
    (scrambled Sobol points beyond two parameters), then a pattern search around the best point, halving its
    step at each level; with ``opts.narrow`` the pattern search around ``x0`` only.

    Not least squares from the prior: the pump's cost is rippled by ~2 gap units for parameter changes of
    1e-5 of a range (the fast path places a disc's lift-off from its seat within a few crank degrees only),
    so finite-difference gradients are noise and such a fit stalls where it starts. ``ob`` gives
    ``model_of(units)``, ``cost(model)``, ``relinearize(units, stage)`` and ``simulate(points)``.
    """
    st = pb.settings
    k = len(params)
    lo = np.clip([p.to_unit(p.plausible[0]) for p in params], 0.0, 1.0)
    hi = np.clip([p.to_unit(p.plausible[1]) for p in params], 0.0, 1.0)
    if opts.narrow is not None:      # a local refit: the pattern search around the start
        grid = np.empty((0, k))
        step = np.full(k, opts.narrow / 2.0)
    elif k <= 2:
        n = 3 if opts.coarse_only else st.n_grid_box
        grid = np.array(list(itertools.product(*[np.linspace(a, b, n) for a, b in zip(lo, hi)])))
        step = (hi - lo) / (2 * (st.n_grid_box - 1))
    else:   # a full grid grows as n^k: as many scrambled Sobol points as a two-parameter grid (32)
        n = 2 ** math.ceil(math.log2(st.n_grid_box ** 2))
        grid = lo + (hi - lo) * qmc.Sobol(k, scramble=True, seed=0).random(n)
        step = (hi - lo) / (2 * (st.n_grid_box - 1))
    offsets = np.array([o for o in itertools.product((-1, 0, 1), repeat=k) if any(o)], float)
    seen: dict = {}

    box = np.array([_narrow_box(p, opts) for p in params]) if opts.narrow is not None else np.array([[0.0, 1.0]] * k)

    def costs(points):
        points = [tuple(np.round(np.clip(u, box[:, 0], box[:, 1]), 12)) for u in points]
        new = [u for u in dict.fromkeys(points) if u not in seen]
        ob.simulate(new)          # each stage in one batch (parallel), then evaluated from the cache
        for u in new:
            seen[u] = ob.cost(ob.model_of(list(u)))

    pb.sims.stage = f"{stage}/{'narrow' if opts.narrow is not None else 'grid'}"
    costs([x0, *grid])
    best = min(seen, key=seen.get)
    if reject_above is not None and opts.narrow is None and seen[best] >= reject_above:
        return np.array(best), True               # hopeless: no grid point beats the base
    if opts.coarse_only:
        return np.array(best), False
    if opts.narrow is None and ob.relinearize(list(best), stage):   # the profile taken again
        for u in seen:
            seen[u] = ob.cost(ob.model_of(list(u)))
        best = min(seen, key=seen.get)
    pb.sims.stage = f"{stage}/pattern"
    for _ in range(st.box_levels):
        costs([np.array(best) + step * o for o in offsets])
        best = min(seen, key=seen.get)
        step = step / 2
    return np.array(best), False


def refine(pb, model: tuple, skip: frozenset = frozenset()) -> tuple:
    """Refit the added effects one at a time with the others fixed (one pass, narrow brackets);
    the effects named in ``skip`` (with a nuisance: the candidate and the nuisances, which
    :func:`polish` refits jointly) are left as they are; each refit stays inside the effect's plausible range."""
    model = list(model)
    for i, a in enumerate(model):
        if a.name in skip:
            continue
        others = tuple(model[:i] + model[i + 1:])
        eff = pb.library[a.name]
        if not {p.name for p in eff.parameters_for(pb.context, a.target)} - set(pb.held_values(a.name, a.target)):
            continue
        vals = fit(pb, others, eff, a.target, FitOptions(start=a.value_dict, narrow=0.1, plausible_only=True)).values
        model[i] = Applied.of(a.name, a.target, vals)
    return tuple(model)


def acceptable_units(p, tol: float = BOUND_TOL) -> tuple[float, float]:
    """The unit coordinates (of the search bounds, :meth:`lumped.model.effects.Parameter.to_unit`) a fitted value must lie strictly
    between to be plausible (lumped.model.effects.Parameter.plausibility): off the search bounds, inside the
    plausible range and off its edges."""
    ulo, uhi = (p.to_unit(x) for x in p.plausible)
    edge = tol * (uhi - ulo)
    lo = max(tol, ulo + edge if ulo > tol else ulo)
    hi = min(1.0 - tol, uhi - edge if uhi < 1.0 - tol else uhi)
    return lo, hi


def _polish_bounds(pb, model: tuple, idx: list, free: frozenset) -> tuple[np.ndarray, np.ndarray]:
    """Unit-coordinate bounds of a polish: the search bounds for the nuisances and the effects in ``free`` (a
    candidate being judged: a fit at its plausible edge is evidence, edge.py), strictly inside the acceptable
    zone for an effect already added (every refit keeps the model plausible)."""
    lo, hi = np.zeros(len(idx)), np.ones(len(idx))
    for k, (i, p) in enumerate(idx):
        if model[i].name in pb.nuisance_effects or model[i].name in free:
            continue
        a, b = acceptable_units(p)
        lo[k], hi[k] = a + 1e-6, b - 1e-6
    return lo, hi


def polish(pb, model: tuple, names: set, fixed: frozenset = frozenset(), least: int = 2,
           free: frozenset = frozenset()) -> tuple:
    """Joint least-squares refit of the parameters of the applied effects named in ``names`` (the others, the
    (index, parameter) pairs in ``fixed`` and those ``Problem.held_values`` names held), from their current
    values, each added effect kept inside its plausible range and the effects in ``free`` within their search bounds (``_polish_bounds``);
    ``model`` itself if that does not lower the fit cost, or if fewer than ``least`` parameters are free (one
    alone is better fitted by :func:`fit`'s grids).

    One-at-a-time refits zigzag along a valley where two parameters trade (a stiffer seat and a
    lower Cd both restore the delivery a soft seat loses); Gauss-Newton steps follow it. The Jacobian is
    taken by forward differences once and then updated along the steps (:class:`SecantJacobian`).
    """
    idx = [(i, p) for i, a in enumerate(model) if a.name in names
           for p in pb.eff(a.name).parameters_for(pb.context, a.target)
           if (i, p.name) not in fixed and p.name not in pb.held_values(a.name, a.target)]
    if len(idx) < least or not idx:
        return model

    def model_of(u) -> tuple:
        m = model
        for (i, p), ui in zip(idx, u):
            m = with_value(m, i, p.name, p.from_unit(ui))
        return m

    r0 = pb.residual_vector(model)
    if r0 is None:
        return model
    lo, hi = _polish_bounds(pb, model, idx, free)
    x0 = np.clip([p.to_unit(model[i].value_dict[p.name]) for i, p in idx], np.maximum(lo, 1e-6),
                 np.minimum(hi, 1 - 1e-6))

    def fun(u):
        r = pb.residual_vector(model_of(u))
        return np.full(r0.size, 1e3) if r is None else r

    res = least_squares(fun, x0, jac=SecantJacobian(pb, fun, model_of, (lo, hi)), bounds=(lo, hi),
                        x_scale=0.1, max_nfev=pb.settings.polish_nfev * len(idx), method="trf")
    out = model_of(res.x)
    return out if pb.fit_objective(out)[0] < float(r0 @ r0) else model


#: the forward-difference step of :func:`polish`'s Jacobian [unit coordinates of the search bounds]
POLISH_STEP = 0.01


def forward_jacobian(pb, fun, model_of, u: np.ndarray, bounds: tuple, f0: np.ndarray) -> np.ndarray:
    """d(fit residuals)/du at ``u`` (residuals ``f0`` there) by forward differences of POLISH_STEP (backward
    where a step would leave ``bounds``), as scipy's 2-point scheme with ``diff_step`` POLISH_STEP takes them on
    unit coordinates, but with every perturbed point simulated in one batch: the columns run on the workers
    together instead of one fitting-run batch after another."""
    u = np.asarray(u, float)
    lo, hi = bounds
    h = np.where(u + POLISH_STEP > hi, -POLISH_STEP, POLISH_STEP)
    points = [u + h[j] * np.eye(u.size)[j] for j in range(u.size)]
    pb.sims.many([(pb.conds[r.name], model_of(x)) for x in points for r in pb.fit_runs])
    return np.column_stack([(fun(x) - f0) / h[j] for j, x in enumerate(points)])


class SecantJacobian:
    """:func:`polish`'s Jacobian: forward differences where the polish starts (:func:`forward_jacobian`, one
    simulation per fitting run and parameter), then Broyden's rank-one update along each accepted step
    (J += (df - J du) du^T / |du|^2: exact for the residuals' change along the step, the rest kept).

    Why: every polish ends on its budget (Settings.polish_nfev residual evaluations per parameter; measured on
    the independent suite, none converged before it), and scipy's trust-region step asks for a Jacobian after
    each accepted step, so forward differences cost k evaluations per step beside the step's one: 2-4 times the
    evaluations the budget counts. A secant Jacobian costs none; where it is poor the trust region rejects the
    step and shrinks, at one evaluation."""

    def __init__(self, pb, fun, model_of, bounds: tuple):
        self.pb, self.fun, self.model_of, self.bounds = pb, fun, model_of, bounds
        self.u = self.f = self.J = None

    def __call__(self, u) -> np.ndarray:
        u = np.array(u, float)
        f = self.fun(u)        # simulated already: scipy asks for the Jacobian where it has just evaluated
        if self.J is None:
            self.J = forward_jacobian(self.pb, self.fun, self.model_of, u, self.bounds, f)
        else:
            du = u - self.u
            d2 = float(du @ du)
            if d2 > 0.0:
                self.J = self.J + np.outer(f - self.f - self.J @ du, du) / d2
        self.u, self.f = u, f
        return self.J
