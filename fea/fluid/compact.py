"""Compact forms of a disc valve's flow, fitted to its axisymmetric Navier-Stokes points, cached on disk.

:func:`characterise` runs the ``axisymmetric`` fidelity over a grid of lifts (fractions of the
stop, :data:`LIFT_FRACTIONS`) and Reynolds numbers (:data:`REYNOLDS`), continuing Newton along
Re on each lift's mesh, on three meshes (resolution n/2, n, 2n) for the GCI of every output;
the moving-disc solves (f1, f2) run at :data:`MOVING_REYNOLDS`, the Stokes drag (c_visc) once
per lift. :func:`fit_forms` fits the forms the lumped model uses:

- Cd(Re) in the Wu et al. (2002) form of eq 2.47, lift-independent (k = 0) and with the lift
  entering through an effective Reynolds number Re (x / x_stop)^k (the viscous limit of a
  film has Cd ~ sqrt(Re x): Q = K x^3 dP with A_o ~ x), least squares over every point; the
  per-lift fits are kept for inspection. The residuals say where the lift matters;
- the force coefficient F / (dP A_disc): C1 of the Reynolds film (eq 2.14 computed) below the
  Poiseuille-orifice transition of eq 2.18, and in the orifice regime the mean over its lifts
  and the pump's Reynolds numbers (:data:`PUMP_REYNOLDS`), ``K_o`` (eq 2.18 assumes 1);
- the effective jet angle of eq 2.36 and f1, f2 of eq 2.42: means over the same points;
- c_visc of eq 2.28: the Stokes drag at the stop (at smaller lifts the squeeze film adds to it,
  ``c_visc_by_lift``).

The result, with its provenance (grid, mesh DOFs, fit residuals, code version, seconds, the oil it
was computed with), is a JSON file keyed by a hash of the valve's geometry and housing
(:func:`valve_key`; the forms are functions of Re, so not of the oil): looked up
first among the shipped files (``fea/fluid/data``: the thesis disc's two valves), then in the
cache directory (``VALVELAB_CACHE_DIR``, else ``$XDG_CACHE_HOME/valvelab``, else
``~/.cache/valvelab``; never inside the package), computed and stored there otherwise.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from .axisymmetric import DISC_SPEED, MOVING, STEADY, ladder_u, moving, steady
from .point import FluidValve
from .valve_mesh import DEFAULT_RESOLUTION, disc_domain, valve_mesh

#: version of the forms (changes when the model or the fit changes; part of the cache key)
FORMS_VERSION = "1"
#: lifts of the characterisation as fractions of the stop gap
LIFT_FRACTIONS = (0.05, 0.1, 0.2, 0.35, 0.55, 0.8, 1.0)
#: Reynolds numbers of eq 2.46 (the thesis pump peaks near 70: Q ~ 8.6e-5 m^3/s at 743 rpm)
REYNOLDS = (1.0, 3.0, 10.0, 30.0, 60.0, 100.0, 150.0)
#: Reynolds numbers of the moving-disc solves
MOVING_REYNOLDS = (10.0, 60.0)
#: the largest pressure difference of the grid below the transition [Pa] (the pump's highest load
#: pressure is 3.78 MPa, Table 5.4)
DP_MAX = 5.0e6
#: the pump's range of Re (eq 2.46) over which the orifice-regime means are taken
PUMP_REYNOLDS = (10.0, 100.0)
#: shipped forms (the thesis disc's inlet and delivery valves)
DATA = Path(__file__).parent / "data"


def cache_dir() -> Path:
    """VALVELAB_CACHE_DIR, else $XDG_CACHE_HOME/valvelab, else ~/.cache/valvelab."""
    env = os.environ.get("VALVELAB_CACHE_DIR")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "valvelab"


def valve_key(valve: FluidValve, resolution: float = DEFAULT_RESOLUTION) -> str:
    """Hash of what the forms depend on: the flow domain (valve geometry, disc mass, housing), the
    orifice perimeter of eq 2.46, the grid and FORMS_VERSION. Not the oil: every form is a function
    of the Reynolds number (the dimensionless flow depends on Re and the geometry alone), so one
    characterisation serves every oil and temperature (a Monte Carlo over the viscosity reuses it)."""
    d = disc_domain(valve.params)
    what = {"domain": {k: round(float(v), 12) for k, v in asdict(d).items()},
            "perimeter": round(valve.perimeter, 12), "lifts": LIFT_FRACTIONS, "reynolds": REYNOLDS,
            "moving": MOVING_REYNOLDS, "dp_max": DP_MAX, "resolution": resolution, "version": FORMS_VERSION}
    return hashlib.sha256(json.dumps(what, sort_keys=True).encode()).hexdigest()[:20]


def _say(progress: bool, text: str) -> None:
    if progress:
        print(text, file=sys.stderr, flush=True)


def reynolds_for(valve: FluidValve, lift: float) -> list[float]:
    """The grid's Reynolds numbers at ``lift``: below the Poiseuille-orifice transition (eq 2.18) those
    whose film pressure drop (Q = K x^3 dP, the log law) stays under :data:`DP_MAX`; all above it."""
    from .disc_film import DiscFilm, closed_form

    v = valve.params
    if lift >= v.transition_opening:
        return list(REYNOLDS)
    k = closed_form(DiscFilm(v.inner_radius, v.outer_radius, v.bevel_angle), valve.viscosity)["conductance"]
    return [re for re in REYNOLDS if valve.flow_of(re) / (k * lift**3) <= DP_MAX]


def _lift_on_mesh(valve, d, lift: float, resolution: float) -> dict:
    """{Re: outputs} at one lift on one mesh (Newton continued along Re), moving solves at
    MOVING_REYNOLDS; a point where Newton fails ends the lift's ladder (recorded under "failed")."""
    mesh = valve_mesh(d, lift, resolution)
    rows, prev = {}, None
    for re in reynolds_for(valve, lift):
        try:
            out, sol = steady(valve, d, mesh, lift, re, initial=prev)
            if re in MOVING_REYNOLDS:
                out.update(moving(valve, d, mesh, lift, out["dp"], sol, DISC_SPEED))
        except RuntimeError as exc:
            rows[re] = {"lift": lift, "reynolds": re, "failed": str(exc)}
            break
        out.update(lift=lift, reynolds=re, dofs=sol.dofs)
        rows[re] = out
        prev = sol
    return rows


