"""The gap between measured and modelled pump runs, and where in the cycle it sits, in words.

Everything here works on one revolution in crank angle (0 deg = top dead centre;
the suction stroke is 0-180 deg, the delivery stroke 180-360 deg). A measured trace
is folded onto crank angle; a simulated one (:class:`CycleTrace`) is interpolated
periodically at the measured crank angles, after the position sensor's nuisances
(a scale error per valve, one time offset) are applied.

Metrics per run: position RMS [m] (and its excess over the measurement noise),
opening / closing timing error [crank deg], peak-opening error [m], seated-position
error [m], delivery error [%] (modelled - measured, the thesis's sign, Tables 5.4,
5.6), and, where the run has a cylinder-pressure trace, its RMS gap [Pa] and excess over
the transducer noise: the pressure is what a piston leak changes (it lowers the pressure
while both valves are shut, in proportion to the pressure difference and the time) and
what a discharge coefficient does not mimic (it moves the pressure with the flow). The sentences a hydraulic engineer reads
("delivery valve sits 0.30 mm below its modelled seat position during the suction
stroke (crank 12-171 deg)"): :mod:`studies.discrepancy.words`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from lumped.model.pump_model import POSITIONS
from lumped.run.trace import Trace
from studies.discrepancy.measured import Run

VALVES = POSITIONS          # the valves a trace holds


class CycleTrace(Trace):
    """One simulated revolution on crank angle: a :class:`lumped.run.trace.Trace` (positions [m] of both
    valves, cylinder pressure [Pa] if known) with the delivery of that revolution [m^3/rev].

    Built from crank angles [deg] within [0, 360): the trace's clock is one revolution per second
    (``speed_rpm = 60``), so ``crank_deg`` gives the angles back.
    """

    def __init__(self, crank_deg, positions: dict, delivery_m3_per_rev: float, cylinder_pressure_pa=None):
        base = Trace.measured(np.asarray(crank_deg, dtype=float) / 360.0, positions, cylinder_pressure_pa,
                              speed_rpm=60.0)
        super().__init__(base.time, base.speed_rpm, base.signals)
        object.__setattr__(self, "delivery_m3_per_rev", float(delivery_m3_per_rev))


#: default tolerance of the cylinder-pressure gap (GapScales.pressure_pa), from the leak/Cd study
#: of docs/discrepancy.md ("Small leaks")
PRESSURE_TOLERANCE_PA = 2.5e3
#: the robust scale of the cylinder-pressure residual [noise deviations]: where a squeeze film lets go the
#: delivery-opening spike (up to 5.9 MPa) moves by 0.5-1 deg between implementations or tolerances, and its
#: few samples (residuals of 20-170 noise deviations) outweighed every other residual by 10,000 units; a
#: Cauchy loss at 5 deviations keeps a residual of one deviation (a leak's pressure deficit) at 98 % of its
#: square and takes a 100-deviation one to 1.5 % (docs/discrepancy.md, "The cost")
PRESSURE_ROBUST = 5.0


@dataclass(frozen=True)
class GapScales:
    """What counts as one unit of gap: a position RMS [m] and a relative delivery error [-].

    They weight the two kinds of evidence in fits and scores (a 20 um RMS position
    gap weighs as much as a 0.5 % delivery error) and are the smallest gaps put
    into words.
    """

    position_m: float = 2.0e-5
    delivery_frac: float = 5.0e-3
    #: cylinder-pressure RMS above the transducer noise [Pa] that weighs as one unit
    pressure_pa: float = PRESSURE_TOLERANCE_PA
    #: the cylinder-pressure residual's robust scale, in noise deviations: a sample weighs c^2 ln(1 + (z / c)^2)
    #: noise variances instead of z^2 (:func:`robust_pressure`); 0 for plain least squares
    pressure_robust: float = PRESSURE_ROBUST


@dataclass(frozen=True)
class Nuisance:
    """Position-sensor nuisances: scale factor per valve [-], time offset [s] (measured lags model)."""

    scale: dict = field(default_factory=lambda: {"inlet": 1.0, "delivery": 1.0})
    offset_s: float = 0.0

    def as_dict(self) -> dict:
        return {"scale_inlet": self.scale.get("inlet", 1.0), "scale_delivery": self.scale.get("delivery", 1.0),
                "time_offset_s": self.offset_s}


# --------------------------------------------------------------------------- folding


@dataclass(frozen=True)
class Folded:
    """A measured run's trace folded onto crank angle, sorted, with its noise estimate."""

    crank_deg: dict       # valve -> crank angles [deg]
    position: dict        # valve -> measured position [m]
    noise_m: dict         # valve -> white-noise standard deviation [m]
    pressure_crank_deg: np.ndarray | None = None   # crank angles of the cylinder-pressure samples [deg]
    pressure_pa: np.ndarray | None = None          # measured cylinder pressure [Pa], absolute
    pressure_noise_pa: float = 0.0                 # its white-noise standard deviation [Pa]


