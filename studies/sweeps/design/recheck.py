"""The multi-fidelity re-check of an optimisation's front, and the baseline it is compared with.

Each front design (at most ``recheck.max_designs``, spread evenly along the front) goes
through two stages:

1. each reed valve with a geometry by the solid FEA (:func:`studies.validation.reed_check.multi_fidelity_check`
   on the workers, :mod:`studies.sweeps.design.fea_tasks`): kappa, omega_n and gamma1..3
   against the analytic model (flagged beyond ``recheck.tolerance_pct``), the bending stress
   at maximum lift against the in-loop estimate;
2. every operating point by the reference integrator (Radau), with the solid FEA's reed
   parameters for a flagged valve (``fidelity = "solid"``).

The base model goes through the same stages (and, when a design was re-run with solid reed
parameters, once more with them: like is compared with like).
"""

from __future__ import annotations

import time
import tomllib
from pathlib import Path

import numpy as np

from studies.sweeps.design import runner, study
from studies.sweeps.design.evaluator import design_records
from studies.sweeps.design.study import Study, calibration_inputs, design_values_inputs, model_keys


def flag_list(x) -> list[str]:
    """The flags of an FEA check cell.

    Parameters
    ----------
    x : str or None
        ``"kappa,omega_n"``; empty or missing: none.

    Returns
    -------
    list of str
    """
    return [t for t in x.split(",") if t] if isinstance(x, str) else []


def fidelity_keys(ctx: Study, fea: dict | None) -> dict:
    """The reed fidelity each valve is re-run with: ``solid`` where the FEA check flagged it, else the model's.

    Parameters
    ----------
    ctx : Study
    fea : dict or None
        The design's FEA check row (None: not checked).

    Returns
    -------
    dict
        ``{"valves.<pos>.fidelity": fidelity}`` per reed valve.
    """
    ok = bool(fea and fea.get("status") == "ok")
    return {f"valves.{pos}.fidelity": "solid" if ok and flag_list(fea.get(f"{pos}_flags"))
            else ctx.model.valve(pos).fidelity for pos in ctx.positions}


def _baseline_rows(ctx: Study, extra: dict) -> list[dict]:
    """The base model's evaluation rows: one per operating point (the model's speed when a point is empty)."""
    rows = [{**p, **extra} for p in ctx.spec.points]
    return rows if rows[0] else [{"speed_rpm": ctx.model.operating.speed_rpm}]


def baseline(ctx: Study) -> dict:
    """The base model as it is (no variable applied), evaluated as in the loop (fast integrator).

    Parameters
    ----------
    ctx : Study

    Returns
    -------
    dict
        ``name``, the variables' ``values`` in the base model (:func:`base_value`),
        ``objectives_fast``, ``constraints_fast``, ``ok_fast``, ``points_fast``, ``warnings``.
    """
    spec, model = ctx.spec, ctx.model
    fixed = dict(study.fixed_inputs(spec, ctx.base_path), **calibration_inputs(ctx.calibration))
    rows = _baseline_rows(ctx, {})
    df, _ = runner.evaluate_rows(ctx.cluster, Path(ctx.out) / "baseline" / "fast", study.EVALUATE, fixed, rows,
                                 group=len(rows), progress=False, desc="baseline")
    rec = design_records(spec, ctx.catalogue, df, 1)[0]
    return {"name": model.name if model.source.startswith("lumped/") else Path(model.source).stem or model.name,
            "variables": {v.name: base_value(model, v.name) for v in spec.variables},
            "objectives_fast": rec["objectives"], "constraints_fast": rec["constraints"], "ok_fast": rec["ok"],
            "points_fast": rec["points"], "warnings": rec["warnings"]}


