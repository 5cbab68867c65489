"""What a sensitivity and an optimisation study share: the base model, the checks of the variables against it,
the evaluation rows (designs x operating points), the reed stress calibration, the aggregation of outputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from geometry.errors import InputError
from studies.outputs import finite_or_none  # noqa: F401  (used as study.finite_or_none)
from studies.sweeps.design import runner
from studies.sweeps.design.spec import DesignSpec, _q, design_inputs

EVALUATE = "studies.sweeps.design.evaluate"
FEA_TASKS = "studies.sweeps.design.fea_tasks"
BASE_MODEL_FILE = "base_model.toml"


# --------------------------------------------------------------------------- base model and checks
def base_model(spec: DesignSpec):
    """The base PumpModel with the spec's [fixed] keys applied (None for a module model)."""
    if spec.model_kind != "pump":
        return None
    from lumped.model.model_file import load_model, with_values

    model = load_model(spec.model, field="model")
    for k, v in spec.fixed:
        try:
            model = with_values(model, {k: list(v) if isinstance(v, tuple) else v})
        except InputError as exc:
            raise InputError(f"fixed.{_q(k)}", exc.message if exc.field.endswith(k) else
                             f"{exc.field}: {exc.message}") from None
    return model


def outputs_catalogue(spec: DesignSpec) -> dict:
    from studies.sweeps.design.outputs import PUMP_OUTPUTS, module_outputs

    if spec.model_kind == "pump":
        return PUMP_OUTPUTS
    return module_outputs(__import__(spec.model, fromlist=["x"]))


def _apply(model, spec: DesignSpec, values: dict):
    from lumped.model.model_file import with_values

    inputs = design_inputs(spec, values)
    keys = {k: v for k, v in inputs.items() if k not in ("speed_rpm", "load_pressure")}
    return with_values(model, keys)


def check_variables(spec: DesignSpec, model) -> None:
    """Every variable's range ends (or distribution quantiles, or levels) on the base model, the others at their
    centre; and the centre design itself. InputError names the variable and the end."""
    from geometry.declare import check_value
    from lumped.model.pump_model import LOAD_MPA, SPEED

    centre = {v.name: v.centre() for v in spec.variables}
    if spec.model_kind == "module":
        mod = __import__(spec.model, fromlist=["x"])
        chk = getattr(mod, "check", None)
        for v in spec.variables:
            if chk is not None:
                for x in v.check_points():
                    try:
                        chk(v.name, x)
                    except InputError as exc:
                        raise InputError(f"variables.{_q(v.name)}", exc.message) from None
        return
    from lumped.model.model_file import with_values

    try:
        _apply(model, spec, centre)
    except InputError as exc:
        # each key path on its own (at its centre value): an unknown key names its variable. Only when the
        # centre design fails: alone, a key may break a constraint its [derived] partners restore.
        for v in spec.variables:
            if v.role == "key":
                try:
                    with_values(model, {v.name: centre[v.name]})
                except InputError as exc1:
                    raise InputError(f"variables.{_q(v.name)}", exc1.message if exc1.field.endswith(v.name) else
                                     f"{exc1.field}: {exc1.message}") from None
        raise InputError("variables", f"the design at the centre of the ranges is invalid: {exc}") from None
    for v in spec.variables:
        pts = v.check_points()
        names = ["low", "high"] if (v.values is None and len(pts) == 2) else [f"values[{i}]" for i in range(len(pts))]
        if v.values is None and not v.is_range:
            names = ["quantile 0.001", "quantile 0.999"]
        for end, x in zip(names, pts):
            where = f"variables.{_q(v.name)}" + (f".{end}" if end in ("low", "high") or end.startswith("values")
                                                else "")
            if v.role == "operating":
                check_value(float(x), SPEED if v.name == "speed_rpm" else LOAD_MPA, where)
                continue
            try:
                _apply(model, spec, dict(centre, **{v.name: x}))
            except InputError as exc:
                via = "" if exc.field.endswith(v.name) or exc.field == v.name else f" ({exc.field})"
                raise InputError(where, f"{x!r} with the other variables at their centre: {exc.message}{via}") from None


def write_base_model(out: Path, model) -> str:
    """The base model as a complete model file in the study folder (the workers read it); its absolute path."""
    from lumped.model.model_file import to_toml

    path = Path(out) / BASE_MODEL_FILE
    text = to_toml(model)
    if not path.is_file() or path.read_text() != text:
        tmp = path.with_suffix(".tmp")
        tmp.write_text(text)
        tmp.replace(path)
    return str(path.resolve())


def fixed_inputs(spec: DesignSpec, base_path: str | None) -> dict:
    """The inputs every evaluation row shares: the base model file and the run settings."""
    if spec.model_kind == "module":
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in spec.fixed}
    r = spec.run_dict
    out = {"model": base_path, "revolutions": r["revolutions"], "max_revolutions": r["max_revolutions"],
           "steady_tol": r["steady_tol"], "method": r["integrator"], "rtol": r["rtol"], "atol": r["atol"]}
    if "on_warning" in r:
        out["on_warning"] = r["on_warning"]
    return out


def evaluation_warnings(df) -> list[dict]:
    """The validity warnings of an evaluation table (lumped.validity), one entry per code: how many
    evaluations carry it and the first one's message ([] for a module model: no ``warnings`` column)."""
    from studies.sweeps.pump import summarize_warnings

    if "warnings" not in getattr(df, "columns", ()) or not len(df):
        return []
    return summarize_warnings(zip((f"evaluation {int(i)}" for i in df["row"]), df["warnings"]), "evaluations")


