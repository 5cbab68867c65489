"""The designs an optimisation reports: one entry per front design, the front re-sorted after the re-check, and
each design written as a complete model file.

An entry's ``objectives`` and ``constraints`` are its re-checked values (the reference
integrator's; the solid FEA's reed stress where it was run), ``objectives_fast`` and
``constraints_fast`` the loop's. ``design_NNN.toml`` is the base model with the design's keys
(and the reed fidelity it was re-checked with); ``valvelab pump --model design_NNN.toml
--method reference`` reproduces its objectives (the entry's ``commands``).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from studies.sweeps.design import study
from studies.sweeps.design.front import FAILED_F, dominates, non_dominated, violations
from studies.sweeps.design.recheck import flag_list
from studies.sweeps.design.study import OPERATING_INPUTS, Study

PUMP_COMMAND = "valvelab pump --model {file} --method reference --speed-rpm {speed:g} --load-pressure-mpa {load:g} " \
               "--revolutions {rev} --max-revolutions {maxrev} --json"


def file_keys(rec: dict) -> dict:
    """The model-file keys of a re-checked design.

    Parameters
    ----------
    rec : dict
        The design (``inputs``, ``fidelity_keys``).

    Returns
    -------
    dict
        Its inputs other than the operating point, and the reed fidelity it was re-checked with.
    """
    return {**{k: v for k, v in rec["inputs"].items() if k not in OPERATING_INPUTS}, **(rec.get("fidelity_keys") or {})}


def fea_json(f: dict | None, positions) -> dict | None:
    """A design's FEA check as the JSON reports it.

    Parameters
    ----------
    f : dict or None
        The check's row (:mod:`studies.sweeps.design.fea_tasks`; None: not checked).
    positions : list of str
        The reed valves.

    Returns
    -------
    dict or None
        ``flagged`` and per valve its flags, kappa [Pa/m], omega [rad/s], the gammas' deviations
        [%], the stress estimate and the solid FEA's stress [MPa] and the mesh's dofs.
    """
    if not f:
        return None
    if f.get("status") != "ok":
        return {"flagged": True, "error": f.get("error") or f.get("status")}
    out = {"flagged": bool(f.get("flagged"))}
    for pos in positions:
        if f.get(f"{pos}_kappa_solid") is None:
            continue
        out[pos] = {
            "flags": flag_list(f.get(f"{pos}_flags")),
            "kappa_analytic_pa_m": f[f"{pos}_kappa_analytic"], "kappa_solid_pa_m": f[f"{pos}_kappa_solid"],
            "kappa_dev_pct": f[f"{pos}_kappa_dev_pct"],
            "omega_analytic_rad_s": f[f"{pos}_omega_analytic"], "omega_solid_rad_s": f[f"{pos}_omega_solid"],
            "omega_dev_pct": f[f"{pos}_omega_dev_pct"],
            "gamma_dev_pct": [f[f"{pos}_gamma{i}_dev_pct"] for i in (1, 2, 3)],
            "stress_estimate_mpa": None if f.get(f"{pos}_stress_estimate_pa") is None
            else f[f"{pos}_stress_estimate_pa"] / 1e6,
            "stress_solid_mpa": f[f"{pos}_stress_solid_pa"] / 1e6,
            "stress_solid_at_clamp_mpa": f[f"{pos}_stress_solid_max_pa"] / 1e6,
            "stress_dev_pct": f.get(f"{pos}_stress_dev_pct"),
            "solid_dofs": int(f[f"{pos}_solid_dofs"]) if f.get(f"{pos}_solid_dofs") is not None else None,
        }
    return out


def final_constraints(fin: dict, fea: dict | None, positions) -> dict:
    """The constraints' worst values after the re-check: the solid FEA's stress [MPa] replaces the estimate.

    Parameters
    ----------
    fin : dict
        The design's record by the reference integrator.
    fea : dict or None
        Its FEA check row.
    positions : list of str
        The reed valves.

    Returns
    -------
    dict
        {output: worst value}.
    """
    cons = dict(fin["constraints"])
    if fea and "reed_stress_mpa" in cons:
        vals = [fea[f"{p}_stress_solid_pa"] / 1e6 for p in positions if fea.get(f"{p}_stress_solid_pa") is not None]
        if vals:
            cons["reed_stress_mpa"] = max(vals)
    for p in positions:
        k = f"{p}_reed_stress_mpa"
        if fea and k in cons and fea.get(f"{p}_stress_solid_pa") is not None:
            cons[k] = fea[f"{p}_stress_solid_pa"] / 1e6
    return cons


def _pct(a, b):
    """(a - b) / |b| in %, or None."""
    if a is None or b is None or b == 0:
        return None
    return (a - b) / abs(b) * 100.0


def _entry(ctx: Study, rec: dict) -> dict:
    """One design's entry (its model file not written yet; ``_keys`` holds its file keys)."""
    spec, positions = ctx.spec, ctx.positions
    fin = rec.get("final") or rec
    fea = rec.get("fea")
    ok = fin.get("ok", True)
    cons = final_constraints(fin, fea, positions) if ok else {}
    viol = violations(spec.constraints, cons) if ok else [fin.get("error") or "evaluation failed"]
    e = {"variables": rec["values"],
         "derived": {k: rec["inputs"][k] for k, _ in spec.derived} if spec.model_kind == "pump" else {},
         "objectives": fin["objectives"] if ok else {o.output: None for o in spec.objectives},
         "objectives_fast": rec["objectives"], "constraints": cons,
         "constraints_fast": rec["constraints"], "constraints_met": not viol, "violations": viol,
         "fea_check": fea_json(fea, positions), "fea_flagged": bool(fea and fea.get("flagged")),
         "fidelity": {k.split(".")[1]: v for k, v in (rec.get("fidelity_keys") or {}).items()} or None,
         "points": fin["points"], "ok": bool(ok), "rechecked": bool(rec.get("rechecked")),
         "warnings": fin.get("warnings", rec.get("warnings", [])),
         "generation_folder": rec.get("generation_folder")}
    if rec.get("final") is not None:
        e["fast_vs_reference_pct"] = {o.output: _pct(rec["objectives"][o.output], fin["objectives"][o.output])
                                      for o in spec.objectives} if fin["ok"] else None
    e["_keys"] = file_keys(rec) if spec.model_kind == "pump" else None
    return e