def base_value(model, path: str):
    """The value of a key path in a model.

    Parameters
    ----------
    model : lumped.model.pump_model.PumpModel
    path : str
        A key path, ``speed_rpm`` [rpm] or ``load_pressure_mpa`` [MPa].

    Returns
    -------
    int, float, str, bool or None
        None if it cannot be read (an auxiliary variable, an effect that is off).
    """
    from lumped.model.model_file import model_table

    if path == "speed_rpm":
        return model.operating.speed_rpm
    if path == "load_pressure_mpa":
        return None if model.operating.load_pressure is None else model.operating.load_pressure / 1e6
    parts = path.split(".")
    try:
        if parts[0] == "valves" and parts[1] not in ("inlet", "delivery"):
            parts = ["valves", "delivery", *parts[1:]]
        if parts[0] == "valves" and len(parts) > 3 and parts[2] == "geometry":
            v = model.valve(parts[1])
            if getattr(v, "reed", None) is None:
                return None
            from geometry.reed_io import reed_to_toml

            node = tomllib.loads(reed_to_toml(v.reed))["reed"]
            for p in parts[3:]:
                node = node[p]
            return node
        node = model_table(model)
        for p in parts:
            node = node[p]
        return node if isinstance(node, (int, float, str, bool)) else None
    except (KeyError, TypeError, IndexError):
        return None


def _pick(ctx: Study, front: list) -> tuple[list, list]:
    """(re-checked, not re-checked) designs of the front, sorted by the first objective; with a cap, designs
    spread evenly along it are re-checked."""
    n_check = ctx.spec.recheck_dict.get("max_designs", len(front)) if ctx.spec.model_kind == "pump" else len(front)
    front = sorted(front, key=lambda rec: rec["F"][0])
    pick = set(np.unique(np.linspace(0, len(front) - 1, min(n_check, len(front))).round().astype(int)).tolist()) \
        if front else set()
    return [rec for i, rec in enumerate(front) if i in pick], [rec for i, rec in enumerate(front) if i not in pick]


def _fea(ctx: Study, keys: list, factors: dict) -> tuple[list, dict | None]:
    """The solid FEA check of each design's reeds and of the base model's: (rows, the baseline's row)."""
    recheck = ctx.spec.recheck_dict
    fixed = {"model": ctx.base_path, "tolerance_pct": recheck["tolerance_pct"],
             "stress_tolerance_pct": recheck["stress_tolerance_pct"]}
    if recheck.get("mesh_size"):
        fixed["mesh_size"] = recheck["mesh_size"]
    df, _ = runner.evaluate_rows(ctx.cluster, Path(ctx.out) / "recheck-fea" / "front", study.FEA_TASKS, fixed,
                                 [{"task": "fea", **k, **factors} for k in keys], progress=ctx.progress,
                                 desc="re-check: solid FEA")
    dfb, _ = runner.evaluate_rows(ctx.cluster, Path(ctx.out) / "recheck-fea" / "baseline", study.FEA_TASKS, fixed,
                                  [{"task": "fea", **factors}], progress=False, desc="baseline FEA")
    return df.to_dict("records"), dfb.to_dict("records")[0]


def _reference_fixed(ctx: Study) -> dict:
    """The inputs of a reference-integrator row: the loop's, with Radau's own default tolerances."""
    ref_fixed = dict(study.fixed_inputs(ctx.spec, ctx.base_path), method="reference")
    ref_fixed.pop("rtol"), ref_fixed.pop("atol")
    return ref_fixed


def _reference(ctx: Study, items: list, inputs: list, fea: list) -> list:
    """Each re-checked design by the reference integrator at every point (solid reed parameters where its FEA
    check flagged a valve): the designs with ``fea``, ``final``, ``fidelity_keys`` and ``inputs``."""
    factors = calibration_inputs(ctx.calibration)
    rows, fidelity = [], []
    for i, f in zip(inputs, fea):
        fid = fidelity_keys(ctx, f)
        fidelity.append(fid)
        rows += [{**p, **model_keys(i), **factors, **fid} for p in ctx.spec.points]
    df, _ = runner.evaluate_rows(ctx.cluster, Path(ctx.out) / "recheck-reference" / "front", study.EVALUATE,
                                 _reference_fixed(ctx), rows, group=len(ctx.spec.points), progress=ctx.progress,
                                 desc="re-check: reference integrator")
    finals = design_records(ctx.spec, ctx.catalogue, df, len(items))
    return [dict(rec, fea=f, final=fin, fidelity_keys=fid, inputs=i, rechecked=True)
            for rec, f, fin, fid, i in zip(items, fea, finals, fidelity, inputs)]


