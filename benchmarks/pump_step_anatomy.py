"""Where a revolution's Rosenbrock steps go, and whether another Rosenbrock method would take fewer.

Run on demand from the repository root: ``python benchmarks/pump_step_anatomy.py [--valve
disc|reed] [--speed-rpm N] [--load-pressure-mpa P] [--air-content R] [--effect NAME@TARGET ...]
[--rtol TOL]``; prints one JSON object (progress on stderr). Default: the first validation case of
each valve kind (Tables 5.4 and 5.6), the fast path's own tolerance. ``--effect``: a candidate effect
of the discrepancy workflow's library (lumped/model/effect_library.py) at its prior values on the baseline
(every effect off), repeatable, e.g. the slowest discrepancy dataset's models: ``--valve disc
--speed-rpm 593 --load-pressure-mpa 2.76 --air-content 0.013 --rtol 1e-5 --effect
seat_compliance@inlet --effect squeeze_film@delivery --effect flow_force@both``
(docs/discrepancy.md, "Cost").

The fast path runs three revolutions; the last one is cut at its mode changes (the events of
the compiled solver) into segments of one mode each, and every segment is integrated again,
from the first state the compiled run recorded in it to its end, by a plain numpy driver with
the model's own compiled right-hand side, Jacobian and tolerances and the compiled solver's
step-size controller (Gustafsson's, safety 0.9, step ratio 0.2-6), once with Rodas4P and once
with Rodas5P (Steinebach 2023, 8 stages, order 5 with an embedded order-4 estimate; controller
exponent 1/5), both the compiled solver's tableaus (:mod:`lumped.solver.rosenbrock`; the fast path takes
Rodas5P at tight tolerances and with a flow force, ``lumped.solver.steppers.rodas_order``). Events are not located inside a
segment, so the counts leave out the event steps and their retries: they compare the methods
on the smooth stretches, where the step size is the integrator's choice.

Per segment and in total it reports accepted and rejected steps and right-hand sides, and the
estimated cost from the measured per-call costs of the README (a right-hand side with its
stage solve ~0.43 us, the rest of a step ~2.3 us). For every rejected Rodas4P step it also
measures how the error estimate grows with the step there (err at h and at 0.7 h: the local
exponent, which the controller takes as 4).

Reference: S. Steinebach, "Construction of Rosenbrock-Wanner method Rodas5P and numerical
benchmarks within the Julia Differential Equations package", BIT Numer. Math. 63 (2023) 27
(transformed form W k_i = f(.) + sum C_ij/h k_j + h d_i f_t).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lumped.solver import rodas, rosenbrock  # noqa: E402
from lumped.solver import steppers  # noqa: E402
from lumped.run.simulate import ensure_compiled, simulate  # noqa: E402
from studies.tables.thesis import experiments  # noqa: E402

RHS_US, STEP_US = 0.43, 2.3   # README: per right-hand side with its stage solve; the rest of a step


def rodas4p() -> tuple:
    """(gamma, a, C, d, c, order) of Rodas4P in the transformed form of lumped.solver.rosenbrock (6 stages)."""
    r = rosenbrock
    a, cm, d, c = np.zeros((6, 6)), np.zeros((6, 6)), np.zeros(6), np.zeros(6)
    a[1, 0] = r.A21
    a[2, :2] = r.A31, r.A32
    a[3, :3] = r.A41, r.A42, r.A43
    a[4, :4] = r.A51, r.A52, r.A53, r.A54
    a[5, :4], a[5, 4] = a[4, :4], 1.0            # stage 6 at y + ... + k5, the step's y1 = that + k6
    cm[1, 0] = r.C21
    cm[2, :2] = r.C31, r.C32
    cm[3, :3] = r.C41, r.C42, r.C43
    cm[4, :4] = r.C51, r.C52, r.C53, r.C54
    cm[5, :5] = r.C61, r.C62, r.C63, r.C64, r.C65
    d[:4] = r.D1, r.D2, r.D3, r.D4
    c[:] = 0.0, r.C2, r.C3, r.C4, 1.0, 1.0
    return r.GAMMA, a, cm, d, c, 4


def rodas5p() -> tuple:
    """(gamma, a, C, d, c, order) of Rodas5P (Steinebach 2023) in the same form (8 stages), from
    lumped.solver.rosenbrock."""
    r = rosenbrock
    a, cm, d, c = np.zeros((8, 8)), np.zeros((8, 8)), np.zeros(8), np.zeros(8)
    a[1, 0] = r.P_A21
    a[2, :2] = r.P_A31, r.P_A32
    a[3, :3] = r.P_A41, r.P_A42, r.P_A43
    a[4, :4] = r.P_A51, r.P_A52, r.P_A53, r.P_A54
    a[5, :5] = r.P_A61, r.P_A62, r.P_A63, r.P_A64, r.P_A65
    a[6, :5], a[6, 5] = a[5, :5], 1.0            # stages 7 and 8 at the previous stage's input + its k
    a[7, :6], a[7, 6] = a[6, :6], 1.0
    cm[1, 0] = r.P_C21
    cm[2, :2] = r.P_C31, r.P_C32
    cm[3, :3] = r.P_C41, r.P_C42, r.P_C43
    cm[4, :4] = r.P_C51, r.P_C52, r.P_C53, r.P_C54
    cm[5, :5] = r.P_C61, r.P_C62, r.P_C63, r.P_C64, r.P_C65
    cm[6, :6] = r.P_C71, r.P_C72, r.P_C73, r.P_C74, r.P_C75, r.P_C76
    cm[7, :7] = r.P_C81, r.P_C82, r.P_C83, r.P_C84, r.P_C85, r.P_C86, r.P_C87
    d[:5] = r.P_D1, r.P_D2, r.P_D3, r.P_D4, r.P_D5
    c[:] = 0.0, r.P_C2, r.P_C3, r.P_C4, r.P_C5, 1.0, 1.0, 1.0
    return r.P_GAMMA, a, cm, d, c, 5


class Segment:
    """One mode's stretch of the revolution: the model's compiled hooks at that mode."""

    def __init__(self, solver_globals, p, atol, rtol, n_dyn):
        self.rhs, self.jac = solver_globals["rhs"], solver_globals["jacobian"]
        self.p, self.rtol, self.n_dyn = p, rtol, n_dyn
        self.atol = atol.copy()
        solver_globals["update_tolerances"](p, self.atol)

    def f(self, t, y):
        out = np.empty(y.shape[0])
        self.rhs(t, y, self.p, out)
        return out

    def step(self, tab, t, y, h):
        """One Rosenbrock step: (y1, err), err the compiled solver's RMS norm of the embedded estimate."""
        gamma, a, cm, d, c, _ = tab
        n, s = y.shape[0], d.shape[0]
        f0 = self.f(t, y)
        jac, ft = np.empty((n, n)), np.empty(n)
        nj = self.jac(t, y, self.p, f0, jac, ft, np.empty(n), np.empty(n), self.atol, self.rtol, self.n_dyn, h)
        if nj < 0:  # the pump always brings its analytic Jacobian
            raise RuntimeError("model without an analytic Jacobian")
        w = np.eye(n) / (h * gamma) - jac
        k = np.zeros((s, n))
        for i in range(s):
            fi = f0 if i == 0 else self.f(t + c[i] * h, y + a[i, :i] @ k[:i])
            k[i] = np.linalg.solve(w, fi + h * d[i] * ft + (cm[i, :i] / h) @ k[:i])
        y1 = y + a[-1, :s - 1] @ k[:s - 1] + k[-1]
        sk = self.atol + self.rtol * np.maximum(np.abs(y), np.abs(y1))
        return y1, float(np.sqrt(np.mean((k[-1] / sk) ** 2)))

    def integrate(self, tab, t0, t1, y0, h0, exponents: list | None = None) -> dict:
        """Integrate [t0, t1] with the compiled solver's controller; counts of steps and rhs calls.

        ``exponents``: if a list, for each rejected step log(err(h) / err(0.7 h)) / log(1 / 0.7) is
        appended, the power of h the error estimate grows with there.
        """
        order = tab[-1]
        stages = tab[3].shape[0]
        t, y, h = t0, y0.copy(), h0
        acc = rej = n_rhs = 0
        first, reject, h_acc, err_acc = True, False, 0.0, 1.0
        while t < t1 - 1e-15 * abs(t1):
            hit = t + h >= t1
            h_try = t1 - t if hit else h
            y1, err = self.step(tab, t, y, h_try)
            n_rhs += stages
            fac = max(1 / rodas.FAC_MAX, min(1 / rodas.FAC_MIN, err ** (1 / order) / rodas.SAFE))
            h_new = h_try / fac
            if not math.isfinite(err) or err > 1.0:
                rej += 1
                if exponents is not None and math.isfinite(err):
                    e07 = self.step(tab, t, y, 0.7 * h_try)[1]
                    if e07 > 0.0:
                        exponents.append(math.log(err / e07) / math.log(1 / 0.7))
                h = 0.1 * h_try if first or not math.isfinite(err) else h_new
                reject = True
                continue
            if not first:
                fg = (h_acc / h_try) * (err * err / err_acc) ** (1 / order) / rodas.SAFE
                h_new = h_try / max(fac, max(1 / rodas.FAC_MAX, min(1 / rodas.FAC_MIN, fg)))
            h_acc, err_acc, first = h_try, max(1e-2, err), False
            if reject:
                h_new = min(h_new, h_try)
            reject = False
            acc += 1
            t += h_try
            y = y1
            h = max(h_new, h) if hit else h_new
        return {"accepted": acc, "rejected": rej, "rhs": n_rhs,
                "cost_us": round((acc + rej) * (stages * RHS_US + STEP_US), 1)}