def characterise(valve: FluidValve, resolution: float = DEFAULT_RESOLUTION, ladder: bool = True,
                 progress: bool = True) -> dict:
    """The grid of axisymmetric points (module docstring) with each output's u_num (GCI, three meshes).

    A point that did not converge on every mesh is kept with its ``failed`` reason and no outputs
    (a result the numerics did not resolve is not an output).
    """
    d = disc_domain(valve.params)
    lifts = [f * valve.params.stop_gap for f in LIFT_FRACTIONS]
    levels = [resolution / 2, resolution, 2 * resolution] if ladder else [resolution]
    t0, c0 = time.perf_counter(), time.process_time()
    rows, failed, dofs = [], [], {str(r): 0 for r in levels}
    for i, lift in enumerate(lifts):
        per_mesh = []
        for r in levels:
            _say(progress, f"fluid characterisation: lift {i + 1}/{len(lifts)} ({lift * 1e3:.4g} mm), "
                           f"resolution {r:g} ({time.perf_counter() - t0:.0f} s so far)")
            per_mesh.append(_lift_on_mesh(valve, d, lift, r))
            done = [row["dofs"] for row in per_mesh[-1].values() if "dofs" in row]
            dofs[str(r)] = max([dofs[str(r)], *done])
        for re in per_mesh[0]:
            outs = [m.get(re, {"failed": "not reached"}) for m in per_mesh]
            bad = [o["failed"] for o in outs if "failed" in o]
            if bad:
                failed.append({"lift": lift, "reynolds": re, "reason": bad[0]})
                continue
            row = dict(outs[levels.index(resolution)])
            row["u_num"] = ladder_u(outs, levels, STEADY + MOVING) if ladder else {}
            rows.append(row)
    return {"rows": rows, "failed": failed, "lifts": lifts, "reynolds": list(REYNOLDS), "levels": levels,
            "dofs": dofs, "wall_seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0}


# ------------------------------------------------------------------ fits
def wu(re, x_rel, cd_inf: float, a: float, b: float, c: float, k: float = 0.0):
    """Cd of eq 2.47 at the effective Reynolds number Re x_rel^k (x_rel = x / x_stop); Cd(0) = 0."""
    s = np.sqrt(np.asarray(re, float) * np.asarray(x_rel, float) ** k)
    return a * np.expm1(-b * s) - (cd_inf + a) * np.expm1(-c * s)


def fit_cd(re, x_rel, cd, with_lift: bool, p0=None) -> dict:
    """Least-squares fit of :func:`wu` (eq 2.47) to points (Re, x / x_stop, Cd); eq 2.48 starts it
    unless ``p0`` = (cd_inf, a, b, c) is given (the reed's eq 3.89, same form: eq 3.88)."""
    re, x_rel, cd = (np.asarray(v, float) for v in (re, x_rel, cd))
    p0 = list(p0 if p0 is not None else (0.972, -1.0801, 0.1058, 0.9505)) + ([0.5] if with_lift else [])
    lo = [0.05, -20.0, 1e-4, 1e-4] + ([-3.0] if with_lift else [])
    hi = [2.0, 20.0, 50.0, 50.0] + ([3.0] if with_lift else [])

    def res(p):
        return wu(re, x_rel, *p) - cd

    sol = least_squares(res, p0, bounds=(lo, hi), x_scale="jac")
    r = res(sol.x)
    names = ["cd_inf", "a", "b", "c"] + (["lift_exponent"] if with_lift else [])
    return {**dict(zip(names, map(float, sol.x))), "rms": float(np.sqrt(np.mean(r**2))),
            "max_abs": float(np.abs(r).max()), "max_rel": float(np.abs(r / cd).max()), "points": int(r.size)}


def _mean_u(rows, key) -> tuple[float | None, float | None]:
    vals = [r[key] for r in rows if r.get(key) is not None]
    if not vals:
        return None, None
    us = [r["u_num"].get(key) for r in rows if r.get(key) is not None and r["u_num"].get(key) is not None]
    return float(np.mean(vals)), (float(np.mean(us)) if us else None)


def fit_forms(raw: dict, valve: FluidValve) -> dict:
    """The compact forms (module docstring) from :func:`characterise`'s points."""
    from .disc_film import DiscFilm, film_ladder

    v = valve.params
    rows = raw["rows"]
    stop = v.stop_gap
    re = [r["reynolds"] for r in rows]
    xr = [r["lift"] / stop for r in rows]
    cd = [r["cd"] for r in rows]
    film = film_ladder(DiscFilm(v.inner_radius, v.outer_radius, v.bevel_angle), valve.viscosity)
    transition = v.transition_opening
    orifice = [r for r in rows if r["lift"] >= transition and PUMP_REYNOLDS[0] <= r["reynolds"] <= PUMP_REYNOLDS[1]]
    k_o, u_k = _mean_u(orifice, "force_coefficient")
    jet, u_jet = _mean_u(orifice, "jet_angle")
    moved = [r for r in rows if "f1" in r and r["lift"] >= transition]
    f1, u_f1 = _mean_u(moved, "f1")
    f2, u_f2 = _mean_u(moved, "f2")
    per_lift = {}
    for x in raw["lifts"]:
        sel = [r for r in rows if r["lift"] == x]
        per_lift[f"{x:.6e}"] = fit_cd([r["reynolds"] for r in sel], [1.0] * len(sel), [r["cd"] for r in sel], False)
    drag = {f"{r['lift']:.6e}": r["c_visc"] for r in rows if "c_visc" in r and r["reynolds"] == MOVING_REYNOLDS[0]}
    at_stop = [r for r in rows if "c_visc" in r and r["lift"] == max(raw["lifts"])][0]
    return {
        "cd": fit_cd(re, xr, cd, False), "cd_lift": fit_cd(re, xr, cd, True), "cd_per_lift": per_lift,
        "C1": film["levels"][2].c1, "u_C1": film["gci"]["c1"].u_fine / 1.15,
        "C2": film["levels"][2].c2, "u_C2": film["gci"]["c2"].u_fine / 1.15,
        "force_coefficient_orifice": k_o, "u_force_coefficient_orifice": u_k,
        "jet_angle": jet, "u_jet_angle": u_jet, "f1": f1, "u_f1": u_f1, "f2": f2, "u_f2": u_f2,
        "c_visc": at_stop["c_visc"], "u_c_visc": at_stop["u_num"].get("c_visc"), "c_visc_by_lift": drag,
        "transition_opening": transition, "pump_reynolds": list(PUMP_REYNOLDS),
    }


# ------------------------------------------------------------------ cache
def shipped(key: str, pattern: str = "*.json") -> dict | None:
    """The shipped record (``fea/fluid/data/<pattern>``) whose ``key`` is ``key``, or None."""
    for path in sorted(DATA.glob(pattern)) if DATA.is_dir() else []:
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if data.get("key") == key:
            return data
    return None


def stored(key: str, cache_name: str, pattern: str = "*.json") -> dict | None:
    """The record of ``key``: shipped (:func:`shipped`, ``pattern``), else the user's cache file ``cache_name``
    (in :func:`cache_dir`; one that does not read is ignored: it is recomputed), else None."""
    found = shipped(key, pattern)
    path = cache_dir() / cache_name
    if found is None and path.exists():
        try:
            found = json.loads(path.read_text())
        except (OSError, ValueError):
            found = None
    return found


def compact_forms(valve: FluidValve, resolution: float = DEFAULT_RESOLUTION, recompute: bool = False,
                  progress: bool = True) -> dict:
    """The valve's compact forms: shipped, cached or computed (then cached); see the module docstring.

    Returns ``{"key", "valve", "forms", "points", "provenance"}``.
    """
    key = valve_key(valve, resolution)
    if not recompute:
        found = stored(key, f"fluid-{key}.json")
        if found is not None:
            return found
    _say(progress, f"fluid: characterising {valve.name} ({len(LIFT_FRACTIONS)} lifts x {len(REYNOLDS)} Re on "
                   f"three meshes; a few minutes, cached afterwards in {cache_dir()})")
    raw = characterise(valve, resolution, ladder=True, progress=progress)
    data = {"key": key, "valve": valve.name, "forms": fit_forms(raw, valve), "points": raw["rows"],
            "failed": raw["failed"],
            "provenance": {"version": FORMS_VERSION, "resolution_levels": raw["levels"], "dofs": raw["dofs"],
                           "lifts": raw["lifts"], "reynolds": raw["reynolds"],
                           "moving_reynolds": list(MOVING_REYNOLDS), "disc_speed": DISC_SPEED,
                           "wall_seconds": raw["wall_seconds"], "cpu_seconds": raw["cpu_seconds"],
                           "density": valve.density, "viscosity": valve.viscosity}}
    store(data, cache_dir() / f"fluid-{key}.json")
    return data


def refit(data: dict, valve: FluidValve) -> dict:
    """``data`` with its forms fitted again from its stored points (no flow solve)."""
    lifts = sorted({r["lift"] for r in data["points"]} | {f["lift"] for f in data.get("failed", [])})
    raw = {"rows": data["points"], "lifts": lifts}
    return {**data, "forms": fit_forms(raw, valve)}


def store(data: dict, path: Path) -> None:
    """Write ``data`` as JSON whole or not at all (another process may read the cache meanwhile)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps(data, indent=1, default=_jsonable))
        os.replace(tmp, path)
    except OSError as exc:
        print(f"warning: the fluid forms could not be cached in {path.parent} ({exc})", file=sys.stderr)


def _jsonable(obj):
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    raise TypeError(type(obj).__name__)




# ------------------------------------------------------------------ what the pump model reads
def predicted_values(valve, oil) -> dict:
    """The disc's predicted fluid parameters {DiscValve field: value} for ``fluid = "predicted"``
    (the entry point of lumped.valves.fluid_forms): Cd(Re) of eq 2.47 with its lift exponent, the
    orifice regime's force coefficient, the jet angle of eq 2.36, f1 and f2 of eq 2.42 and c_visc of
    eq 2.28 from the compact forms of this valve's geometry and ``oil`` (computed once, cached)."""
    from geometry.errors import InputError
    from lumped.valves.kind import check_discharge

    fv = FluidValve(name=f"disc:{valve.position}", kind="disc", position=valve.position, params=valve,
                    density=oil.density, viscosity=oil.viscosity, vapour_pressure=oil.vapour_pressure)
    forms = compact_forms(fv)["forms"]
    cd = forms["cd_lift"]
    try:
        check_discharge(cd["cd_inf"], cd["a"], cd["b"], cd["c"], f"valves.{valve.position}.fluid")
    except InputError as exc:
        raise InputError(exc.field, f"the predicted Cd(Re) is not a usable correlation ({exc.message})") from None
    return {"cd_inf": cd["cd_inf"], "cd_a": cd["a"], "cd_b": cd["b"], "cd_c": cd["c"],
            "cd_lift_exponent": cd["lift_exponent"], "force_coefficient": forms["force_coefficient_orifice"],
            "jet_angle": forms["jet_angle"], "f1": min(1.0, forms["f1"]), "f2": min(1.0, forms["f2"]),
            "viscous_drag": forms["c_visc"]}
