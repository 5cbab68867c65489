"""u_input: the model file's declared input uncertainties propagated through the fast pump model by Monte Carlo.

Each operating point draws its model's declarations (``[uncertainty."KEY"]``,
:mod:`lumped.model.uncertainty`) on scrambled Sobol points (scipy.stats.qmc, seeded; the inverse
CDF of each declaration's normal or uniform distribution), sets the keys
(:func:`lumped.model.model_file.with_values`) and runs the compiled stepper at rtol 1e-4 (the
sweeps' design tolerance: its numerical noise, ~1e-5 relative in delivery, is far below
u_input) until the cyclic steady-state test passes (:meth:`lumped.run.revolutions.StopRule.steady`,
two revolutions at least), each draw of a task started from the state predicted from the draws
solved before it (a warm start, :class:`lumped.run.warmstart.WarmStarts`, the draws visited in a
nearest-neighbour chain of their standard scores). The simulations run on a dask cluster like
the sweeps (:class:`studies.sweeps.cluster.Cluster`), or in this process.

u_input of an output is the standard deviation of its draws. How well the sample knows
it is measured, not assumed: :data:`SCRAMBLES` independent scrambles of the Sobol sequence
each give an estimate u_r, and the standard error of the pooled estimate is
se = std(u_r) / sqrt(SCRAMBLES) (randomised QMC; Owen 1997). That standard error is the
Monte Carlo's precision, reported beside u_input (``se``, ``precision`` = 2 se / u); it is
not a degree of freedom: the declarations are Type B, their u_input has infinite degrees of
freedom (GUM G.4.3). Two ways to size the sample:

- adaptive (``valvelab pump --uncertainty``): 16 points per scramble, doubled (keeping the
  sequences balanced) until 2 se is within 10 % of u_input for every output, or 128 per
  scramble (1024 draws); ``--quick``: 8 per scramble, once;
- a fixed budget (``per_scramble``, ``valvelab validate``): that many points per scramble at
  once, so the total is known before the first draw.

Points of one ``group`` (the runs of one rig) share their Sobol points: draw k is the same
set of inputs at every point of the group, so the draws give the joint distribution of the
group's outputs (differences between conditions, a calibration on some runs and a
prediction of the others; :mod:`studies.validation.joint`).

Contributors: a linear regression of the output on the standard scores of the same draws
(first-order, linear variance decomposition): input j contributes |beta_j| sd(z_j), in the
output's units; ``linear_r2`` says how much of the variance the linear model explains
(the contributions add in quadrature to u_input when it is near 1).
"""

from __future__ import annotations

import math
import sys
from dataclasses import asdict, dataclass, replace

import numpy as np

from studies.validation.numerical import OUTPUTS
from studies.validation.point import Point

#: the fast path's tolerances for the draws
MC_RTOL, MC_ATOL = 1e-4, 1e-6
#: independent scrambles of the Sobol sequence (their spread measures the estimate's precision)
SCRAMBLES = 8
#: points per scramble: 2^FIRST_POWER to start, doubled up to 2^MAX_POWER; --quick: 2^QUICK_POWER once
FIRST_POWER, MAX_POWER, QUICK_POWER = 4, 7, 3
#: stop when 2 x the standard error of u_input is at most this fraction of it
TARGET_PRECISION = 0.10
#: the contributors reported per output
TOP = 3
#: draws per dask task (a warm start comes from the draws before it in its task)
BATCH = 64
#: at most this many revolutions per draw (unless the point's max_revolutions is larger)
DRAW_MAX_REVOLUTIONS = 12


@dataclass(frozen=True)
class InputUncertainty:
    """u_input of one output at one point (output units)."""

    output: str
    unit: str
    u: float | None
    mean: float | None
    precision: float | None                 # 2 x standard error of u / u
    se: float | None                        # the Monte Carlo's standard error of u (output units)
    samples: int
    missing: int                            # draws where the output is undefined or the run failed
    contributors: tuple[tuple[str, float], ...]
    linear_r2: float | None
    note: str = ""

    def as_dict(self) -> dict:
        d = asdict(self)
        d["contributors"] = [list(c) for c in self.contributors]
        return d


def evaluate_draws(model, speed_rpm: float, load_pressure: float, decls, keys: dict, zs, settings: dict,
                   outputs=tuple(OUTPUTS)) -> list[dict | None]:
    """The outputs of ``model`` at each draw of standard scores ``zs`` (None for a failed run); runs on a worker.

    ``settings``: ``revolutions`` (at least, default 2), ``max_revolutions``, ``circuit``; each draw runs
    until the cyclic steady-state test passes, warm-started from the draws solved before it."""
    from lumped.run.simulate import simulate
    from lumped.model.model_file import with_values
    from lumped.run.revolutions import StopRule
    from lumped.model.uncertainty import sample_values
    from lumped.run.warmstart import WarmStarts, chain_order
    from studies.validation.numerical import output_values

    settings = dict(settings)
    least = max(2, int(settings.pop("revolutions", 2) or 2))
    most = max(least, int(settings.pop("max_revolutions", None) or DRAW_MAX_REVOLUTIONS))
    stop = StopRule.steady(max_revolutions=most, min_revolutions=least)
    zs = [np.asarray(z, dtype=float) for z in zs]
    pool = WarmStarts()
    out: list = [None] * len(zs)
    for i in chain_order(np.array(zs)) if zs else []:
        try:
            m = with_values(model, sample_values(model, decls, zs[i], keys))
            # at MC_RTOL, tighter than the default: no accuracy check (its cost per draw, not its need)
            r = simulate(m, speed_rpm, load_pressure, method="fast", rtol=MC_RTOL, atol=MC_ATOL, stop=stop,
                         initial_state=pool.predict(zs[i]), accuracy_check=False, **settings)
            pool.add(zs[i], r.tdc_state)
            out[i] = output_values(r, {k: OUTPUTS[k] for k in outputs})
        except Exception:  # noqa: BLE001 - a draw the model cannot run is counted as missing, by design
            out[i] = None
    return out


