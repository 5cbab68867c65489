"""Compact forms of a reed valve's flow from its 3-D Navier-Stokes and film solves, cached on disk.

:func:`characterise` runs, for one reed valve (:class:`fea.fluid.reed3d.ReedValveFlow`):

- flow sweeps (:func:`fea.fluid.reed_flux.flow_sweep`: the flow rate prescribed, continued in
  the Reynolds number through any fold in dP) at tip openings that are
  fractions of the stop gap (:data:`OPENING_FRACTIONS`), to the Reynolds numbers of
  eq 3.87 in :data:`REYNOLDS` (up to the pump's maximum) as far as the pressure differences a
  reed held open by its stiffness sees (:func:`fea.fluid.reed3d.pressure_cap`): a small
  opening never carries the pump's largest flows;
- moving-wall solves (:func:`fea.fluid.reed3d.displacement_sweep`) at
  :data:`DISPLACEMENT_FRACTIONS` of the stop and tip speeds +-:data:`TIP_SPEED`;
- the sealing film (:func:`fea.fluid.reed_film.reed_film`) at the smallest opening: X in the
  Poiseuille regime with F4 computed, and the squeeze coefficient;

and :func:`fit_forms` turns them into the forms the lumped reed model reads:

- Cd(Re) in eq 3.88's form (Wu et al. 2002; :func:`fea.fluid.compact.wu`): lift-independent,
  fitted on the valve's static operating line kappa (x - x_0) = X dP (:func:`equilibrium_points`,
  where the thesis's bench measured it: off that line Cd depends on x as well as Re, Cd ~
  sqrt(Re x) in the film regime), and over every point with an effective Reynolds number
  Re (x / x_stop)^k;
- X(x) as a table: at each opening the mean of X over the points in the pump's Reynolds range
  (:data:`PUMP_REYNOLDS`; the thesis's X depends on x only), below the smallest opening the
  film's Poiseuille plateau; the opening where the table reaches 0, if it does;
- f1, f2 (eq 3.26): the means over the openings of the closing and the opening speed.

The result with its provenance (grid, DOFs, seconds, fit residuals) is a JSON file keyed by a
hash of everything it depends on (:func:`reed_key`), in the cache directory of part one's
forms (:func:`fea.fluid.compact.cache_dir`).
"""

from __future__ import annotations

import hashlib
import json
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from .compact import cache_dir, fit_cd, store, stored
from .reed3d import ReedValveFlow, displacement_sweep, pressure_cap
from .reed_flux import flow_sweep
from .reed_film import reed_film

#: version of the reed forms (part of the cache key)
FORMS_VERSION = "reed-4"
#: tip openings of the pressure sweeps, fractions of the stop gap (0.1 to 1.7 mm for the prototype)
OPENING_FRACTIONS = (0.05, 0.15, 0.3, 0.5, 0.7, 0.9)
#: Reynolds numbers of eq 3.87 aimed at (the thesis pump peaks near 62: 1.1e-4 m^3/s at 893 rpm)
REYNOLDS = (1.0, 3.0, 10.0, 25.0, 62.0)
#: the pump's range of Re over which X is averaged
PUMP_REYNOLDS = (3.0, 62.0)
#: openings of the moving-wall solves (fractions of the stop)
DISPLACEMENT_FRACTIONS = (0.15, 0.5, 0.9)
#: tip speed of the moving-wall solves [m/s], either sign
TIP_SPEED = 0.1
#: eq 3.89's coefficients: the start of the Cd fit
CD_START = (0.5740, 6.144, 0.3661, 0.3379)


def _say(progress: bool, text: str) -> None:
    if progress:
        print(text, file=sys.stderr)