def _sorted_front(spec, entries: list) -> tuple[list, np.ndarray, list]:
    """The entries sorted by their objectives (the first first); which are on the front; which are feasible."""
    okm = [e["ok"] and e["constraints_met"] and all(v is not None for v in e["objectives"].values()) for e in entries]
    F = np.array([[((-1 if o.sense == "max" else 1) * e["objectives"][o.output]) if ok else FAILED_F
                   for o in spec.objectives] for e, ok in zip(entries, okm)]) if entries else np.zeros((0, 1))
    nd = non_dominated(F) if len(F) else np.zeros(0, bool)
    order = np.lexsort(F.T[::-1]) if len(F) else []
    return [entries[i] for i in order], (nd[order] if len(F) else nd), [okm[i] for i in order]


def _finish_baseline(ctx: Study, baseline: dict) -> tuple:
    """The baseline's entry completed in place; (its objectives after the re-check, with solid reed parameters)."""
    base_final = (baseline.get("final") or {}).get("objectives") or baseline.get("objectives_fast")
    baseline["objectives"] = base_final
    base_solid = None
    fs = baseline.pop("final_solid", None)
    if fs is not None and fs.get("ok"):
        base_solid = fs["objectives"]
        baseline["objectives_solid_fea"] = base_solid
    if baseline.get("final"):
        fb = baseline["final"]
        baseline["constraints"] = final_constraints(fb, baseline.get("fea"), ctx.positions)
        baseline["constraints_met"] = not violations(ctx.spec.constraints, baseline["constraints"])
        baseline["points"] = fb["points"]
        baseline["warnings"] = fb.get("warnings", baseline.get("warnings", []))
    baseline["fea_check"] = fea_json(baseline.pop("fea", None), ctx.positions)
    baseline["fidelity"] = {k.split(".")[1]: v for k, v in (baseline.pop("fidelity_keys", None) or {}).items()} \
        or None
    baseline.pop("final", None)
    baseline["model_file"] = str(Path(ctx.out) / study.BASE_MODEL_FILE)
    return base_final, base_solid


