"""u_num of the reed's fluid displacement fraction f (f1 closing, f2 opening; section 3.8.7) by the GCI of the 3-D mesh study's three meshes.

Moving-wall solves (:func:`fea.fluid.reed3d.displacement_sweep`: the Stokes limit and tip speeds -0.1 / +0.1 m/s,
closing / opening) at one tip opening on the study's coarse, default and fine meshes (:data:`fea.fluid.reed3d.STUDY_MESHES`),
then :func:`fea.convergence.gci` on the cell counts (Celik et al. 2008). Slow: the fine mesh takes 5-17 min and 7.8 GB.

    python benchmarks/reed_displacement_gci.py --opening 0.95 --save benchmarks/results_reed_displacement_gci.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import sys
import time

from fea.convergence import gci
from fea.fluid import reed3d
from fea.fluid.reed_mesh import fluid_mesh


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--opening", type=float, default=0.95, help="tip opening [mm]")
    ap.add_argument("--save", default=None, help="also write the JSON to this path")
    args = ap.parse_args(argv)
    x = args.opening * 1e-3
    print(f"three meshes at {args.opening} mm: the fine one takes 5-17 min and ~8 GB", file=sys.stderr)
    base, meshes = reed3d.prototype_valve(), []
    for m in reed3d.STUDY_MESHES[::-1]:                      # fine first, as gci() takes them
        v = dataclasses.replace(base, mesh=m)
        cells = fluid_mesh(v.reed, v.seat, x, v.shape, m).mesh.nelements
        t = time.perf_counter()
        pts = reed3d.displacement_sweep(v, x, (-0.1, 0.1), progress=False)
        meshes.append({"cells": int(cells), "speeds": [p.speed for p in pts], "f": [p.fraction for p in pts],
                       "seconds": time.perf_counter() - t,
                       "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6})
        print(json.dumps(meshes[-1]), file=sys.stderr, flush=True)
    rows = []
    for k, speed in enumerate(meshes[0]["speeds"]):
        g = gci([m["f"][k] for m in meshes], cells=[m["cells"] for m in meshes], dim=3)
        rows.append({"speed": speed, "f_default": meshes[1]["f"][k], "u_num": g.u_coarse, "gci_pct": g.gci_coarse_pct,
                     "oscillatory": g.oscillatory, "note": g.note})
    out = {"opening_mm": args.opening, "meshes": meshes, "f": rows}
    text = json.dumps(out, indent=1)
    if args.save:
        with open(args.save, "w") as fh:
            fh.write(text + "\n")
    print(text)
    return out


if __name__ == "__main__":
    main()