def reed_key(valve: ReedValveFlow) -> str:
    """Hash of what the forms depend on: reed, seat, shape, oil, orifice definitions, kappa (it caps
    the pressure differences, :func:`fea.fluid.reed3d.pressure_cap`), mesh, grid, version."""
    s, psi = valve.shape
    what = {"reed": repr(valve.reed), "seat": asdict(valve.seat), "fluid": asdict(valve.fluid),
            "shape": [round(float(v), 9) for v in np.interp(np.linspace(0, valve.reed.length, 41), s, psi)],
            "definitions": [valve.orifice_length, valve.orifice_perimeter, valve.area_min, valve.area_max],
            "stiffness": round(float(valve.stiffness), 3),
            "mesh": repr(valve.mesh), "inlet_total": valve.inlet_total, "grad_div": valve.grad_div,
            "openings": OPENING_FRACTIONS, "reynolds": REYNOLDS,
            "displacement": [DISPLACEMENT_FRACTIONS, TIP_SPEED], "version": FORMS_VERSION}
    return hashlib.sha256(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()[:20]


#: the sweeps of a characterisation, in the order they run
PARTS = ("pressure", "moving")


def read_log(log) -> dict:
    """The completed sweeps of a characterisation log: {(part, opening fraction): [rows]}.

    Each line names its sweep by ``part`` and ``at`` (the opening as a fraction of the stop); a
    sweep's rows are those between its start line ``{"start": part, "at": f}`` and its end line
    ``{"done": part, "at": f}``; without the end line they do not count (a sweep
    interrupted halfway is run again whole: its points continue from each other).
    """
    done, pending = {}, {}
    try:
        lines = open(log).read().splitlines()
    except OSError:
        return done
    for line in lines:
        try:
            row = json.loads(line)
        except ValueError:
            continue                                  # a line cut by the interruption
        if "start" in row:
            pending[(row["start"], float(row["at"]))] = []
        elif "done" in row:
            k = (row["done"], float(row["at"]))
            if k in pending:                          # (a repeated end line adds nothing)
                done[k] = pending.pop(k)
        elif "part" in row:
            pending.setdefault((row["part"], float(row["at"])), []).append(
                {k: v for k, v in row.items() if k not in ("part", "at")})
    return done


def characterise(valve: ReedValveFlow, progress: bool = True, log=None, parts=PARTS) -> dict:
    """The 3-D and film points of :func:`fit_forms` (module docstring), with wall and CPU seconds.

    ``log``: a path to which every point is appended as a JSON line as soon as it is solved,
    and each finished sweep's end line; sweeps the log already holds finished are read from it,
    not solved again (a run resumes where an interrupted one stopped). ``parts``: the sweeps
    to run (:data:`PARTS`; two processes may share the work, each with its own log).
    """
    t0, c0 = time.perf_counter(), time.process_time()
    stop = valve.seat.stop_gap
    done = read_log(log) if log is not None else {}

    def write(row: dict) -> None:
        if log is not None:
            with open(log, "a") as fh:
                fh.write(json.dumps(row) + "\n")

    def sweep(part: str, fraction: float, run) -> list[dict]:
        if (part, fraction) in done:
            _say(progress, f"fluid: {part} sweep at {fraction:g} x_stop read from {log}")
            return done[(part, fraction)]
        rows = []
        write({"start": part, "at": fraction})

        def keep(point) -> None:                 # each point logged as soon as it is solved
            rows.append({k: float(v) for k, v in asdict(point).items()})
            write({"part": part, "at": fraction, **rows[-1]})
        run(fraction * stop, keep)
        write({"done": part, "at": fraction})
        return rows

    rows, moving = [], []
    for f in OPENING_FRACTIONS if "pressure" in parts else ():
        rows += sweep("pressure", f, lambda x, keep: flow_sweep(
            valve, x, REYNOLDS, progress=progress, on_point=keep, dp_max=pressure_cap(valve, x)))
    for f in DISPLACEMENT_FRACTIONS if "moving" in parts else ():
        moving += sweep("moving", f, lambda x, keep: [keep(p) for p in displacement_sweep(
            valve, x, (-TIP_SPEED, TIP_SPEED), progress=progress)])
    film = reed_film(valve, OPENING_FRACTIONS[0] * stop / 5)
    return {"rows": rows, "moving": moving, "film": asdict(film), "wall_seconds": time.perf_counter() - t0,
            "cpu_seconds": time.process_time() - c0}


def multiplier_table(rows: list[dict], plateau: float) -> dict:
    """X(x): per opening the mean X over the rows in :data:`PUMP_REYNOLDS` (the Stokes limit where
    none reached it), the film's plateau first; and where the table first reaches 0 (None if not)."""
    xs = sorted({r["opening"] for r in rows})
    table = [(0.0, plateau)]
    for x in xs:
        sel = [r["multiplier"] for r in rows if r["opening"] == x and PUMP_REYNOLDS[0] <= r["reynolds"] <= PUMP_REYNOLDS[1]]
        if not sel:
            sel = [r["multiplier"] for r in rows if r["opening"] == x and r["dp"] == 1.0]
        table.append((x, float(np.mean(sel))))
    zero = None
    for (xa, Xa), (xb, Xb) in zip(table[:-1], table[1:]):
        if Xa > 0.0 >= Xb:
            zero = xa + (xb - xa) * Xa / (Xa - Xb)
            break
    return {"opening": [t[0] for t in table], "X": [t[1] for t in table], "zero_opening": zero}


def _at_dp(pts: list[dict], dp: float, key: str) -> float | None:
    """``key`` at pressure difference ``dp`` [Pa], log-log (flow) or log-linear (others) between the
    bracketing points of one opening (the first is the Stokes limit at 1 Pa: flow ~ dP below the
    first Navier-Stokes point); None beyond the last point."""
    dps = np.array([p["dp"] for p in pts])
    if dp > dps[-1] * (1 + 1e-9):
        return None
    k = int(np.clip(np.searchsorted(dps, dp) - 1, 0, len(pts) - 2)) if len(pts) > 1 else 0
    if len(pts) == 1:
        return pts[0][key] * (dp if key == "flow" else 1.0)
    a, b = pts[k], pts[k + 1]
    t = np.log(dp / a["dp"]) / np.log(b["dp"] / a["dp"])
    if key == "flow":
        return float(np.exp(np.log(a["flow"]) + t * (np.log(b["flow"]) - np.log(a["flow"]))))
    return float(a[key] + t * (b[key] - a[key]))


def equilibrium_points(rows: list[dict], valve: ReedValveFlow, preload: float = 0.0) -> list[dict]:
    """The points on the valve's static operating line: at each opening x the dP at which the reed is
    held there by its stiffness, kappa (x - x_0) = X dP (eq 3.82, as on the thesis's bench), with X
    and the flow interpolated between the computed points (``_at_dp``, two fixed-point passes);
    openings whose line lies beyond the computed dP are left out. Cd and Re as eqs 3.84, 3.87."""
    out = []
    rho, mu = valve.fluid.rho, valve.fluid.mu
    for x in sorted({r["opening"] for r in rows}):
        pts = sorted((r for r in rows if r["opening"] == x), key=lambda r: r["dp"])
        X = pts[0]["multiplier"]
        dp = None
        for _ in range(3):
            dp = valve.stiffness * (x - preload) / X
            X = _at_dp(pts, dp, "multiplier")
            if X is None or X <= 0.0:
                break
        if X is None or X <= 0.0:
            continue
        Q = _at_dp(pts, dp, "flow")
        out.append({"opening": x, "dp": dp, "flow": Q, "multiplier": X,
                    "cd": Q / (valve.orifice_length * x * np.sqrt(2 * dp / rho)),
                    "reynolds": 4 * rho * Q / (valve.orifice_perimeter * mu)})
    return out


def fit_forms(raw: dict, valve: ReedValveFlow, preload: float = 0.0) -> dict:
    """The compact forms (module docstring) from :func:`characterise`'s points; ``preload`` x_0 [m]
    of the static operating line the lift-independent Cd(Re) is fitted on (:func:`equilibrium_points`)."""
    stop = valve.seat.stop_gap
    rows = [r for r in raw["rows"] if r["dp"] != 1.0]       # the Stokes-limit rows have Re ~ 0
    re = [r["reynolds"] for r in rows]
    xr = [r["opening"] / stop for r in rows]
    cd = [r["cd"] for r in rows]
    line = equilibrium_points(raw["rows"], valve, preload)
    closing = [m["fraction"] for m in raw["moving"] if m["speed"] < 0.0]
    opening = [m["fraction"] for m in raw["moving"] if m["speed"] > 0.0]
    film = raw["film"]
    return {
        "cd": fit_cd([p["reynolds"] for p in line], [1.0] * len(line), [p["cd"] for p in line], False, p0=CD_START)
        if len(line) >= 4 else None,
        "cd_lift": fit_cd(re, xr, cd, True, p0=CD_START), "operating_line": line, "preload": preload,
        "multiplier": multiplier_table(raw["rows"], film["multiplier"]),
        "multiplier_poiseuille": film["multiplier"], "base_fraction": film["base_fraction"],
        "f1": float(np.mean(closing)) if closing else None, "f2": float(np.mean(opening)) if opening else None,
        "f1_by_opening": closing, "f2_by_opening": opening,
        "reynolds_range": [float(min(re)), float(max(re))] if re else None,
        "opening_range": [float(min(r["opening"] for r in raw["rows"])), float(max(r["opening"] for r in raw["rows"]))],
        "pump_reynolds": list(PUMP_REYNOLDS),
    }


#: measured cost of one solve of the default mesh (144,312 DOFs, 2.5-2.7 GB) on the 2-core machine:
#: wall seconds (low: the machine to itself, where wall ~ CPU; high: shared at load 10-17) and CPU
#: seconds: a Stokes solve (mesh, assembly, one factorization) and a Navier-Stokes point (2-8 Newton
#: steps, failed attempts included); the prototype's characterisation, docs/fluid.md "Cost"
STOKES_SECONDS = {"wall": (25.0, 110.0), "cpu": 20.0}
NEWTON_SECONDS = {"wall": (40.0, 600.0), "cpu": 40.0}


#: Navier-Stokes solves of one flow-rate sweep, failed steps included (the prototype's: 1-11 points and
#: 0-6 failed steps per opening, 40 points in all)
SWEEP_POINTS = 12


def cost_estimate() -> dict:
    """What a characterisation solves and how long that takes, from the measured per-solve costs:
    {"stokes", "newton" (at most), "wall_seconds" (low, high), "cpu_seconds"}."""
    stokes = len(OPENING_FRACTIONS) + len(DISPLACEMENT_FRACTIONS)
    newton = len(OPENING_FRACTIONS) * SWEEP_POINTS + 2 * len(DISPLACEMENT_FRACTIONS)
    wall = tuple(stokes * a + newton * b for a, b in zip(STOKES_SECONDS["wall"], NEWTON_SECONDS["wall"]))
    return {"stokes": stokes, "newton": newton, "wall_seconds": wall,
            "cpu_seconds": stokes * STOKES_SECONDS["cpu"] + newton * NEWTON_SECONDS["cpu"]}


def _data(valve: ReedValveFlow, raw: dict, key: str) -> dict:
    """The stored record: forms, points and provenance."""
    return {"key": key, "reed": valve.reed.name, "forms": fit_forms(raw, valve),
            "points": {"pressure": raw["rows"], "moving": raw["moving"], "film": raw["film"]},
            "provenance": {"version": FORMS_VERSION, "mesh": repr(valve.mesh), "inlet_total": valve.inlet_total,
                           "openings": OPENING_FRACTIONS,
                           "reynolds": REYNOLDS, "tip_speed": TIP_SPEED, "wall_seconds": raw["wall_seconds"],
                           "cpu_seconds": raw["cpu_seconds"],
                           "solve_seconds": sum(r["seconds"] for r in raw["rows"] + raw["moving"]),
                           "density": valve.fluid.rho, "viscosity": valve.fluid.mu,
                           "stiffness": valve.stiffness}}


def forms_from_log(valve: ReedValveFlow, log) -> dict:
    """The record of :func:`compact_forms` from the finished sweeps of a characterisation log alone
    (:func:`read_log`; the film is solved, it takes seconds; no 3-D solve): the forms of a run that
    was stopped, over the points it has (``provenance["sweeps"]`` lists them)."""
    done = read_log(log)
    stop = valve.seat.stop_gap
    rows = [r for f in OPENING_FRACTIONS for r in done.get(("pressure", f), [])]
    moving = [r for f in DISPLACEMENT_FRACTIONS for r in done.get(("moving", f), [])]
    film = reed_film(valve, OPENING_FRACTIONS[0] * stop / 5)
    raw = {"rows": rows, "moving": moving, "film": asdict(film), "wall_seconds": None, "cpu_seconds": None}
    data = _data(valve, raw, reed_key(valve))
    data["provenance"]["sweeps"] = sorted([p, f] for p, f in done)
    return data


def compact_forms(valve: ReedValveFlow, recompute: bool = False, progress: bool = True, log=None) -> dict:
    """The reed valve's compact forms: shipped (``fea/fluid/data``), cached, or computed and cached.
    ``{"key", "forms", "points", "provenance"}``.

    ``log``: a path that receives every solved point as a JSON line and from which an interrupted
    run resumes (:func:`characterise`).
    """
    key = reed_key(valve)
    path = cache_dir() / f"reed-{key}.json"
    if not recompute:
        found = stored(key, path.name, "reed-*.json")
        if found is not None:
            return found
    cost = cost_estimate()
    lo, hi = cost["wall_seconds"]
    _say(progress, f"fluid: characterising the reed valve {valve.reed.name} in 3-D: {cost['stokes']} Stokes solves "
                   f"and up to {cost['newton']} Navier-Stokes points, about {cost['cpu_seconds'] / 60:.0f} CPU "
                   f"minutes, {lo / 60:.0f}-{hi / 60:.0f} min wall on 2 cores (idle to loaded; measured per "
                   f"solve), 2.5 GB; cached afterwards in {cache_dir()}")
    raw = characterise(valve, progress=progress, log=log)
    data = _data(valve, raw, key)
    store(data, path)
    return data


# ------------------------------------------------------------------------------ the pump's use
#: the scale of eq 3.83's linear denominator term [m^2] (the thesis's d1 = -50.23): the cubic and
#: quadratic terms are below 1e-6 of it at the valve's openings, so the form is c (x_z - x) / (x_p - x)
MULTIPLIER_SCALE = 50.0


def fit_multiplier(table: dict, plateau: float) -> dict:
    """eq 3.83's coefficients (x in m) fitted to the X(x) table by least squares, with the film's plateau.

    Eq 3.83 is, at the valve's openings, X = c (x_z - x) / (x_p - x): its cubic and quadratic
    denominator terms are below 1e-6 of the linear one (the thesis's zero x_z = 1.37 mm, pole
    x_p = 1.65 mm). The fit keeps that form with d2 = 0, d1 = -k, d0 = k x_p, n1 = -c k,
    n0 = c k x_z (k = :data:`MULTIPLIER_SCALE`; the x^3 term kept exactly), and x_p > x_z >= x_max,
    the table's largest opening: the pump model takes X = 0 from x_z on (lumped.valves.reed), so a
    zero inside the computed range would drop X to 0 where the flow says otherwise. Returns the
    coefficients, ``zero_opening`` x_z, ``pole`` (a denominator root in (0, x_z], None if none),
    ``max_abs`` (the largest residual over the table).
    """
    from scipy.optimize import least_squares

    x = np.asarray(table["opening"][1:], float)
    X = np.asarray(table["X"][1:], float)
    x_max, k = float(x.max()), MULTIPLIER_SCALE

    def coefficients(p):
        c, tz, tp = p
        xz = x_max + np.exp(tz)
        xp = xz + np.exp(tp)
        return -c * k, c * k * xz, 0.0, -k, k * xp

    def res(p):
        n1, n0, d2, d1, d0 = coefficients(p)
        return np.minimum((n1 * x + n0) / (x**3 + d2 * x**2 + d1 * x + d0), plateau) - X

    sol = least_squares(res, [float(X[0]), np.log(0.5 * x_max), np.log(0.5 * x_max)], x_scale="jac")
    c = coefficients(sol.x)
    zero = float(-c[1] / c[0])
    roots = np.roots([1.0, c[2], c[3], c[4]])
    real = sorted(float(r.real) for r in roots if abs(r.imag) < 1e-9 * max(1.0, abs(r)) and 0.0 < r.real <= zero)
    names = ("n1", "n0", "d2", "d1", "d0")
    return {**dict(zip(names, map(float, c))), "poiseuille": float(plateau),
            "max_abs": float(np.abs(res(sol.x)).max()), "zero_opening": zero, "pole": real[0] if real else None}


#: the largest residual of eq 3.83's form fitted to the computed X(x) table that the pump accepts
MULTIPLIER_FIT_TOL = 0.02


def predicted_values(valve, oil) -> dict:
    """The reed's predicted fluid parameters {ReedValve field: value} for ``fluid = "predicted"`` (the
    entry point of lumped.valves.fluid_forms): Cd(Re) in eq 3.88's form at the effective Reynolds
    number Re (x / x_stop)^k fitted to every computed point (``discharge.lift_exponent`` k: off the
    bench's operating line Cd depends on the opening as well), X(x) in eq 3.83's form with the
    film's plateau, f1 and f2 of eq 3.26, from the compact forms of the reed the valve names
    (``geometry`` or ``flow.geometry``), the valve's l_o, p_o, A_1, A_2 and kappa and ``oil``
    (shipped for the thesis reed; else computed once, cached); and the range they were computed
    on (the pump warns beyond it)."""
    from geometry.errors import InputError
    from lumped.valves.kind import check_discharge

    from . import ns3d
    from .reed3d import valve_flow

    where = f"valves.{valve.position}"
    flow = valve_flow(valve.fluid_reed(where), fluid=ns3d.Fluid(oil.density, oil.viscosity),
                      stiffness=valve.stiffness,
                      definitions=(valve.orifice_length, valve.orifice_perimeter, valve.area_min, valve.area_max))
    forms = compact_forms(flow)["forms"]
    cd = forms["cd_lift"]
    try:
        check_discharge(cd["cd_inf"], cd["a"], cd["b"], cd["c"], f"{where}.fluid")
    except InputError as exc:
        raise InputError(exc.field, f"the predicted Cd(Re) is not a usable correlation ({exc.message})") from None
    X = fit_multiplier(forms["multiplier"], forms["multiplier_poiseuille"])
    if X["pole"] is not None or X["max_abs"] > MULTIPLIER_FIT_TOL:
        raise InputError(f"{where}.fluid", "the predicted X(x) has no form of eq 3.83 without a pole before its zero "
                         f"within {MULTIPLIER_FIT_TOL:g} of the computed table (largest residual "
                         f"{X['max_abs']:.3g}); use \"empirical\"")
    if forms["f1"] is None or forms["f2"] is None:
        raise InputError(f"{where}.fluid", "the compact forms have no moving-wall solve: no f1, f2 to predict; "
                         "use \"empirical\"")
    return {"cd_inf": cd["cd_inf"], "cd_a": cd["a"], "cd_b": cd["b"], "cd_c": cd["c"],
            "cd_lift_exponent": cd["lift_exponent"],
            "multiplier_poiseuille": X["poiseuille"], "multiplier_n1": X["n1"], "multiplier_n0": X["n0"],
            "multiplier_d2": X["d2"], "multiplier_d1": X["d1"], "multiplier_d0": X["d0"],
            "f1": float(np.clip(forms["f1"], 0.0, 1.0)), "f2": float(np.clip(forms["f2"], 0.0, 1.0)),
            "fluid_opening_max": float(forms["opening_range"][1]),
            "fluid_reynolds_max": float(forms["reynolds_range"][1])}
