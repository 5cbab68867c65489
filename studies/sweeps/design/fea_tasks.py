"""The FEA work of a design study as a sweep model (run on dask, resumable): stress calibration and the check
of a design's reeds against the solid FEA.

Inputs: ``model`` (the base model file) and the design's model-file key paths, plus

- ``task = "calibrate"``: per reed valve with a geometry, the Euler-Bernoulli stress estimate and the
  solid FEA's stress at maximum lift, and their ratio (:func:`studies.sweeps.design.stress.calibration_row`);
- ``task = "fea"``: per reed valve, the multi-fidelity check analytic vs solid of kappa, omega_n and
  gamma1..3 (:func:`studies.validation.reed_check.multi_fidelity_check`, flags above ``tolerance_pct``) and the
  solid FEA's stress at maximum lift against the in-loop estimate (``stress_calibration_<pos>``),
  flagged when the estimate is more than ``stress_tolerance_pct`` below it;

``mesh_size`` (optional): the solid's element size (default: its converged default).
"""

from __future__ import annotations

from lumped.model.pump_model import POSITIONS

TASK_INPUTS = ("task", "mesh_size", "tolerance_pct", "stress_tolerance_pct", "stress_calibration_inlet",
               "stress_calibration_delivery")
_CAL = ("eb_pa", "solid_away_pa", "solid_max_pa", "ratio")
_FEA = ("kappa_analytic", "kappa_solid", "kappa_dev_pct", "omega_analytic", "omega_solid", "omega_dev_pct",
        "gamma1_dev_pct", "gamma2_dev_pct", "gamma3_dev_pct", "stress_estimate_pa", "stress_solid_pa",
        "stress_solid_max_pa", "stress_dev_pct", "solid_dofs")
OUTPUTS = {**{f"{pos}_{k}": "float64" for pos in POSITIONS for k in _CAL + _FEA},
           **{f"{pos}_flags": "string" for pos in POSITIONS}, "flagged": "bool"}
REQUIRED = ("model", "task")


def check(name: str, value) -> None:
    from geometry.errors import InputError

    if name == "task" and value not in ("calibrate", "fea"):
        raise InputError(name, f"expected calibrate or fea, got {value!r}")


def ensure_gmsh() -> None:
    """Initialise gmsh once per worker process without its SIGINT handler: dask runs tasks outside the main
    thread, where gmsh.initialize() (interruptible) raises "signal only works in main thread"; fea.mesh then
    reuses the open session (it adds and removes its own model, so the meshes are the same)."""
    import threading

    if threading.current_thread() is threading.main_thread():
        return
    import gmsh

    if not gmsh.isInitialized():
        gmsh.initialize(["-noenv"], readConfigFiles=False, interruptible=False)


def _model(design: dict):
    from lumped.model.model_file import load_model, with_values

    values = {k: v for k, v in design.items() if k not in TASK_INPUTS and k != "model"}
    return with_values(load_model(design["model"], field="model"), values)


def _reed_positions(model):
    return [pos for pos in POSITIONS if getattr(model.valve(pos), "reed", None) is not None]


def evaluate(design: dict) -> dict:
    from studies.sweeps.design.stress import calibration_row, eb_kappa, eb_stress, lift_deflection, solid_stress

    ensure_gmsh()
    model = _model(design)
    mesh = design.get("mesh_size")
    mesh = None if mesh is None or (isinstance(mesh, float) and mesh != mesh) else mesh
    out = dict.fromkeys(OUTPUTS)
    done: dict = {}   # reed -> (deflection, result): the two valves often share one reed
    if design["task"] == "calibrate":
        for pos in _reed_positions(model):
            v = model.valve(pos)
            d = lift_deflection(v)
            if v.reed in done:
                d0, row0 = done[v.reed]
                row = {k: (x * d / d0 if k.endswith("_pa") else x) for k, x in row0.items()}
            else:
                row = calibration_row(v.reed, d, mesh)
                done[v.reed] = (d, row)
            for k in _CAL:
                out[f"{pos}_{k}"] = row[k]
        return out

    from studies.validation.reed_check import multi_fidelity_check

    tol = float(design.get("tolerance_pct", 4.0))
    stol = float(design.get("stress_tolerance_pct", 10.0))
    flagged = False
    for pos in _reed_positions(model):
        v = model.valve(pos)
        d = lift_deflection(v)
        if v.reed in done:
            d0, (chk, sol) = done[v.reed]
            sol = {k: (x * d / d0 if k in ("away", "max", "pressure") else x) for k, x in sol.items()}
        else:
            chk = multi_fidelity_check(v.reed, ("analytic", "solid"), tolerance_pct=tol, mesh_size=mesh,
                                       progress=False)
            sol = solid_stress(v.reed, d, mesh)
            done[v.reed] = (d, (chk, sol))
        rows = {r["fidelity"]: r for r in chk["rows"]}
        a, s = rows["analytic"], rows["solid"]
        flags = [f.split(".", 1)[1] for f in chk["flagged"]]
        out[f"{pos}_kappa_analytic"], out[f"{pos}_kappa_solid"] = a["kappa"], s["kappa"]
        out[f"{pos}_omega_analytic"], out[f"{pos}_omega_solid"] = a["omega_n"], s["omega_n"]
        for q in ("kappa", "omega", "gamma1", "gamma2", "gamma3"):
            out[f"{pos}_{q}_dev_pct"] = a["deviation_pct"]["omega_n" if q == "omega" else q]
        cal = float(design.get(f"stress_calibration_{pos}", 0.0) or 0.0)
        est = cal * eb_stress(v.reed, d, eb_kappa(v)) if cal else None
        out[f"{pos}_stress_estimate_pa"] = est
        out[f"{pos}_stress_solid_pa"], out[f"{pos}_stress_solid_max_pa"] = sol["away"], sol["max"]
        out[f"{pos}_solid_dofs"] = float(sol["dofs"])
        if est is not None:
            dev = (est - sol["away"]) / sol["away"] * 100.0
            out[f"{pos}_stress_dev_pct"] = dev
            if dev < -stol:
                flags.append("stress")
        out[f"{pos}_flags"] = ",".join(flags)
        flagged = flagged or bool(flags)
    out["flagged"] = flagged
    return out
