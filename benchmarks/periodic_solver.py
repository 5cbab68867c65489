"""Cyclic steady state of the pump: how fast the revolution map contracts, and plain revolutions against periodic solvers.

Run from the repository root: ``python benchmarks/periodic_solver.py [--random N] [--save]``;
prints one JSON object (``--save``: also benchmarks/results_periodic.json). On the 12 validation
cases and N random designs (lumped/model/random_designs.py, every valve kind; fast path at
rtol 1e-3 and 1e-4):

- contraction: the error of each revolution's delivery against the cycle (the mean of revolutions
  31-40), from today's start (cold) and from the cycle of a design 3 % faster at a 3 % lower load
  (warm); the ratio of the second revolution's error to the first's bounds how much the
  steady-state test's change (the previous revolution's) overstates the last revolution's error
  (lumped.run.revolutions.STEADY_TOL rests on it);
- reference spread: what validate reports (delivery, peak openings) on the reference stepper,
  revolution after revolution of one cycle (the reed cases of Table 5.6);
- solvers: revolutions until the steady-state test passes (change of delivery and TDC state
  below tol) and the delivery's error against the cycle then, for three ways to the cycle on the
  TDC state x (each valve's coordinates and rates over its stop gap, the masses over one swept
  volume's): plain revolutions x <- F(x) (lumped.run.revolutions.run: what the studies use),
  Anderson acceleration (type II, memory 2; Walker & Ni 2011) and Newton on x - F(x) = 0 with a
  forward-difference Jacobian (one revolution per state, n_dyn + 1 per iteration). The
  simplified circuit (the complete circuit's needle-valve tuning moves the problem between
  revolutions).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

RESULTS = Path(__file__).resolve().parent / "results_periodic.json"
LONG = 40


def _designs(n_random: int, seed: int = 3):
    from lumped.model.random_designs import VALVES, random_design
    from studies.validation.chain import case_name, cases, thesis_model_of

    out = [(case_name(c), thesis_model_of(c), c["speed_rpm"], c["load_pressure"], c["air_content"]) for c in cases()]
    rng = np.random.default_rng(seed)
    for i in range(n_random):
        v = VALVES[i % len(VALVES)]
        s, p, a, m = random_design(rng, v)
        out.append((f"random{i}_{v.replace('/', '-')}", m, s, p, a))
    return out


class Map:
    """The revolution map of one design: x (normalized TDC state) -> (F(x), delivery of the revolution)."""

    def __init__(self, model, speed, load, air, rtol):
        from dataclasses import replace

        from lumped.run.simulate import _physics, ensure_compiled
        from lumped.solver.problem import PumpProblem
        from lumped.solver.steppers import METHODS

        ensure_compiled()
        m = replace(model, oil=replace(model.oil, air_content=air))
        self.problem = PumpProblem.build(m, speed, load, "simplified")
        self.stepper = METHODS["fast"](self.problem, rtol, rtol / 100, record=False)
        self.physics = _physics("fast1" if self.problem.layout.one_dof else "fast")
        self.n = self.problem.n_dyn
        self.scale = self.problem.scales[: self.n]
        self.revolutions = 0
        self.rtol = rtol

    def cold(self):
        return self.problem.initial_state(self.physics.load_mass)[: self.n] / self.scale

    def __call__(self, x):
        from lumped.solver.layout import N_MODE
        from lumped.run.revolutions import mode_for

        p = self.problem
        y = np.zeros(p.layout.n_states)
        y[: self.n] = x * self.scale
        mode = mode_for(p, y, None)
        y0 = y.copy()
        span = self.stepper.advance(0.0, p.period, y, mode)
        self.revolutions += 1
        q = p.layout.quadratures
        delivery = (span.y_end[q["m_out"]] - y0[q["m_out"]]) / p.rho0
        assert N_MODE
        return span.y_end[: self.n] / self.scale, delivery


def _change(d1, d0, x1, x0) -> float:
    return max(abs(d1 - d0) / abs(d1), float(np.max(np.abs(x1 - x0))))


def plain(F, x, tol, limit=40):
    d_prev, x_prev = None, None
    for _ in range(limit):
        x_new, d = F(x)
        if d_prev is not None and _change(d, d_prev, x_new, x) < tol:
            return d, F.revolutions
        d_prev, x = d, x_new
    return d, F.revolutions


def anderson(F, x, tol, memory=2, limit=40):
    """Type-II Anderson acceleration of x <- F(x) (Walker & Ni 2011), stopped by the same test."""
    Gs, Fs = [], []
    d_prev = None
    for _ in range(limit):
        g, d = F(x)
        f = g - x
        if d_prev is not None and max(abs(d - d_prev) / abs(d), float(np.max(np.abs(f)))) < tol:
            return d, F.revolutions
        d_prev = d
        Gs.append(g)
        Fs.append(f)
        Gs, Fs = Gs[-(memory + 1):], Fs[-(memory + 1):]
        if len(Fs) > 1:
            dF = np.column_stack([Fs[i + 1] - Fs[i] for i in range(len(Fs) - 1)])
            dG = np.column_stack([Gs[i + 1] - Gs[i] for i in range(len(Gs) - 1)])
            gamma, *_ = np.linalg.lstsq(dF, f, rcond=None)
            x = g - dG @ gamma
        else:
            x = g
    return d, F.revolutions


def newton(F, x, tol, limit=40, h=1e-4):
    """Newton on R(x) = F(x) - x with a forward-difference Jacobian (one revolution per state)."""
    d_prev = None
    while F.revolutions < limit:
        g, d = F(x)
        r = g - x
        if d_prev is not None and max(abs(d - d_prev) / abs(d), float(np.max(np.abs(r)))) < tol:
            return d, F.revolutions
        d_prev = d
        J = np.empty((len(x), len(x)))
        for j in range(len(x)):
            xp = x.copy()
            xp[j] += h
            J[:, j] = (F(xp)[0] - g) / h
        try:
            x = x - np.linalg.solve(J - np.eye(len(x)), r)
        except np.linalg.LinAlgError:
            x = g
    return d, F.revolutions


def predictors(n_designs: int = 40, seed: int = 5) -> dict:
    """Warm starts on an optimiser-like population: the reed example's variables drawn (Latin hypercube)
    within +-15 % of their ranges around the prototype, at the example's three speeds (rtol 1e-4, as the
    optimiser), visited in a nearest-neighbour chain; the nearest solved design's state against the
    local linear prediction (lumped.WarmStarts.nearest / predict)."""
    import tempfile
    import tomllib

    from scipy.stats import qmc

    from lumped.run.simulate import simulate
    from lumped.run.revolutions import StopRule
    from lumped.run.warmstart import WarmStarts, chain_order
    from studies.sweeps.design import evaluate as dev
    from studies.sweeps.design import study
    from studies.sweeps.design.spec import parse_spec
    from studies.sweeps.locality import features

    example = ROOT / "docs" / "examples" / "optimize_reed.toml"
    spec = parse_spec(tomllib.loads(example.read_text()), "optimize", "", base_dir=example.parent)
    model = study.base_model(spec)
    proto = {"valves.geometry.thickness": 1.35e-3, "valves.geometry.width_root": 7.9375e-3,
             "valves.geometry.width_tip": 15.875e-3, "valves.geometry.length": 25.4e-3, "step_length": 4.7625e-3}
    u = qmc.LatinHypercube(d=len(spec.variables), seed=seed).random(n_designs)
    designs = []
    for row in u:
        vals = {}
        for v, x in zip(spec.variables, row):
            lo, hi = v.opt_bounds()
            c = min(max(v.to_opt(proto[v.name]), lo), hi)
            vals[v.name] = v.from_opt(min(max(c + (x - 0.5) * 0.3 * (hi - lo), lo), hi))
        designs.append(vals)
    out = {"designs": n_designs, "points": len(spec.points)}
    with tempfile.TemporaryDirectory() as tmp:
        base = study.write_base_model(Path(tmp), model)
        rows = [dict(r, model=base) for r in study.rows_for(spec, designs)]
        X, groups = features([{k: v for k, v in r.items() if k != "model"} for r in rows])
        order = chain_order(X, groups)
        out["rows"] = len(rows)
        for how in ("nearest", "linear"):
            pool = WarmStarts()
            revs, first = [], []
            for i in order:
                m = dev._model_for(rows[i])
                start = pool.nearest(X[i]) if how == "nearest" else pool.predict(X[i])
                r = simulate(m, rows[i]["speed_rpm"], rows[i]["load_pressure"], rtol=1e-4, atol=1e-6,
                             stop=StopRule.steady(max_revolutions=20), initial_state=start)
                pool.add(X[i], r.tdc_state)
                revs.append(r.revolutions)
                first.append(abs(r.deliveries[0] / r.deliveries[-1] - 1))
            out[how] = {"revolutions_mean": float(np.mean(revs)), "revolutions_max": int(max(revs)),
                        "first_error_median": float(np.median(first)), "first_error_p90": float(np.quantile(first, 0.9))}
    return out


def reference_spread(revolutions: int = 6) -> dict:
    """How much what the validation reports moves between revolutions of one cycle: each reed case of Table 5.6
    on the reference stepper from the fast path's cycle, ``revolutions`` revolutions one at a time; the spread
    (max - min) of its delivery [cc] and of each valve's peak opening [mm] (the largest opening at the
    stepper's step ends) over them."""
    from lumped.run.simulate import simulate
    from lumped.run.warmstart import fast_start
    from studies.validation.chain import case_name, cases, thesis_model_of

    out = []
    for c in cases(valve="reed"):
        m = thesis_model_of(c)
        kw = dict(air_content=c["air_content"])
        state = fast_start(m, c["speed_rpm"], c["load_pressure"], **kw)
        d, pin, pdel = [], [], []
        for _ in range(revolutions):
            r = simulate(m, c["speed_rpm"], c["load_pressure"], method="reference", revolutions=2, initial_state=state,
                         **kw)
            state = r.tdc_state
            d.append(r.delivery_per_rev * 1e6)
            pin.append(r.inlet.peak_opening * 1e3)
            pdel.append(r.delivery.peak_opening * 1e3)
        out.append({"case": case_name(c), "delivery_cc": [min(d), max(d)], "inlet_peak_mm": [min(pin), max(pin)],
                    "delivery_peak_mm": [min(pdel), max(pdel)]})
    worst = max(out, key=lambda r: r["delivery_peak_mm"][1] - r["delivery_peak_mm"][0])
    return {"revolutions": revolutions, "cases": out, "worst_peak_case": worst["case"],
            "worst_peak_spread_mm": worst["delivery_peak_mm"][1] - worst["delivery_peak_mm"][0],
            "worst_peak_range_mm": worst["delivery_peak_mm"],
            "delivery_spread_max_cc": max(r["delivery_cc"][1] - r["delivery_cc"][0] for r in out)}