def _baseline_reference(ctx: Study, base: dict, fea_base: dict | None, do_fea: bool) -> None:
    """The baseline by the reference integrator (with its FEA check's fidelity), into ``base``; and, when the
    designs may have been re-run with solid reed parameters, with those too (``final_solid``)."""
    factors = calibration_inputs(ctx.calibration)
    bfid = fidelity_keys(ctx, fea_base)
    brows = _baseline_rows(ctx, {**bfid, **factors})
    dfb, _ = runner.evaluate_rows(ctx.cluster, Path(ctx.out) / "baseline" / "reference", study.EVALUATE,
                                  _reference_fixed(ctx), brows, group=len(brows), progress=False,
                                  desc="baseline reference")
    brec = design_records(ctx.spec, ctx.catalogue, dfb, 1)[0]
    base.update(final=brec, fea=fea_base, fidelity_keys=bfid)
    # like for like: a design re-evaluated with the solid FEA's reed parameters is compared with the baseline
    # re-evaluated the same way
    if ctx.positions and do_fea and any(v != "solid" for v in bfid.values()):
        srows = _baseline_rows(ctx, {**{k: "solid" for k in bfid}, **factors})
        dfs, _ = runner.evaluate_rows(ctx.cluster, Path(ctx.out) / "baseline" / "reference-solid", study.EVALUATE,
                                      _reference_fixed(ctx), srows, group=len(srows), progress=False,
                                      desc="baseline reference, solid FEA reed")
        base["final_solid"] = design_records(ctx.spec, ctx.catalogue, dfs, 1)[0]
    elif ctx.positions and do_fea:
        base["final_solid"] = brec


def recheck(ctx: Study, front: list, base: dict | None, stages: dict) -> list:
    """Re-check the front (see the module docstring).

    Parameters
    ----------
    ctx : Study
    front : list of dict
        The front designs' records (:class:`~studies.sweeps.design.evaluator.Evaluator`).
    base : dict or None
        The baseline (:func:`baseline`), completed here with its reference results.
    stages : dict
        Receives the wall seconds of the stages (``recheck_fea``, ``recheck_reference``).

    Returns
    -------
    list of dict
        The re-checked designs (``fea``, ``final``: their record by the reference integrator,
        ``fidelity_keys``, ``inputs``, ``rechecked``), then those beyond ``max_designs``.
    """
    spec = ctx.spec
    t0 = time.perf_counter()
    enabled = spec.recheck_dict.get("enabled", True) and spec.model_kind == "pump"
    do_fea = enabled and bool(ctx.positions) and any(v.role == "key" for v in spec.variables)
    items, unchecked = _pick(ctx, front)
    extra = [dict(rec, fea=None, final=None, inputs=design_values_inputs(spec, rec["values"]), rechecked=False)
             for rec in unchecked]
    inputs = [design_values_inputs(spec, rec["values"]) for rec in items]
    fea, fea_base = [None] * len(items), None
    if do_fea and items:
        fea, fea_base = _fea(ctx, [model_keys(i) for i in inputs], calibration_inputs(ctx.calibration))
    stages["recheck_fea"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if not enabled:
        return [dict(rec, fea=f, inputs=i, final=None, rechecked=do_fea) for rec, f, i in zip(items, fea, inputs)] \
            + extra
    checked = _reference(ctx, items, inputs, fea)
    if base is not None:
        _baseline_reference(ctx, base, fea_base, do_fea)
    stages["recheck_reference"] = time.perf_counter() - t0
    return checked + extra