def last_revolution(model, speed_rpm: float, load_pressure: float, air_content: float | None,
                    rtol: float | None = None):
    """The compiled solver's call for the third revolution of a fast run: (t0, t1, q, opts, result, solver),
    the parameter array and options as the stepper passed them (before the call changed them)."""
    seen = {}
    build = steppers.compiled_solver

    def capturing(one_dof: bool = True):
        solver = build(one_dof)

        def capture(t0, y0, tstops, q, opts):
            q0, atol0 = q.copy(), opts.atol.copy()
            r = solver(t0, y0, tstops, q, opts)
            seen["call"] = (t0, float(tstops[-1]), q0, opts._replace(atol=atol0), r, solver)
            return r
        return capture

    steppers.compiled_solver = capturing     # the stepper of the run below takes its flavour's solver from here
    try:
        simulate(model, speed_rpm, load_pressure, revolutions=3, max_revolutions=3, method="fast",
                 air_content=air_content, rtol=rtol, atol=None if rtol is None else rtol / 100.0)
    finally:
        steppers.compiled_solver = build
    return seen["call"]


def with_effects(valve: str, effects: list[str]):
    """The thesis model of ``valve`` with the effects ``NAME[@TARGET][:PARAM=VALUE,...]`` (as ``valvelab synth
    --effect`` reads them: unset parameters at their priors) on the baseline (every candidate effect off), as the
    discrepancy workflow simulates them; the shipped model itself if none."""
    from lumped.model.effect_library import LIBRARY, baseline
    from lumped.model.model_file import load_model
    from studies.cli.synth import parse_effect

    m = load_model(f"thesis-{valve}")
    if not effects:
        return m
    m = baseline(m)
    return m.with_effects(tuple(parse_effect(e, LIBRARY, m) for e in effects))


