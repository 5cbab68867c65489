"""The reed stress calibration of a design study: the solid FEA's bending stress over the Euler-Bernoulli estimate.

In the loop a design's reed stress is the Euler-Bernoulli estimate at its largest lift
(:mod:`studies.sweeps.design.stress`) times a calibration factor C per reed valve, so that it
matches the solid FEA (:mod:`fea.reed_stress`) without running it per design.
``stress.calibration`` chooses C:

- ``"base"`` (default): the ratio solid FEA / E-B of the base model's reed;
- ``"conservative"``: the largest ratio over the base reed, the centre of the ranges and each
  variable at both ends of its range (the others at their centre);
- a number: C itself.

The optimisation's re-check then compares the calibrated estimate with the solid FEA of each
front design (``recheck.stress_tolerance_pct``).
"""

from __future__ import annotations

import json
from pathlib import Path

from geometry.errors import InputError
from studies.sweeps.design import runner
from studies.sweeps.design.spec import DesignSpec, design_inputs
from studies.sweeps.design.study import (  # noqa: F401  (calibration_inputs: used as calibration.calibration_inputs)
    FEA_TASKS, Study, apply_design, calibration_inputs, model_keys, reed_positions)


def _designs(spec: DesignSpec, model, positions: list[str]) -> tuple[list, list]:
    """The evaluation rows of the designs whose reeds are calibrated (None: the base model), one per distinct
    reed, and those designs."""
    designs = [None]
    if spec.stress_dict["calibration"] == "conservative":
        centre = {v.name: v.centre() for v in spec.variables}
        designs.append(centre)
        for v in spec.variables:
            if v.role == "operating" or v.values is not None:
                continue
            for x in v.check_points()[:2]:
                designs.append(dict(centre, **{v.name: x}))
    rows, seen, kept = [], set(), []
    for d in designs:
        m = model if d is None else apply_design(model, spec, d)
        reeds = tuple((m.valve(p).reed, m.valve(p).stop_gap, m.valve(p).preload) for p in positions)
        if reeds in seen:
            continue
        seen.add(reeds)
        rows.append({"task": "calibrate", **({} if d is None else model_keys(design_inputs(spec, d)))})
        kept.append(d)
    return rows, kept


def _run(ctx: Study, rows: list, kept: list) -> tuple[list, list]:
    """The solid FEA and E-B stress of each row (rows with the same inputs run as one sweep); (results, designs)."""
    groups: dict = {}
    for r, d in zip(rows, kept):
        groups.setdefault(tuple(sorted(r)), []).append((r, d))
    fixed = {"model": ctx.base_path}
    if ctx.spec.stress_dict.get("mesh_size"):
        fixed["mesh_size"] = ctx.spec.stress_dict["mesh_size"]
    results, used = [], []
    for gi, (_, items) in enumerate(sorted(groups.items(), key=lambda t: len(t[0]))):
        df, _ = runner.evaluate_rows(ctx.cluster, Path(ctx.out) / "calibration" / f"set-{gi}", FEA_TASKS, fixed,
                                     [r for r, _ in items], progress=ctx.progress,
                                     desc="stress calibration (solid FEA)")
        for rec, (_, d) in zip(df.to_dict("records"), items):
            results.append(rec)
            used.append(d)
    return results, used


def calibrate(ctx: Study) -> dict:
    """The stress calibration factor C of each reed valve with a geometry (see the module docstring).

    Parameters
    ----------
    ctx : Study
        The study (its spec's ``stress.calibration``, base model, cluster and folder).

    Returns
    -------
    dict
        ``{"models": {valve: {"factor", "base", "min", "max"}}, "rows": [...], "failed": [...],
        "method"}``: per reed valve the factor C [-], the base reed's ratio and the range of the
        ratios; the FEA rows; the designs whose FEA failed. Kept in ``calibration.json``.

    Raises
    ------
    InputError
        The base model has no reed valve with a geometry.
    RuntimeError
        The solid FEA of the base model's reed failed.
    """
    positions = reed_positions(ctx.model)
    if not positions:
        raise InputError("run", "the reed stress needs a reed valve with a geometry (valves.<pos>.geometry); "
                                "the base model has none")
    st = ctx.spec.stress_dict
    if not isinstance(st["calibration"], str):
        c = float(st["calibration"])
        return {"models": {pos: {"factor": c, "base": None, "min": c, "max": c} for pos in positions},
                "rows": [], "failed": [], "method": "given"}
    results, used = _run(ctx, *_designs(ctx.spec, ctx.model, positions))
    failed = [{"design": d, "error": rec.get("error")} for rec, d in zip(results, used) if rec["status"] != "ok"]
    if any(f["design"] is None for f in failed):
        raise RuntimeError(f"stress calibration: the solid FEA of the base model's reed failed "
                           f"({next(f['error'] for f in failed if f['design'] is None)})")
    models, table = {}, []
    for pos in positions:
        prow = [{"ratio": rec[f"{pos}_ratio"], "eb_pa": rec[f"{pos}_eb_pa"],
                 "solid_away_pa": rec[f"{pos}_solid_away_pa"], "solid_max_pa": rec[f"{pos}_solid_max_pa"],
                 "design": d} for rec, d in zip(results, used) if rec["status"] == "ok"]
        ratios = [r["ratio"] for r in prow]
        base = next(r["ratio"] for r in prow if r["design"] is None)
        models[pos] = {"factor": base if st["calibration"] == "base" else max(ratios), "base": base,
                       "min": min(ratios), "max": max(ratios)}
        table += [dict(r, valve=pos) for r in prow]
    cal = {"models": models, "rows": table, "failed": failed, "method": st["calibration"]}
    (Path(ctx.out) / "calibration.json").write_text(json.dumps(cal, indent=1, default=str))
    return cal


def calibration_summary(cal: dict | None) -> dict | None:
    """The calibration as the summary JSON reports it.

    Parameters
    ----------
    cal : dict or None
        :func:`calibrate`'s result.

    Returns
    -------
    dict or None
        ``method``, the number of failed FEA runs and per valve the factor, the base model's
        ratio and the smallest and largest ratio.
    """
    if not cal:
        return None
    return {"method": cal["method"], "failed": len(cal.get("failed", [])),
            **{pos: {"factor": m["factor"], "base_ratio": m["base"], "min_ratio": m["min"], "max_ratio": m["max"]}
               for pos, m in cal["models"].items()}}
