"""Does the fast path's default answer hold, or say it does not? Random designs against the reference path.

Run on demand from the repository root::

    python benchmarks/fast_accuracy_study.py --designs 300 [--workers 2] [--cache out/fast_accuracy_ref.json]

Prints one JSON object (progress on stderr). The designs: ``lumped.model.random_designs.random_design`` over
every valve design (each kind and each ordered pair of kinds), design ``i`` with its valves
``valve_designs()[i % 9]``, and every candidate effect of ``lumped.model.effect_library`` switched on in turn
(design ``i`` with effect ``i % (n_effects + 1)``, none for the last; an effect that does not apply to the
design's valves leaves it bare). Each design runs three revolutions on the reference path (scipy Radau at
rtol = atol = 1e-6, cached in ``--cache``) and on the fast path at its defaults (``method="fast"``: its
accuracy check included). A design is a *miss* when an opening or closing angle differs from the reference by
more than 0.5 deg or the delivery by more than 0.05 %; a miss is *silent* unless the fast result carries a
``numerical_accuracy`` warning. The cost: the fast path's CPU time and Rosenbrock steps against the same runs
with the check off (``accuracy_check=False``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ANGLE_TOL_DEG = 0.5
DELIVERY_TOL = 5e-4
REVOLUTIONS = 3


def design(i: int):
    """(label, speed [rpm], load [Pa], air [-], model) of design ``i``."""
    from geometry.errors import InputError
    from lumped.model.effect_library import LIBRARY
    from lumped.model.model_file import with_values
    from lumped.model.random_designs import random_design, valve_designs

    valves = valve_designs()
    effects = list(LIBRARY.names()) + [None]
    valve, effect = valves[i % len(valves)], effects[i % len(effects)]
    speed, load, air, model = random_design(np.random.default_rng(1000 + i), valve)
    label = valve
    if effect is not None:
        try:
            model = with_values(model, {f"effects.{effect}": True})
            label += f" + {effect}"
        except InputError:
            pass
    return label, speed, load, air, model


def _angles(res) -> list:
    return [None if a is None else math.degrees(a) for a in
            (res.inlet.opening_angle, res.delivery.opening_angle, res.inlet.closing_angle, res.delivery.closing_angle)]


def _summary(res) -> dict:
    return {"delivery": res.delivery_per_rev, "angles": _angles(res), "steps": int(res.steps),
            "cpu_s": float(res.cpu_seconds), "warnings": [w.code for w in res.warnings],
            "messages": [w.message for w in res.warnings if w.code == "numerical_accuracy"]}


def reference(i: int) -> dict:
    from geometry.errors import ModelFailure
    from lumped.run.simulate import simulate

    label, speed, load, air, model = design(i)
    try:
        r = simulate(model, speed, load, air_content=air, revolutions=REVOLUTIONS, method="reference")
    except ModelFailure as exc:       # the reference itself gave up: the design is left out, and counted
        return {"i": i, "label": label, "failed": str(exc)}
    return {"i": i, "label": label, **_summary(r)}


def fast(i: int) -> dict:
    from geometry.errors import ModelFailure
    from lumped.run.simulate import simulate

    label, speed, load, air, model = design(i)
    out = {"i": i, "label": label}
    for name, kw in (("checked", {}), ("unchecked", {"accuracy_check": False})):
        try:
            t0 = time.process_time()
            r = simulate(model, speed, load, air_content=air, revolutions=REVOLUTIONS, method="fast", **kw)
            out[name] = {**_summary(r), "cpu_s": time.process_time() - t0}
        except ModelFailure as exc:
            out[name] = {"failed": str(exc)}
    return out


def _deviation(f: dict, r: dict) -> tuple[float, float]:
    """(largest angle deviation [deg], delivery deviation [-]); an event in one and not the other: inf."""
    worst = 0.0
    for a, b in zip(f["angles"], r["angles"]):
        if (a is None) != (b is None):
            worst = math.inf
        elif a is not None:
            d = abs(a - b) % 360.0
            worst = max(worst, min(d, 360.0 - d))
    return worst, abs(f["delivery"] - r["delivery"]) / abs(r["delivery"])


def _map(fn, items, workers: int, what: str) -> list:
    out = []
    with ProcessPoolExecutor(workers) as pool:
        for k, res in enumerate(pool.map(fn, items, chunksize=1)):
            out.append(res)
            if (k + 1) % 10 == 0:
                sys.stderr.write(f"{what}: {k + 1}/{len(items)}\n")
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=300)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--cache", default="out/fast_accuracy_ref.json", help="reference results (reused when present)")
    ap.add_argument("--reference-only", action="store_true", help="only fill the cache of reference results")
    ap.add_argument("--save", action="store_true", help="also write benchmarks/results_fast_accuracy.json")
    args = ap.parse_args(argv)
    cache = Path(args.cache)
    refs = {r["i"]: r for r in json.loads(cache.read_text())} if cache.is_file() else {}
    todo = [i for i in range(args.designs) if i not in refs]
    for r in _map(reference, todo, args.workers, "reference"):
        refs[r["i"]] = r
        cache.parent.mkdir(parents=True, exist_ok=True)
        cache.write_text(json.dumps(sorted(refs.values(), key=lambda r: r["i"])))
    if args.reference_only:
        return {"reference_cached": len(refs)}
    load_before = os.getloadavg()[0]
    fasts = _map(fast, list(range(args.designs)), args.workers, "fast")
    rows, misses, silent, flagged, cost = [], [], [], 0, {"checked": [0.0, 0], "unchecked": [0.0, 0]}
    for f in fasts:
        r = refs[f["i"]]
        if "failed" in r or "failed" in f["checked"] or "failed" in f["unchecked"]:
            rows.append({"i": f["i"], "label": f["label"], "left_out": r.get("failed") or "fast failed"})
            continue
        for k in cost:
            cost[k][0] += f[k]["cpu_s"]
            cost[k][1] += f[k]["steps"]
        c = f["checked"]
        warned = "numerical_accuracy" in c["warnings"]
        flagged += warned
        angle, dl = _deviation(c, r)
        u_angle, u_dl = _deviation(f["unchecked"], r)
        row = {"i": f["i"], "label": f["label"], "angle_dev_deg": angle, "delivery_dev": dl,
               "unchecked_angle_dev_deg": u_angle, "unchecked_delivery_dev": u_dl, "warned": warned}
        rows.append(row)
        if angle > ANGLE_TOL_DEG or dl > DELIVERY_TOL:
            misses.append(row)
            if not warned:
                silent.append(row)
    compared = [r for r in rows if "left_out" not in r]
    result = {
        "designs": args.designs, "compared": len(compared), "left_out": [r for r in rows if "left_out" in r],
        "revolutions": REVOLUTIONS, "limits": {"angle_deg": ANGLE_TOL_DEG, "delivery_rel": DELIVERY_TOL},
        "misses_without_check": sum(1 for r in compared if r["unchecked_angle_dev_deg"] > ANGLE_TOL_DEG
                                    or r["unchecked_delivery_dev"] > DELIVERY_TOL),
        "misses": len(misses), "silent_misses": len(silent), "warned": flagged, "silent": silent,
        "worst_angle_dev_deg": max((r["angle_dev_deg"] for r in compared), default=None),
        "worst_delivery_dev": max((r["delivery_dev"] for r in compared), default=None),
        "worst_unchecked_angle_dev_deg": max((r["unchecked_angle_dev_deg"] for r in compared), default=None),
        "worst_unchecked_delivery_dev": max((r["unchecked_delivery_dev"] for r in compared), default=None),
        "cpu_s": {k: v[0] for k, v in cost.items()}, "steps": {k: v[1] for k, v in cost.items()},
        "cost_ratio_cpu": cost["checked"][0] / cost["unchecked"][0] if cost["unchecked"][0] else None,
        "cost_ratio_steps": cost["checked"][1] / cost["unchecked"][1] if cost["unchecked"][1] else None,
        "valve_designs": sorted({r["label"].split(" + ")[0] for r in compared}),
        "effects": {e: sum(1 for r in compared if r["label"].endswith(f" + {e}")) for e in
                    sorted({r["label"].split(" + ")[1] for r in compared if " + " in r["label"]})},
        "bare": sum(1 for r in compared if " + " not in r["label"]),
        "workers": args.workers, "load_average_before_after": [load_before, os.getloadavg()[0]],
        "unchecked_misses": [r for r in compared if r["unchecked_angle_dev_deg"] > ANGLE_TOL_DEG
                             or r["unchecked_delivery_dev"] > DELIVERY_TOL],
    }
    if args.save:
        (Path(__file__).parent / "results_fast_accuracy.json").write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