def noise_std(x: np.ndarray) -> float:
    """White-noise standard deviation of a sampled signal [m] from the MAD of its second differences.

    Second differences cancel the signal's slope; the median ignores the few samples
    at impacts. Var(x[i+1] - 2 x[i] + x[i-1]) = 6 sigma^2 for white noise.
    """
    d2 = np.diff(np.asarray(x, float), 2)
    if d2.size == 0:
        return 0.0
    mad = np.median(np.abs(d2 - np.median(d2)))
    return float(1.4826 * mad / np.sqrt(6.0))


def fold(run: Run) -> Folded:
    """Fold a measured run's trace onto one revolution of crank angle (noise estimated in time order)."""
    tr = run.trace
    th = replace(tr, speed_rpm=run.speed_rpm).crank_deg     # the run's speed is the one measured
    order = np.argsort(th, kind="stable")
    crank, pos, noise = {}, {}, {}
    for valve, x in tr.positions.items():
        crank[valve] = th[order]
        pos[valve] = np.asarray(x, float)[order]
        noise[valve] = noise_std(x)
    if tr.cylinder_pressure_pa is None:
        return Folded(crank, pos, noise)
    pc = np.asarray(tr.cylinder_pressure_pa, float)
    return Folded(crank, pos, noise, th[order], pc[order], noise_std(pc))



