"""Tolerance study of the fast path: accuracy against the reference vs work, per setting.

Run on demand from the repository root: ``python benchmarks/pump_tolerance_study.py
[--random N] [--quick] [--effects]``; prints one JSON object (progress on stderr). The reference
(the scipy Radau stepper at its defaults, rtol = atol = 1e-6) is run once per case:
the 12 validation cases of Tables 5.4 and 5.6 (five revolutions) and N random designs
(three revolutions; operating point, air, seat stiffness, spring, reed kappa and f1/f2
drawn by lumped.model.random_designs, as in tests/test_pump_fast.py); with ``--effects``
also the discrepancy workflow's models (its baseline with each hidden effect of its
confusion cases at the thesis's three operating conditions, three revolutions). Then the fast path runs every case under each
setting below, and the study reports per setting and valve type: Rosenbrock step
attempts per revolution (the machine-independent measure of work), CPU ms per
simulated second (median of two runs), the worst delivery deviation and the worst
opening/closing angle deviation from the reference, and how many cases count a different
number of stop contacts. The defaults (``lumped.run.simulate.DEFAULT_TOLERANCES``, the per-state
multipliers of ``lumped.solver.steppers`` and each valve kind's contact tolerances) keep
every case within 0.03 % (delivery), 0.5 deg (angles, the bound of tests/test_pump_fast.py)
and the reference's contact counts; a looser rtol saves a few percent of the steps for a
larger deviation, and the margin is kept for designs outside these cases.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import statistics
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lumped.solver import steppers as fast  # noqa: E402
from lumped.run.simulate import simulate  # noqa: E402
from lumped.valves.kind import KINDS  # noqa: E402
from lumped.model.random_designs import random_design  # noqa: E402
from studies.tables.thesis import experiments  # noqa: E402

# (name, attributes of lumped.solver.steppers (or "kind.attribute" of a valve kind) to set, simulate keyword arguments)
SETTINGS = [
    ("default", {}, {}),
    ("rtol 3e-4", {}, {"rtol": 3e-4}),
    ("rtol 3e-3", {}, {"rtol": 3e-3}),
    ("contact velocity x30 (both)", {}, {"contact_atol": 30.0}),
    ("contact velocity x100 (both)", {}, {"contact_atol": 100.0}),
    ("rtol 1e-4", {}, {"rtol": 1e-4}),
    ("contact opening x30 (disc, before)", {"disc.contact_position_atol": 30.0}, {}),
    ("contact opening and velocity x1 (disc)", {"disc.contact_position_atol": 1.0, "disc.contact_velocity_atol": 1.0},
     {}),
    ("contact opening x1000 (disc)", {"disc.contact_position_atol": 1000.0}, {}),
    ("contact opening x100 (reed)", {"reed.contact_position_atol": 100.0}, {}),
    ("free velocity x1000 (reed)", {"reed.free_velocity_atol": 1000.0}, {}),
    ("free velocity x300 (disc)", {"disc.free_velocity_atol": 300.0}, {}),
    ("free velocity x1000 (disc)", {"disc.free_velocity_atol": 1000.0}, {}),
    ("free opening x10", {"FREE_POSITION_ATOL": 10.0}, {}),
]


def _random_case(rng, valve):
    speed, load, air, model = random_design(rng, valve)
    return dict(model=model, kind=model.label, speed_rpm=speed, load_pressure=load, air_content=air, revolutions=3)


def _effect_cases():
    """The discrepancy workflow's models: the baseline with each hidden effect of
    studies.discrepancy.confusion (values of seed 1) at the thesis's three inlet-measured runs."""
    from studies.discrepancy import confusion
    from studies.discrepancy.pump_sim import for_valve_type
    from studies.discrepancy.workflow import RunCondition
    out = []
    for valve in ("disc", "reed"):
        sim = for_valve_type(valve)
        for name, spec in confusion.CASES[valve].items():
            truth, conds = confusion.case_truth(spec, valve, 1)
            for c in conds[:3]:
                cond = RunCondition("r", valve, c.speed_rpm, c.load_pressure_pa, c.air_content)
                out.append(dict(model=sim.model_for(cond, truth), kind=f"{valve} + effects", label=f"{valve} {name}",
                                speed_rpm=c.speed_rpm,
                                load_pressure=c.load_pressure_pa, revolutions=3))
    return out


def _angles(r):
    return [r.inlet.opening_angle, r.delivery.opening_angle, r.inlet.closing_angle, r.delivery.closing_angle]