def run(n_random: int = 12) -> dict:
    from lumped.run.simulate import simulate

    contraction = []
    solvers = {name: {"cold": [], "warm": []} for name in ("plain", "anderson", "newton")}
    for rtol in (1e-3, 1e-4):
        for name, model, speed, load, air in _designs(n_random):
            try:
                long = simulate(model, speed, load, air_content=air, rtol=rtol, atol=rtol / 100, revolutions=LONG)
                near = simulate(model, speed * 1.03, load * 0.97, air_content=air, rtol=rtol, atol=rtol / 100,
                                revolutions=5)
                warm = simulate(model, speed, load, air_content=air, rtol=rtol, atol=rtol / 100, revolutions=4,
                                initial_state=near.tdc_state)
            except Exception as exc:  # noqa: BLE001 - a design the fast path cannot run is reported, not fatal
                contraction.append({"design": name, "rtol": rtol, "error": str(exc)})
                continue
            cyc = float(np.mean(long.deliveries[-10:]))
            noise = float((max(long.deliveries[-10:]) - min(long.deliveries[-10:])) / cyc)
            row = {"design": name, "rtol": rtol, "noise": noise}
            for start, r in (("cold", long), ("warm", warm)):
                e = [abs(d / cyc - 1) for d in r.deliveries[:4]]
                row[f"{start}_errors"] = e
                row[f"{start}_ratio"] = e[1] / e[0] if e[0] > 10 * noise else None
            contraction.append(row)
            for solver, fn in (("plain", plain), ("anderson", anderson), ("newton", newton)):
                for start in ("cold", "warm"):
                    F = Map(model, speed, load, air, rtol)
                    x0 = F.cold() if start == "cold" else near.tdc_state.start(F.problem, F.physics.load_mass)[0][: F.n] / F.scale
                    try:
                        d, revs = fn(F, x0, 1e-3)
                        solvers[solver][start].append({"design": name, "rtol": rtol, "revolutions": revs,
                                                       "error": abs(d / cyc - 1)})
                    except Exception as exc:  # noqa: BLE001
                        solvers[solver][start].append({"design": name, "rtol": rtol, "failed": str(exc)})
    ratios = [r[k] for r in contraction for k in ("cold_ratio", "warm_ratio") if r.get(k) is not None]
    summary = {}
    for solver, by in solvers.items():
        summary[solver] = {}
        for start, rows in by.items():
            ok = [r for r in rows if "revolutions" in r]
            summary[solver][start] = {
                "designs": len(rows), "failed": len(rows) - len(ok),
                "revolutions_mean": round(float(np.mean([r["revolutions"] for r in ok])), 3) if ok else None,
                "revolutions_max": max((r["revolutions"] for r in ok), default=None),
                "delivery_error_max": max((r["error"] for r in ok), default=None),
                "delivery_error_median": float(np.median([r["error"] for r in ok])) if ok else None,
            }
    best = min(summary, key=lambda s: summary[s]["warm"]["revolutions_mean"] or math.inf)
    return {
        "benchmark": "periodic_solver", "machine": platform.machine(), "cores": os.cpu_count(),
        "load_average": round(os.getloadavg()[0], 2), "tol": 1e-3,
        "contraction_ratio_max": max(ratios) if ratios else None,
        "contraction_ratio_median": float(np.median(ratios)) if ratios else None,
        "contraction_ratios": len(ratios),
        "solvers": summary, "fewest_revolutions_warm": best, "predictors": predictors(),
        "reference_spread": reference_spread(),
        "contraction": contraction, "runs": solvers,
    }


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--random", type=int, default=12)
    ap.add_argument("--save", action="store_true")
    a = ap.parse_args(argv)
    res = run(a.random)
    text = json.dumps(res, indent=1)
    print(text)
    if a.save:
        RESULTS.write_text(text + "\n")


if __name__ == "__main__":
    main()