def rows_for(spec: DesignSpec, designs: list[dict], calibration: dict | None = None) -> list[dict]:
    """Evaluation rows of designs (variable values): design-major, one row per operating point; with a stress
    calibration each row carries its design's calibration factors."""
    rows = []
    for values in designs:
        inputs = design_inputs(spec, values) if spec.model_kind == "pump" else dict(values)
        if calibration:
            inputs.update({f"stress_calibration_{pos}": c
                           for pos, c in calibration_factors(calibration, spec, values).items()})
        for p in spec.points:
            rows.append({**p, **inputs})
    return rows


def needs_stress(spec: DesignSpec) -> bool:
    from studies.sweeps.design.outputs import STRESS_OUTPUTS

    names = set(spec.outputs) | {o.output for o in spec.objectives} | {c.output for c in spec.constraints}
    return spec.model_kind == "pump" and bool(names & set(STRESS_OUTPUTS))


def reed_positions(model) -> list[str]:
    return [pos for pos in ("inlet", "delivery") if getattr(model.valve(pos), "reed", None) is not None]


# --------------------------------------------------------------------------- stress calibration
def calibration_factors(cal: dict, spec: DesignSpec | None, values: dict | None) -> dict:
    """The stress calibration factor of each reed valve (the same for every design)."""
    return {pos: float(m["factor"]) for pos, m in cal["models"].items()}


def calibrate(spec: DesignSpec, model, base_path: str, cluster, out: Path, progress: bool) -> dict:
    """The stress calibration factor C of each reed valve with a geometry (:mod:`studies.sweeps.design.stress`).

    ``stress.calibration``: ``"base"`` (default): C = the solid FEA's stress / the E-B estimate of the base model's
    reed; ``"conservative"``: the largest such ratio over the base reed, the centre of the ranges and each
    variable at both ends of its range (the others at their centre); or a number (C itself). Returns
    {"models": {pos: {"factor", "ratios"}}, "rows": [...], "failed": [...], "method"}; kept in
    ``calibration.json``.
    """
    positions = reed_positions(model)
    if not positions:
        raise InputError("run", "the reed stress needs a reed valve with a geometry (valves.<pos>.geometry); "
                                "the base model has none")
    st = spec.stress_dict
    if not isinstance(st["calibration"], str):
        c = float(st["calibration"])
        return {"models": {pos: {"factor": c, "base": None, "min": c, "max": c} for pos in positions},
                "rows": [], "failed": [], "method": "given"}
    designs = [None]
    if st["calibration"] == "conservative":
        centre = {v.name: v.centre() for v in spec.variables}
        designs.append(centre)
        for v in spec.variables:
            if v.role == "operating" or v.values is not None:
                continue
            for x in v.check_points()[:2]:
                designs.append(dict(centre, **{v.name: x}))
    rows, seen, kept = [], set(), []
    for d in designs:
        keys = {} if d is None else {k: x for k, x in design_inputs(spec, d).items()
                                     if k not in ("speed_rpm", "load_pressure")}
        m = model if d is None else _apply(model, spec, d)
        reeds = tuple((m.valve(p).reed, m.valve(p).stop_gap, m.valve(p).preload) for p in positions)
        if reeds in seen:
            continue
        seen.add(reeds)
        rows.append({"task": "calibrate", **{k: (list(x) if isinstance(x, tuple) else x) for k, x in keys.items()}})
        kept.append(d)
    groups: dict = {}
    for r, d in zip(rows, kept):
        groups.setdefault(tuple(sorted(r)), []).append((r, d))
    fixed = {"model": base_path}
    if st.get("mesh_size"):
        fixed["mesh_size"] = st["mesh_size"]
    results, used = [], []
    for gi, (_, items) in enumerate(sorted(groups.items(), key=lambda t: len(t[0]))):
        df, _ = runner.evaluate_rows(cluster, Path(out) / "calibration" / f"set-{gi}", FEA_TASKS, fixed,
                                     [r for r, _ in items], progress=progress, desc="stress calibration (solid FEA)")
        for rec, (_, d) in zip(df.to_dict("records"), items):
            results.append(rec)
            used.append(d)
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
    (Path(out) / "calibration.json").write_text(json.dumps(cal, indent=1, default=str))
    return cal


def calibration_summary(cal: dict | None) -> dict | None:
    """The calibration as reported in the JSON: per valve the base model's factor, the range, the margin."""
    if not cal:
        return None
    return {"method": cal["method"], "failed": len(cal.get("failed", [])),
            **{pos: {"factor": m["factor"], "base_ratio": m["base"], "min_ratio": m["min"], "max_ratio": m["max"]}
               for pos, m in cal["models"].items()}}


# --------------------------------------------------------------------------- aggregation
def aggregate(values: np.ndarray, how: str, sense: str = "min") -> np.ndarray:
    """(designs, points) -> (designs,): mean, or worst (the largest for min/<=, the smallest for max/>=);
    NaN if any point is missing."""
    if values.shape[1] == 1:
        return values[:, 0]
    if how == "mean":
        return values.mean(axis=1)
    return values.max(axis=1) if sense == "min" else values.min(axis=1)