def _angle_error(a, b):
    worst = 0.0
    for x, y in zip(_angles(a), _angles(b)):
        if (x is None) != (y is None):
            return math.inf
        if x is not None:
            d = abs(x - y) % (2 * math.pi)
            worst = max(worst, math.degrees(min(d, 2 * math.pi - d)))
    return worst


def _run(c: dict, **kw):
    """lumped.run.simulate.simulate of one case (its keys but the study's own "kind" and "label")."""
    return simulate(**{k: v for k, v in c.items() if k not in ("kind", "label")}, **kw)


def _reference(c: dict):
    """The reference run of one case (a process of its own with --workers)."""
    print(f"reference: {c.get('label', c['kind'])} {c['speed_rpm']:.0f} rpm", file=sys.stderr, flush=True)
    return _run(c, method="reference")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--random", type=int, default=10, help="random designs (half disc, half reed)")
    ap.add_argument("--quick", action="store_true", help="first validation case of each valve, 2 random designs")
    ap.add_argument("--effects", action="store_true",
                    help="also the discrepancy workflow's models (every hidden effect of its confusion cases)")
    ap.add_argument("--settings", default="", help="only the settings whose names contain one of these "
                    "comma-separated strings (default: all)")
    ap.add_argument("--workers", type=int, default=1, help="processes for the reference runs")
    ap.add_argument("--worst", action="store_true", help="name the worst case of each setting and valve type")
    args = ap.parse_args()
    chosen = [s for s in SETTINGS if not args.settings or any(w in s[0] for w in args.settings.split(","))]
    cases = [dict(model=f"thesis-{c['valve']}", kind=c["valve"], speed_rpm=c["speed_rpm"],
                  load_pressure=c["load_pressure"], air_content=c["air_content"], revolutions=5) for c in experiments()]
    n_random = 2 if args.quick else args.random
    if args.quick:
        cases = [cases[0], cases[6]]
    rng = np.random.default_rng(2026)
    cases += [_random_case(rng, ("disc", "reed", "mixed")[i % 3]) for i in range(n_random)]
    if args.effects:
        cases += _effect_cases()

    if args.workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(args.workers) as ex:
            refs = list(ex.map(_reference, cases))
    else:
        refs = [_reference(c) for c in cases]
    simulate("thesis-disc", 593.0, 2.76e6, revolutions=2)  # compile or load the cache first
    out = {"benchmark": "pump_tolerance_study", "cases": len(cases), "random_designs": n_random, "settings": []}
    def get(key):
        kind, _, attr = key.rpartition(".")
        return getattr(KINDS[kind], attr) if kind else getattr(fast, attr)

    def put(key, value):
        kind, _, attr = key.rpartition(".")
        if kind:
            KINDS[kind] = dataclasses.replace(KINDS[kind], **{attr: value})
        else:
            setattr(fast, attr, value)

    for name, attrs, kw in chosen:
        saved = {k: get(k) for k in attrs}
        for k, v in attrs.items():
            put(k, v)
        per: dict = {}
        for c, r in zip(cases, refs):
            runs = [_run(c, method="fast", **kw) for _ in range(2)]
            f = runs[0]
            per.setdefault(c["kind"], []).append(dict(
                steps_per_rev=f.steps / f.revolutions,
                ms=statistics.median(x.cpu_seconds / x.simulated_seconds for x in runs) * 1e3,
                delivery=abs(f.delivery_per_rev / r.delivery_per_rev - 1), angle=_angle_error(f, r),
                counts=[v.stop_contacts for v in f.valves.values()] != [v.stop_contacts for v in r.valves.values()],
                case=c))
        for k, v in saved.items():
            put(k, v)
        row = {"setting": name}
        for valve, rows in per.items():
            row[valve] = {"steps_per_revolution": round(statistics.mean(x["steps_per_rev"] for x in rows), 1),
                          "cpu_ms_per_simulated_second": round(statistics.mean(x["ms"] for x in rows), 2),
                          "worst_delivery_deviation": float(f"{max(x['delivery'] for x in rows):.3g}"),
                          "worst_angle_deviation_deg": round(max(x["angle"] for x in rows), 4),
                          "cases_with_other_contact_counts": sum(x["counts"] for x in rows)}
            if args.worst:
                w = max(rows, key=lambda x: x["angle"])
                row[valve]["worst_angle_case"] = {k: v for k, v in w["case"].items() if isinstance(v, (str, int, float))}
        print(json.dumps(row), file=sys.stderr, flush=True)
        out["settings"].append(row)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
