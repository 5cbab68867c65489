"""Disagreements in words: where in the cycle a measured valve departs from the model, as an engineer says it.

:func:`findings` lists one run's localised disagreements (seated position, opening and closing angles, peak,
crank windows of the residual, the delivery); :func:`describe` says those seen in at least half of the runs
of a valve ("delivery valve sits 0.30 mm below its modelled seat position during the suction stroke (crank
12-171 deg; 3 of 3 runs)").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from studies.discrepancy.gap import GapScales, RunGap, closed_window, crank_windows, smooth


def stroke(theta_deg: float) -> str:
    """Which stroke a crank angle is in (0 deg = TDC)."""
    t = np.mod(theta_deg, 360.0)
    if t < 10 or t > 350:
        return "around top dead centre"
    if 170 < t < 190:
        return "around bottom dead centre"
    return "suction stroke" if t < 180 else "delivery stroke"


@dataclass(frozen=True)
class Finding:
    """One localised disagreement of one valve in one run (values measured - modelled)."""

    run: str
    valve: str          # inlet, delivery or pump
    kind: str           # seated, opening, closing, peak, window, delivery
    value: float        # m, deg or %
    window: tuple | None = None  # crank deg (start, end)


def findings(gap: RunGap, scales: GapScales, timing_tol_deg: float = 2.0) -> list[Finding]:
    """Localised disagreements of one run beyond the tolerances (position, timing, delivery)."""
    out = []
    for v in gap.valves:
        ptol = max(scales.position_m, 5.0 * v.noise_m / np.sqrt(8.0))
        if v.seated_error_m is not None and abs(v.seated_error_m) > ptol:
            win = closed_window(v.crank_deg, v.measured)
            th = v.crank_deg[win]
            out.append(Finding(gap.run, v.valve, "seated", v.seated_error_m, _span(th)))
        for kind, err in (("opening", v.opening_error_deg), ("closing", v.closing_error_deg)):
            if err is not None and abs(err) > timing_tol_deg:
                at = v.measured.opening_deg if kind == "opening" else v.measured.closing_deg
                out.append(Finding(gap.run, v.valve, kind, err, (at - err, at)))
        if abs(v.peak_error_m) > ptol:
            out.append(Finding(gap.run, v.valve, "peak", v.peak_error_m, None))
        rs = smooth(v.crank_deg, v.residual_m, 3.0)
        for a, e, peak in crank_windows(v.crank_deg, rs, max(ptol, 3.0 * v.noise_m / np.sqrt(8.0))):
            out.append(Finding(gap.run, v.valve, "window", peak, (a, e)))
    if gap.delivery_error_pct is not None and abs(gap.delivery_error_pct) > 100.0 * scales.delivery_frac:
        out.append(Finding(gap.run, "pump", "delivery", -gap.delivery_error_pct, None))
    return out


def _span(theta: np.ndarray) -> tuple | None:
    """Smallest circular crank window holding all of ``theta`` (deg)."""
    if theta.size == 0:
        return None
    t = np.sort(np.mod(theta, 360.0))
    gaps = np.diff(np.concatenate([t, [t[0] + 360.0]]))
    k = int(np.argmax(gaps))
    return (float(t[(k + 1) % t.size]), float(t[k]))


def _fmt_window(w) -> str:
    a, e = w
    return f"crank {a:.0f}-{e:.0f} deg" if e >= a else f"crank {a:.0f}-{e + 360:.0f} deg"


def _mid(w) -> float:
    a, e = w
    if e < a:
        e += 360.0
    return (a + e) / 2.0


def describe(found: list[Finding], n_runs: dict) -> list[str]:
    """Sentences summarising findings over runs, largest first.

    ``n_runs`` maps a valve (and "pump") to the number of runs in which it was
    measured, so a sentence says in how many of them the disagreement appears; a
    disagreement seen in fewer than half of them is not systematic and not said.
    """
    groups: dict = {}
    for f in found:
        if f.kind == "window":
            continue  # windows are reported per run; the kinds below say them in words
        key = (f.valve, f.kind, np.sign(f.value))
        groups.setdefault(key, []).append(f)
    scored = []
    for (valve, kind, sign), fs in groups.items():
        if len(fs) < math.ceil(n_runs.get(valve, len(fs)) / 2):
            continue   # not systematic: in fewer than half the runs (the report lists every run)
        vals = np.array([f.value for f in fs])
        mean = float(np.mean(vals))
        cnt = f"{len(fs)} of {n_runs.get(valve, len(fs))} runs"
        unit, mul = {"seated": (" mm", 1e3), "peak": (" mm", 1e3), "delivery": (" %", 1.0)}.get(kind, (" deg", 1.0))
        rng = "" if len(fs) == 1 else (
            f", {np.min(np.abs(vals)) * mul:.2f}-{np.max(np.abs(vals)) * mul:.2f}{unit}")
        wins = [f.window for f in fs if f.window is not None]
        if kind == "seated":
            w = _fmt_window(wins[0]) if wins else ""
            where = stroke(_mid(wins[0])) if wins else "closed phase"
            s = (f"{valve} valve sits {abs(mean) * 1e3:.2f} mm {'below' if sign < 0 else 'above'} its modelled "
                 f"seated position during the {where} ({w}; {cnt}{rng})")
            weight = abs(mean) / 2e-5
        elif kind in ("opening", "closing"):
            verb = "opens" if kind == "opening" else "closes"
            at = wins[0][1] if wins else 0.0
            s = (f"{valve} valve {verb} {abs(mean):.1f} deg {'late' if sign > 0 else 'early'} "
                 f"(measured near crank {at:.0f} deg, {stroke(at)}; {cnt}{rng})")
            weight = abs(mean) / 2.0
        elif kind == "peak":
            s = (f"{valve} valve opens {abs(mean) * 1e3:.2f} mm {'wider' if sign > 0 else 'less'} than modelled "
                 f"at its peak ({cnt}{rng})")
            weight = abs(mean) / 2e-5
        else:  # delivery
            s = (f"the pump delivers {abs(mean):.2f} % {'more' if sign > 0 else 'less'} than modelled "
                 f"({cnt}{rng})")
            weight = abs(mean) / 0.5
        scored.append((weight * len(fs), s))
    return [s for _, s in sorted(scored, key=lambda t: -t[0])]


def window_sentences(found: list[Finding]) -> list[str]:
    """Per-run residual windows in words (for the report)."""
    out = []
    for f in found:
        if f.kind != "window":
            continue
        out.append(
            f"{f.run}: {f.valve} valve reads up to {abs(f.value) * 1e3:.3f} mm "
            f"{'above' if f.value > 0 else 'below'} the model at {_fmt_window(f.window)} ({stroke(_mid(f.window))})"
        )
    return out