def anatomy(valve: str, speed_rpm: float, load_pressure: float, air_content: float | None = None,
            effects: list[str] = (), rtol: float | None = None) -> dict:
    t0, t1, q, opts, r, solver = last_revolution(with_effects(valve, list(effects)), speed_rpm, load_pressure,
                                                 air_content, rtol)
    g = solver.py_func.__globals__
    mo, nm = steppers.MODE_AT, steppers.N_MODE
    period = t1 - t0

    def deg(t):
        return round(float((t - t0) / period * 360.0), 2)

    bounds = [t0] + [float(t) for t in r.ev_t] + [t1]
    segments, totals, exponents = [], {"rodas4p": {}, "rodas5p": {}}, []
    tableaus = (("rodas4p", rodas4p()), ("rodas5p", rodas5p()))
    for a, b in itertools.pairwise(bounds):
        j = int(np.searchsorted(r.rec_t, a, side="right"))   # the first step end inside the segment
        if j >= len(r.rec_t) - 1 or r.rec_t[j] >= b:
            continue
        tag = int(r.rec_tag[j + 1])
        p = q.copy()
        p[mo:mo + nm] = [(tag // 3**i) % 3 for i in range(nm)]
        seg = Segment(g, p, opts.atol, opts.rtol, opts.n_dyn)
        row = {"from_deg": deg(r.rec_t[j]), "to_deg": deg(b), "mode": [int(x) for x in p[mo:mo + nm]]}
        for name, tab in tableaus:
            res = seg.integrate(tab, r.rec_t[j], b, r.rec_y[j], r.rec_t[j + 1] - r.rec_t[j],
                                exponents if name == "rodas4p" else None)
            row[name] = res
            for k, v in res.items():
                totals[name][k] = round(totals[name].get(k, 0) + v, 1)
        segments.append(row)
        print(json.dumps(row), file=sys.stderr, flush=True)
    return {"valve": valve, "speed_rpm": speed_rpm, "load_pressure_mpa": load_pressure / 1e6,
            "air_content": air_content, "effects": list(effects), "rtol": float(opts.rtol),
            "compiled_solver": {"step_attempts": int(r.n_steps), "rejected": int(r.n_rejected), "rhs": int(r.n_rhs),
                                "events": len(r.ev_t)},
            "segments": segments, "totals": totals,
            "rodas5p_cost_change": round(totals["rodas5p"]["cost_us"] / totals["rodas4p"]["cost_us"] - 1.0, 3),
            "rejected_step_error_exponent": {
                "n": len(exponents),
                "median": round(float(np.median(exponents)), 2) if exponents else None,
                "range": [round(float(min(exponents)), 2), round(float(max(exponents)), 2)] if exponents else None,
                "controller_assumes": 4}}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--valve", choices=("disc", "reed"), action="append",
                    help="valve kind (repeatable; default both)")
    ap.add_argument("--speed-rpm", type=float, help="default: the kind's first validation case")
    ap.add_argument("--load-pressure-mpa", type=float, help="default: the kind's first validation case")
    ap.add_argument("--air-content", type=float, help="default: the validation case's (with --speed-rpm or "
                                                      "--load-pressure-mpa: the model's)")
    ap.add_argument("--effect", action="append", default=[], metavar="NAME@TARGET[:PARAM=VALUE,...]",
                    help="a library effect (unset parameters at their priors), on the baseline (repeatable)")
    ap.add_argument("--rtol", type=float, help="integrator tolerance (atol = rtol / 100; default the fast path's)")
    a = ap.parse_args(argv)
    ensure_compiled()
    out = {"benchmark": "pump_step_anatomy", "cases": []}
    for valve in a.valve or ["disc", "reed"]:
        case = next(c for c in experiments() if c["valve"] == valve)
        speed = a.speed_rpm if a.speed_rpm is not None else case["speed_rpm"]
        load = a.load_pressure_mpa * 1e6 if a.load_pressure_mpa is not None else case["load_pressure"]
        print(f"{valve}: {speed:.0f} rpm, {load / 1e6:.2f} MPa", file=sys.stderr, flush=True)
        air = case["air_content"] if a.speed_rpm is None and a.load_pressure_mpa is None else None
        air = a.air_content if a.air_content is not None else air
        out["cases"].append(anatomy(valve, speed, load, air, a.effect, a.rtol))
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