class _State:
    """The draws of one point: its Sobol samplers, standard scores and results per scramble."""

    def __init__(self, point: Point, seed: int, index: int):
        from scipy.stats import qmc

        from lumped.model.uncertainty import check_reach, numeric_keys

        self.point = point
        self.decls = tuple(point.model.uncertainties)
        check_reach(point.model, self.decls)
        self.model = replace(point.model, uncertainties=())
        self.keys = numeric_keys(self.model)
        d = len(self.decls)
        self.samplers = [qmc.Sobol(d, scramble=True, rng=np.random.default_rng([seed, index, r]))
                         for r in range(SCRAMBLES)] if d else []
        self.z: list[list] = [[] for _ in range(SCRAMBLES)]
        self.y: list[list] = [[] for _ in range(SCRAMBLES)]
        self.n = 0
        self.done = d == 0

    def next_draws(self, n: int) -> list[tuple[int, np.ndarray]]:
        """(scramble, standard scores) of the next ``n`` points of every scramble."""
        from lumped.model.uncertainty import standard_scores

        out = []
        for r, s in enumerate(self.samplers):
            z = standard_scores(self.decls, s.random(n))
            self.z[r] += list(z)
            out.append((r, z))
        self.n += n
        return out


def _estimate(state: _State, name: str, unit: str) -> InputUncertainty:
    decls = state.decls
    if not decls:
        return InputUncertainty(name, unit, 0.0, None, 0.0, None, 0, 0, (), None,
                                "the model declares no input uncertainties")
    zs, ys, scr = [], [], []
    for r in range(SCRAMBLES):
        for z, y in zip(state.z[r], state.y[r]):
            v = None if y is None else y.get(name)
            if v is not None and math.isfinite(v):
                zs.append(z)
                ys.append(v)
                scr.append(r)
    n_all = sum(len(y) for y in state.y)
    missing = n_all - len(ys)
    if len(ys) < 4:
        return InputUncertainty(name, unit, None, None, None, None, n_all, missing, (), None,
                                "undefined in (almost) every draw: the valve never opens or never reseats")
    Z, Y, S = np.asarray(zs), np.asarray(ys), np.asarray(scr)
    u = float(np.std(Y, ddof=1))
    per = [float(np.std(Y[S == r], ddof=1)) for r in range(SCRAMBLES) if np.sum(S == r) >= 2]
    se = float(np.std(per, ddof=1) / math.sqrt(len(per))) if len(per) >= 2 else math.inf
    precision = 0.0 if u == 0.0 else (2.0 * se / u if math.isfinite(se) else None)
    contributors, r2 = (), None
    if u > 0.0:
        X = np.column_stack([np.ones(len(Y)), Z])
        beta, *_ = np.linalg.lstsq(X, Y, rcond=None)
        resid = Y - X @ beta
        r2 = float(1.0 - np.sum(resid**2) / np.sum((Y - Y.mean()) ** 2))
        contrib = [(d.key, float(abs(b) * np.std(Z[:, j], ddof=1))) for j, (d, b) in enumerate(zip(decls, beta[1:]))]
        contributors = tuple(sorted(contrib, key=lambda c: -c[1])[:TOP])
    note = ""
    if missing:
        note = f"{missing} of {n_all} draws without this output (a valve event missing or a failed run), left out"
    return InputUncertainty(name, unit, u, float(Y.mean()), precision, se if math.isfinite(se) else None, len(ys),
                            missing, contributors, r2, note)