def _periodic_table(crank: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Crank samples in [0, 360) extended by one sample each side so plain interpolation wraps."""
    c = np.concatenate([[crank[-1] - 360.0], crank, [crank[0] + 360.0]])
    v = np.concatenate([[values[-1]], values, [values[0]]])
    return c, v


def periodic_interp(theta: np.ndarray, crank: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of a 360-deg periodic signal at ``theta`` [deg] (``crank`` sorted in [0, 360))."""
    c, v = _periodic_table(np.asarray(crank, float), np.asarray(values, float))
    return np.interp(np.mod(theta, 360.0), c, v)


def predict(sim: CycleTrace, valve: str, theta: np.ndarray, speed_rpm: float, nuisance: Nuisance) -> np.ndarray:
    """What the position sensor would read [m]: scale * x_model(theta - crank angle of the time offset)."""
    shift = nuisance.offset_s * speed_rpm * 6.0
    return nuisance.scale.get(valve, 1.0) * periodic_interp(theta - shift, sim.crank_deg, sim.positions[valve])


# --------------------------------------------------------------------------- nuisances


def _sensor_traces(runs: list[Run], folded: dict, sims: dict) -> list[tuple]:
    """(valve, measured crank [deg], measured position [m], model crank table, model positions, crank rate
    [deg/s], weight 1/N) of every measured position trace of ``runs``."""
    traces = []
    for r in runs:
        if r.trace is None:
            continue
        f, s = folded[r.name], sims[r.name]
        for valve, th in f.crank_deg.items():
            c, v = _periodic_table(s.crank_deg, s.positions[valve])
            m = f.position[valve]
            traces.append((valve, th, m, c, v, r.speed_rpm * 6.0, 1.0 / m.size))
    return traces


def _sensor_cost(traces: list[tuple], offsets: np.ndarray, scale_bounds) -> tuple[np.ndarray, dict]:
    """(position cost per time offset, best sensor scale per valve per offset): for a given offset the best
    scale of each valve is linear least squares (closed form), clipped to ``scale_bounds``."""
    k = offsets.size
    pm = {v: np.zeros(k) for v in VALVES}
    pp = {v: np.zeros(k) for v in VALVES}
    mm = 0.0
    for valve, th, m, c, v, omega, w in traces:
        x = np.mod(th[None, :] - offsets[:, None] * omega, 360.0)
        p = np.interp(x.ravel(), c, v).reshape(k, th.size)
        pm[valve] += w * (p @ m)
        pp[valve] += w * np.einsum("ij,ij->i", p, p)
        mm += w * float(m @ m)
    cost = np.full(k, mm)
    scale = {}
    for valve in VALVES:
        with np.errstate(invalid="ignore", divide="ignore"):
            sv = np.where(pp[valve] > 0, pm[valve] / pp[valve], 1.0)
        sv = np.clip(sv, *scale_bounds)
        cost += -2.0 * sv * pm[valve] + sv**2 * pp[valve]
        scale[valve] = sv
    return cost, scale


def fit_nuisance(
    runs: list[Run], folded: dict, sims: dict, *, scale_bounds=(0.95, 1.05), offset_bounds_s=(-1e-3, 1e-3),
    n_grid: int = 21,
) -> Nuisance:
    """Sensor scale per valve and one time offset minimising the position residual over ``runs``.

    For a given offset the best scale of each valve is linear least squares (closed
    form, clipped to ``scale_bounds``); the offset is found on a grid, refined on a
    finer grid around the best point and polished by a parabola through three points.
    ``folded``/``sims`` map run name -> :class:`Folded` / :class:`CycleTrace`.
    Each trace weighs 1/N (its mean square), like the fit objective.
    """
    traces = _sensor_traces(runs, folded, sims)
    if not traces:
        return Nuisance()
    lo, hi = offset_bounds_s
    grid = np.linspace(lo, hi, n_grid)
    for _ in range(2):   # coarse grid, then a fine grid around its best point
        cost, _ = _sensor_cost(traces, grid, scale_bounds)
        i = int(np.argmin(cost))
        step = grid[1] - grid[0]
        grid = np.linspace(max(lo, grid[i] - step), min(hi, grid[i] + step), 11)
    cost, _ = _sensor_cost(traces, grid, scale_bounds)
    i = int(np.argmin(cost))
    best = float(grid[i])
    if 0 < i < grid.size - 1:   # parabola through the best point and its neighbours
        c0, c1, c2 = cost[i - 1: i + 2]
        den = c0 - 2 * c1 + c2
        if den > 0:
            best += 0.5 * (c0 - c2) / den * (grid[1] - grid[0])
    _, scale = _sensor_cost(traces, np.array([best]), scale_bounds)
    return Nuisance(scale={v: float(scale[v][0]) for v in VALVES}, offset_s=best)


# --------------------------------------------------------------------------- events


def smooth(theta: np.ndarray, x: np.ndarray, width_deg: float) -> np.ndarray:
    """Circular moving average over ``width_deg`` of a signal sampled at sorted crank angles."""
    n = x.size
    if n < 3 or width_deg <= 0:
        return x
    k = max(1, int(round(width_deg / (360.0 / n))))
    if k < 2:
        return x
    pad = np.concatenate([x[-k:], x, x[:k]])
    c = np.convolve(pad, np.ones(k) / k, mode="same")
    return c[k:-k]


@dataclass(frozen=True)
class Events:
    """When a valve is open in one revolution (crank deg) and its peak and seated positions [m]."""

    opening_deg: float | None
    closing_deg: float | None
    peak_m: float
    seated_m: float | None
    open_mask: np.ndarray


def valve_events(theta: np.ndarray, x: np.ndarray, threshold_m: float, smooth_deg: float = 2.0) -> Events:
    """Opening and closing crank angles of the longest open interval (x above ``threshold_m``).

    ``theta`` sorted in [0, 360). Crossings are interpolated between samples.
    """
    xs = smooth(theta, np.asarray(x, float), smooth_deg)
    is_open = xs > threshold_m
    peak = float(np.max(xs))
    if is_open.all() or not is_open.any():
        seated = None if is_open.all() else float(np.median(xs))
        return Events(None, None, peak, seated, is_open)
    n = xs.size
    # rotate so that index 0 is closed, then the open intervals do not wrap
    start = int(np.flatnonzero(~is_open)[0])
    idx = (np.arange(n) + start) % n
    o = is_open[idx]
    edges = np.diff(o.astype(int))
    rises = np.flatnonzero(edges == 1)     # o[i] closed, o[i+1] open
    falls = np.flatnonzero(edges == -1)    # o[i] open, o[i+1] closed
    if o[-1]:
        falls = np.append(falls, n - 1)
    best = int(np.argmax([f - r for r, f in zip(rises, falls)]))
    r, f = rises[best], falls[best]

    def cross(i):  # crossing between rotated samples i and i+1
        a, b = idx[i], idx[(i + 1) % n]
        ta, tb = theta[a], theta[b]
        if tb < ta:
            tb += 360.0
        xa, xb = xs[a], xs[b]
        frac = 0.0 if xb == xa else (threshold_m - xa) / (xb - xa)
        return float(np.mod(ta + np.clip(frac, 0.0, 1.0) * (tb - ta), 360.0))

    opening = cross(r)
    closing = cross(f)  # f = n - 1: between the last rotated sample and the first (closed) one
    open_mask = np.zeros(n, bool)
    open_mask[idx[r + 1: f + 1]] = True
    seated = float(np.median(xs[~open_mask])) if (~open_mask).any() else None
    return Events(opening, closing, peak, seated, open_mask)


def wrap_deg(a):
    """Angle difference(s) wrapped to (-180, 180] [deg]."""
    w = -(np.mod(-np.asarray(a, float) + 180.0, 360.0) - 180.0)
    return float(w) if w.ndim == 0 else w


def closed_window(theta: np.ndarray, ev: Events, margin_deg: float = 10.0) -> np.ndarray:
    """Samples well inside the closed phase (``margin_deg`` away from the opening and closing)."""
    closed = ~ev.open_mask
    if ev.opening_deg is None:
        return closed
    far = np.ones_like(closed)
    for a in (ev.opening_deg, ev.closing_deg):
        far &= np.abs(wrap_deg(theta - a)) > margin_deg
    return closed & far


# --------------------------------------------------------------------------- metrics


@dataclass(frozen=True)
class ValveGap:
    """Gap of one valve's position in one run (measured - modelled unless stated)."""

    valve: str
    rms_m: float
    noise_m: float
    opening_error_deg: float | None     # positive: opens later than modelled
    closing_error_deg: float | None     # positive: closes later than modelled
    peak_error_m: float                 # measured peak - modelled peak
    seated_error_m: float | None        # measured - modelled position in the closed phase
    measured: Events
    modelled: Events
    residual_m: np.ndarray              # measured - predicted, at the measured crank angles
    crank_deg: np.ndarray

    @property
    def excess_rms_m(self) -> float:
        """RMS gap above the white measurement noise [m]."""
        return float(np.sqrt(max(self.rms_m**2 - self.noise_m**2, 0.0)))


@dataclass(frozen=True)
class PressureGap:
    """Gap of the cylinder pressure in one run (measured - modelled, absolute pressures)."""

    rms_pa: float                       # of the residuals under the robust loss (robust_pressure)
    noise_pa: float                     # the transducer noise under the same loss
    residual_pa: np.ndarray             # at the measured crank angles
    crank_deg: np.ndarray

    @property
    def excess_rms_pa(self) -> float:
        """RMS gap above the white transducer noise [Pa]."""
        return float(np.sqrt(max(self.rms_pa**2 - self.noise_pa**2, 0.0)))


@dataclass(frozen=True)
class RunGap:
    """Gap of one run: its valves' position gaps, the delivery error and the cylinder-pressure gap."""

    run: str
    speed_rpm: float
    load_pressure_pa: float
    valves: tuple
    delivery_error_pct: float | None     # (modelled - measured) / measured * 100
    pressure: PressureGap | None = None

    @property
    def position_rms_m(self) -> float | None:
        if not self.valves:
            return None
        return float(np.sqrt(np.mean([v.rms_m**2 for v in self.valves])))

    def cost_parts(self, scales: GapScales) -> dict:
        """The dimensionless gap by kind of evidence: position (RMS^2 - noise^2) / scale^2 summed over the
        measured valves, delivery (error / scale)^2, pressure (RMS^2 - noise^2) / scale^2.

        The mean square above the noise, not floored at zero: on data the model reproduces it scatters about 0
        (the noise estimate's own error, ~5 % of the noise at 700 samples, is 1-2.5 gap units of a pressure
        trace either way, since one unit is a quarter of the 10 kPa noise); floored, every clean run kept
        0-2.5 units and a clean reed dataset 9."""
        d = 0.0 if self.delivery_error_pct is None else (self.delivery_error_pct / 100.0 / scales.delivery_frac) ** 2
        pr = 0.0 if self.pressure is None else \
            (self.pressure.rms_pa**2 - self.pressure.noise_pa**2) / scales.pressure_pa**2
        return {"position": float(sum(v.rms_m**2 - v.noise_m**2 for v in self.valves) / scales.position_m**2),
                "delivery": float(d), "pressure": float(pr)}

    def cost(self, scales: GapScales) -> float:
        """Dimensionless gap: (excess position RMS / scale)^2 + (delivery error / scale)^2
        + (excess cylinder-pressure RMS / scale)^2."""
        return float(sum(self.cost_parts(scales).values()))

    def as_dict(self) -> dict:
        d = {"run": self.run, "speed_rpm": self.speed_rpm, "load_pressure_pa": self.load_pressure_pa,
             "position_rms_m": self.position_rms_m, "delivery_error_pct": self.delivery_error_pct,
             "pressure_rms_pa": None if self.pressure is None else self.pressure.rms_pa,
             "pressure_excess_rms_pa": None if self.pressure is None else self.pressure.excess_rms_pa}
        for v in self.valves:
            d[v.valve] = {
                "position_rms_m": v.rms_m, "noise_m": v.noise_m,
                "opening_error_deg": v.opening_error_deg, "closing_error_deg": v.closing_error_deg,
                "peak_error_m": v.peak_error_m, "seated_error_m": v.seated_error_m,
            }
        return d


def event_threshold(x_meas: np.ndarray, noise_m: float) -> float:
    """Position above which a valve counts as open [m]: 10 % of the measured lift, at least 5 noise sigmas."""
    lift = float(np.percentile(x_meas, 99.5))
    return max(0.1 * lift, 5.0 * noise_m, 1e-6)


def run_gap(run: Run, folded: Folded, sim: CycleTrace, nuisance: Nuisance, scales: "GapScales | None" = None) -> RunGap:
    """Every gap metric of one run against one simulation (nuisances applied to the model)."""
    valves = []
    for valve, theta in folded.crank_deg.items():
        m = folded.position[valve]
        p = predict(sim, valve, theta, run.speed_rpm, nuisance)
        thr = event_threshold(m, folded.noise_m[valve])
        em, es = valve_events(theta, m, thr), valve_events(theta, p, thr)
        dopen = None if em.opening_deg is None or es.opening_deg is None else wrap_deg(em.opening_deg - es.opening_deg)
        dclose = None if em.closing_deg is None or es.closing_deg is None else wrap_deg(em.closing_deg - es.closing_deg)
        win = closed_window(theta, em)
        seated = float(np.median(m[win]) - np.median(p[win])) if win.sum() >= 5 else None
        r = m - p
        valves.append(ValveGap(valve, float(np.sqrt(np.mean(r**2))), folded.noise_m[valve], dopen, dclose,
                               em.peak_m - es.peak_m, seated, em, es, r, theta))
    d = None
    if run.delivery_m3_per_rev is not None:
        d = 100.0 * (sim.delivery_m3_per_rev - run.delivery_m3_per_rev) / run.delivery_m3_per_rev
    return RunGap(run.name, run.speed_rpm, run.load_pressure_pa, tuple(valves), d, pressure_gap(folded, sim, scales))


def pressure_residual(folded: Folded, sim: CycleTrace) -> np.ndarray | None:
    """Measured - modelled cylinder pressure [Pa] at the measured crank angles (None without both)."""
    if folded.pressure_pa is None or sim.cylinder_pressure_pa is None:
        return None
    return folded.pressure_pa - periodic_interp(folded.pressure_crank_deg, sim.crank_deg, sim.cylinder_pressure_pa)


def robust_pressure(r: np.ndarray, noise_pa: float, c: float) -> tuple[np.ndarray, float]:
    """(transformed residuals [Pa], their noise level [Pa]): the Cauchy (Lorentzian) loss of residuals z = r / noise,
    c^2 ln(1 + (z / c)^2) noise variances per sample, as residuals of that square with r's sign, and the square
    root of its mean for pure noise, E[c^2 ln(1 + Z^2 / c^2)] noise variances (Z standard normal; 0.947 at c =
    5, by quadrature). ``c`` <= 0 or no noise: ``r`` and ``noise_pa`` unchanged."""
    if c <= 0.0 or noise_pa <= 0.0:
        return r, noise_pa
    z = r / noise_pa
    t = np.sign(r) * noise_pa * c * np.sqrt(np.log1p((z / c) ** 2))
    return t, noise_pa * math.sqrt(_cauchy_noise(c))


@lru_cache(maxsize=8)
def _cauchy_noise(c: float) -> float:
    """E[c^2 ln(1 + Z^2 / c^2)] for Z standard normal (Gauss-Hermite quadrature, 80 nodes)."""
    x, w = np.polynomial.hermite_e.hermegauss(80)
    return float(np.sum(w * c * c * np.log1p((x / c) ** 2)) / math.sqrt(2.0 * math.pi))


def pressure_gap(folded: Folded, sim: CycleTrace, scales: "GapScales | None" = None) -> PressureGap | None:
    """The cylinder-pressure gap of one run (None where the run or the model has no pressure trace): the RMS and
    the noise of the residuals under the robust loss of ``scales`` (:func:`robust_pressure`; None: plain)."""
    r = pressure_residual(folded, sim)
    if r is None:
        return None
    t, noise = (r, folded.pressure_noise_pa) if scales is None else \
        robust_pressure(r, folded.pressure_noise_pa, scales.pressure_robust)
    return PressureGap(float(np.sqrt(np.mean(t**2))), noise, r, folded.pressure_crank_deg)


def _ang(d: float) -> float:
    """An angle difference wrapped into [0, 360) [deg]."""
    return float(np.mod(d, 360.0))


def crank_windows(theta: np.ndarray, r: np.ndarray, thr: float, merge_deg=5.0, min_deg=3.0) -> list[tuple]:
    """Crank windows (start, end, largest residual) where |r| exceeds ``thr``.

    Circular; windows closer than ``merge_deg`` are merged, shorter than ``min_deg`` dropped.
    """
    big = np.abs(r) > thr
    if not big.any():
        return []
    if big.all():
        return [(0.0, 360.0, float(r[np.argmax(np.abs(r))]))]
    n = r.size
    start = int(np.flatnonzero(~big)[0])
    idx = (np.arange(n) + start) % n      # rotated so the first sample is small
    b = big[idx].astype(int)
    edges = np.diff(b)
    rises, falls = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if b[-1]:
        falls = np.append(falls, n - 1)
    runs = [[int(i) + 1, int(j)] for i, j in zip(rises, falls)]
    merged = [runs[0]]
    for i, j in runs[1:]:
        if _ang(theta[idx[i]] - theta[idx[merged[-1][1]]]) < merge_deg:
            merged[-1][1] = j
        else:
            merged.append([i, j])
    wins = []
    for i, j in merged:
        a, e = theta[idx[i]], theta[idx[j]]
        if _ang(e - a) >= min_deg:
            seg = r[idx[i:j + 1]]
            wins.append((float(a), float(e), float(seg[np.argmax(np.abs(seg))])))
    return wins


def pressure_windows(gap: RunGap, scales: GapScales) -> list[tuple]:
    """Crank windows (start, end, largest residual [Pa]) where the smoothed cylinder-pressure residual of a run
    exceeds twice the pressure tolerance and three noise deviations of the 3-deg average; [] without a trace."""
    if gap.pressure is None:
        return []
    pg = gap.pressure
    rs = smooth(pg.crank_deg, pg.residual_pa, 3.0)
    n = max(1, int(round(3.0 / (360.0 / max(pg.crank_deg.size, 1)))))
    return crank_windows(pg.crank_deg, rs, max(2.0 * scales.pressure_pa, 3.0 * pg.noise_pa / math.sqrt(n)))


def summary(gaps: list[RunGap]) -> dict:
    """Dataset gap: position RMS pooled over runs [m] (also its excess over the measurement noise,
    the part a model can explain), RMS of the runs' delivery errors [%]."""
    pos = [g.position_rms_m for g in gaps if g.position_rms_m is not None]
    exc = [v.excess_rms_m for g in gaps for v in g.valves]
    dele = [g.delivery_error_pct for g in gaps if g.delivery_error_pct is not None]
    pres = [g.pressure.excess_rms_pa for g in gaps if g.pressure is not None]
    return {
        "position_rms_m": float(np.sqrt(np.mean(np.square(pos)))) if pos else None,
        "position_excess_rms_m": float(np.sqrt(np.mean(np.square(exc)))) if exc else None,
        "delivery_error_pct": float(np.sqrt(np.mean(np.square(dele)))) if dele else None,
        "pressure_excess_rms_pa": float(np.sqrt(np.mean(np.square(pres)))) if pres else None,
        "runs": len(gaps),
    }