def _write_model_file(ctx: Study, e: dict, keys: dict, model) -> None:
    """The design as a complete model file (rewritten only when it changed), and the commands reproducing it."""
    from lumped.model.model_file import to_toml

    r = ctx.spec.run_dict
    path = Path(ctx.out) / f"{e['name']}.toml"
    m = replace(model, name=e["name"])
    header = (f"# {e['name']} of `valvelab optimize` ({ctx.spec.model}); objectives "
              + ", ".join(f"{o.label} = {e['objectives'][o.output]!r}" for o in ctx.spec.objectives) + "\n")
    text = header + to_toml(m)
    if not path.is_file() or path.read_text() != text:
        tmp = path.with_suffix(".tmp")
        tmp.write_text(text)
        tmp.replace(path)
    e["model_file"] = str(path)
    e["commands"] = [PUMP_COMMAND.format(file=path, speed=p.get("speed_rpm", m.operating.speed_rpm),
                                         load=p.get("load_pressure_mpa", (m.operating.load_pressure or 0) / 1e6),
                                         rev=r["revolutions"], maxrev=r["max_revolutions"]) for p in e["points"]]


def finish(ctx: Study, items: list, baseline: dict | None, built: dict | None = None) -> list[dict]:
    """The design entries of the summary: final objectives and constraints, the front re-sorted, model files.

    Parameters
    ----------
    ctx : Study
    items : list of dict
        The re-checked front (:func:`studies.sweeps.design.recheck.recheck`).
    baseline : dict or None
        The baseline (completed in place: its re-checked objectives, constraints, FEA check).
    built : dict, optional
        {repr(sorted file keys): PumpModel} built on the workers (a model with solid reed
        parameters needs its FEA); a design missing here is built from the base model.

    Returns
    -------
    list of dict
        One entry per design, sorted by the first objective: ``name`` (``design_NNN``),
        ``on_front``, ``dominates_baseline``, ``model_file`` and ``commands`` besides the values.
    """
    from lumped.model.model_file import with_values

    entries, nd, okm = _sorted_front(ctx.spec, [_entry(ctx, rec) for rec in items])
    base_final = base_solid = None
    if baseline is not None:
        base_final, base_solid = _finish_baseline(ctx, baseline)
    base = study.base_model(ctx.spec) if ctx.spec.model_kind == "pump" else None
    for i, (e, front_ok, ok) in enumerate(zip(entries, nd, okm), start=1):
        e["name"] = f"design_{i:03d}"
        e["on_front"] = bool(front_ok and ok)
        if base_final is not None and ok:
            solid = bool(e["fidelity"]) and any(v == "solid" for v in e["fidelity"].values())
            ref = base_solid if (solid and base_solid is not None) else base_final
            e["dominates_baseline"] = dominates(e["objectives"], ref, ctx.spec.objectives)
            e["baseline_compared"] = "solid FEA reed parameters" if ref is base_solid else "as the baseline"
        else:
            e["dominates_baseline"] = None if base_final is None else False
        keys = e.pop("_keys")
        if base is None:
            e["model_file"] = None
            continue
        _write_model_file(ctx, e, keys, (built or {}).get(repr(sorted(keys.items()))) or with_values(base, keys))
    return entries
