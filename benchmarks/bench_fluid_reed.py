"""Benchmark of the reed valve's fluid models (the reed rows of the fluid benchmark). Run on demand:

    python benchmarks/bench_fluid_reed.py [--point] [--forms] [--grooves]

Prints one JSON object: the load average when it started (timings on a loaded machine are
not the code's), the thin film of the prototype (seconds per point, DOFs, X, F4), the cost the
shipped compact forms of the prototype recorded when they were computed; with
``--point`` one 3-D point (the default mesh at 0.5 mm: Stokes and the flow-rate continuation to
Re 10; DOFs, seconds, peak resident memory of that process; ``benchmarks/reed3d_flux.py`` prints
each point of a continuation); with ``--forms`` the
prototype's compact forms computed afresh (wall and CPU seconds, the fitted forms); with
``--grooves`` the film's leakage at 0.024 and 0.095 mm with the grooves' depth scaled (0: none;
the rectangular duct's conductance; 0.5; 10) and its element size halved (the check of the
film's leakage against the 3-D flow, docs/fluid.md).
:func:`reed_rows` is what ``benchmarks/bench_fluid.py`` adds as its reed rows.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fea.fluid import reed3d, reed_film, reed_flux  # noqa: E402

#: the 3-D point's target (one point: under 5 min and 8 GB on the 2-core machine)
POINT_OPENING = 0.5e-3
POINT_REYNOLDS = 10.0


def film_row() -> dict:
    valve = reed3d.prototype_valve()
    reed_film.reed_film(valve, 0.05e-3)                 # warm-up (imports, gmsh)
    t = time.perf_counter()
    film = reed_film.reed_film(valve, 0.05e-3)
    return {"thin_film_seconds_per_point": round(time.perf_counter() - t, 3), "thin_film_dofs": film.dofs,
            "thin_film_X": round(film.multiplier, 5), "thin_film_F4": round(film.base_fraction, 4),
            "thin_film_squeeze_Pa_s_per_m": round(film.squeeze_coefficient, 1)}


def point_row() -> dict:
    valve = reed3d.prototype_valve()
    t = time.perf_counter()
    pts = reed_flux.flow_sweep(valve, POINT_OPENING, (POINT_REYNOLDS,), progress=True)
    last = pts[-1]
    return {"point_opening_mm": POINT_OPENING * 1e3, "point_reynolds": round(last.reynolds, 3),
            "point_cd": round(last.cd, 5), "point_X": round(last.multiplier, 5), "point_dofs": int(last.dofs),
            "point_seconds_stokes_and_ns": round(time.perf_counter() - t, 1),
            "point_peak_rss_gb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6, 2)}


def forms_row() -> dict:
    from fea.fluid.reed_compact import compact_forms

    data = compact_forms(reed3d.prototype_valve(), recompute=True, progress=True)
    prov = data["provenance"]
    return {"forms_wall_seconds": round(prov["wall_seconds"], 1), "forms_cpu_seconds": round(prov["cpu_seconds"], 1),
            "forms": data["forms"]}


def shipped_row() -> dict:
    """What the shipped forms of the thesis reed cost when they were computed (their provenance)."""
    from fea.fluid.reed_compact import compact_forms

    prov = compact_forms(reed3d.prototype_valve(), progress=False)["provenance"]
    return {"forms_shipped_cpu_seconds": prov.get("cpu_seconds"), "forms_shipped_wall_seconds": prov.get("wall_seconds"),
            "forms_shipped_solve_seconds": round(prov.get("solve_seconds") or 0.0, 1),
            "forms_shipped_run": prov.get("run")}


def groove_rows() -> dict:
    """Film leakage relative to the film as is, grooves scaled, and at half the element size."""
    import numpy as np

    from fea.fluid.reed_mesh import plan_view

    valve = reed3d.prototype_valve()
    plan = plan_view(valve.reed, valve.seat, reed_film.FILM_SIZE, 4 * reed_film.FILM_SIZE)
    depth0 = plan.depth.copy()
    w, h = 1.5875e-3, float(depth0.max())                 # the prototype's grooves: 1/16 in x 0.51 mm
    n = np.arange(1, 400, 2)
    duct = 1 - 192 * h / (np.pi**5 * w) * np.sum(np.tanh(n * np.pi * w / (2 * h)) / n**5)   # White eq 3-48
    out = {"groove_duct_conductance_factor": round(float(duct), 4)}
    for x in (0.024e-3, 0.095e-3):
        ref = reed_film.reed_film(valve, x, plan=plan).flow
        rel = {}
        for label, scale in (("none", 0.0), ("duct", duct ** (1 / 3)), ("half", 0.5), ("x10", 10.0)):
            plan.depth[:] = depth0 * scale
            rel[label] = round(reed_film.reed_film(valve, x, plan=plan).flow / ref, 5)
        plan.depth[:] = depth0
        rel["half_element_size"] = round(reed_film.reed_film(valve, x, size=reed_film.FILM_SIZE / 2).flow / ref, 5)
        out[f"film_leakage_relative_at_{x * 1e3:.3g}_mm"] = rel
    return out


def reed_rows(point: bool = False, forms: bool = False, grooves: bool = False) -> dict:
    out = {"loadavg_at_start": os.getloadavg()[0], "cores": os.cpu_count()}
    out.update(film_row())
    out.update(shipped_row())
    if point:
        out.update(point_row())
    if forms:
        out.update(forms_row())
    if grooves:
        out.update(groove_rows())
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--point", action="store_true", help="time one 3-D point")
    ap.add_argument("--forms", action="store_true", help="compute the prototype's compact forms afresh")
    ap.add_argument("--grooves", action="store_true", help="the film's leakage with the grooves scaled")
    args = ap.parse_args(argv)
    print(json.dumps(reed_rows(args.point, args.forms, args.grooves), indent=1))


if __name__ == "__main__":
    main()