def propagate(points, *, quick: bool = False, seed: int = 0, cluster=None, progress: bool = False,
              outputs=tuple(OUTPUTS), draws: dict | None = None,
              per_scramble: int | None = None) -> dict[str, dict[str, InputUncertainty]]:
    """u_input of ``outputs`` at every :class:`~studies.validation.point.Point` (see the module docstring); ``cluster``: a
    :class:`studies.sweeps.cluster.Cluster` (None: in this process). ``per_scramble``: a fixed
    budget of that many points per scramble (a power of two), else the adaptive doubling. ``draws``: a
    dict that receives {point: {"z": standard scores (n x d), "scramble": scramble of each draw (n),
    "keys": the declarations' keys, output: its value at each draw (NaN where undefined)}}, the draws in
    the same order at every point of a group."""
    states = _states(points, seed)
    first = per_scramble or 2**(QUICK_POWER if quick else FIRST_POWER)
    bar = None
    if progress:
        from tqdm import tqdm

        # a fixed budget is the whole total; the adaptive one grows it when a point doubles
        bar = tqdm(total=SCRAMBLES * first * sum(not s.done for s in states), desc="input uncertainty",
                   unit="draw", file=sys.stderr, smoothing=0.05)
    while True:
        active = [s for s in states if not s.done]
        if not active:
            break
        tasks = _tasks(active, first)
        if bar is not None and bar.n + sum(len(t[2]) for t in tasks) > bar.total:
            bar.total = bar.n + sum(len(t[2]) for t in tasks)
            bar.refresh()
        for (s, rs, _), rows in zip(tasks, _run(tasks, cluster, bar, outputs)):
            for r, row in zip(rs, rows):
                s.y[r].append(row)
        _settle(active, quick or per_scramble is not None, outputs)
    if bar is not None:
        bar.close()
    if draws is not None:
        for s in states:
            draws[s.point.name] = _aligned(s, outputs)
    return {s.point.name: {o: _estimate(s, o, OUTPUTS[o]) for o in outputs} for s in states}


def _states(points, seed: int) -> list[_State]:
    """One state per point; the points of a group draw from the same Sobol sequences (the group's first index)."""
    first: dict = {}
    states = []
    for i, p in enumerate(points):
        index = first.setdefault(p.group, i) if p.group is not None else i
        states.append(_State(p, seed, index))
        lead = states[index]
        if p.group is not None and [d.key for d in lead.decls] != [d.key for d in states[-1].decls]:
            raise ValueError(f"points of group {p.group!r} declare different uncertainties: they cannot share draws")
    return states


def _tasks(active, first: int) -> list[tuple]:
    """The next draws of every active state, cut into tasks of at most BATCH draws: a draw's warm start is the
    state predicted from the draws solved before it in its task."""
    tasks = []
    for s in active:
        n = first if s.n == 0 else s.n          # doubling keeps each scramble's sequence balanced
        flat = [(r, zz) for r, z in s.next_draws(n) for zz in z]
        for k in range(0, len(flat), BATCH):
            part = flat[k:k + BATCH]
            tasks.append((s, [r for r, _ in part], [zz for _, zz in part]))
    return tasks


def _settle(active, once: bool, outputs) -> None:
    """Mark the states whose estimate is precise enough (or that ran their one round) done; a group is done when
    every point of it is, so its points keep drawing the same points."""
    for s in active:
        if once or s.n >= 2**MAX_POWER:
            s.done = True
            continue
        est = [_estimate(s, o, OUTPUTS[o]) for o in outputs]
        s.done = all(e.precision is None or e.precision <= TARGET_PRECISION for e in est)
    groups: dict = {}
    for s in active:
        if s.point.group is not None:
            groups.setdefault(s.point.group, []).append(s)
    for members in groups.values():
        done = all(s.done for s in members)
        for s in members:
            s.done = done


def _aligned(state: _State, outputs) -> dict:
    """The draws of a state in scramble order: standard scores, scramble ids and each output (NaN: undefined)."""
    z = [z for r in range(SCRAMBLES) for z in state.z[r]]
    y = [y for r in range(SCRAMBLES) for y in state.y[r]]
    out = {"z": np.array(z, dtype=float).reshape(len(z), len(state.decls)),
           "scramble": np.array([r for r in range(SCRAMBLES) for _ in state.z[r]], dtype=int),
           "keys": tuple(d.key for d in state.decls)}
    for o in outputs:
        out[o] = np.array([np.nan if row is None or row.get(o) is None else row[o] for row in y], dtype=float)
    return out


def _run(tasks, cluster, bar, outputs) -> list[list]:
    """Results of each task, in order (on the cluster's workers, or here)."""
    def args(t):
        s, _, z = t
        p = s.point
        settings = {"revolutions": p.revolutions, "max_revolutions": p.max_revolutions, "circuit": p.circuit}
        return (s.model, p.speed_rpm, p.load_pressure, s.decls, s.keys, list(z), settings, tuple(outputs))

    if cluster is None:
        out = []
        for t in tasks:
            out.append(evaluate_draws(*args(t)))
            if bar is not None:
                bar.update(len(t[2]))
        return out
    from distributed import as_completed

    client = cluster.get()
    futures = [client.submit(evaluate_draws, *args(t), pure=False) for t in tasks]
    index = {f.key: i for i, f in enumerate(futures)}
    out: list = [None] * len(futures)
    for f in as_completed(futures):
        out[index[f.key]] = f.result()
        if bar is not None:
            bar.update(len(tasks[index[f.key]][2]))
        f.release()
    return out


def summary(result: dict[str, InputUncertainty]) -> dict:
    """Draws used and the worst precision reached over the outputs of one point."""
    prec = [e.precision for e in result.values() if e.precision is not None]
    n = max((e.samples + e.missing for e in result.values()), default=0)
    return {"draws": n, "worst_precision": max(prec) if prec else None}
