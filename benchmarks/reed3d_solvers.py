"""Which linear solver for the reed's 3-D Taylor-Hood systems: measured on one Stokes solve.

    python benchmarks/reed3d_solvers.py [--opening MM] [--mesh coarse|medium|fine]

Prints one JSON object for the prototype at the given opening (default 0.5 mm): the Stokes
saddle-point system solved by

- ``pardiso``: the direct LU of PARDISO (pypardiso, real unsymmetric; what fea.fluid.ns3d uses);
- ``minres_amg``: MINRES with the block-diagonal preconditioner diag(AMG(mu K) x 3, M_p / mu)
  (smoothed-aggregation AMG of pyamg on each velocity component, the pressure mass matrix's
  diagonal for the Schur complement; Elman, Silvester and Wathen 2014, ch. 4), to a relative
  residual of 1e-8;

with wall seconds, iterations and peak resident memory of the process so far, the flow rate
and X of each (they must agree), and the load average (timings on a loaded machine are not
the code's).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fea.fluid import ns3d, reed3d  # noqa: E402
from fea.fluid.reed_mesh import fluid_mesh  # noqa: E402


def _rss() -> float:
    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6, 2)


def _outputs(system, x, valve, opening) -> dict:
    p = reed3d.point_outputs(system, x, valve, opening, 1.0, 0, 0.0)
    return {"flow": p.flow, "X": round(p.multiplier, 6)}


def minres_amg(system, rhs, free) -> tuple[np.ndarray, int]:
    import pyamg

    mu, n = system.fluid.mu, system.nv
    M = ns3d._saddle(system, ns3d._velocity_block(system, None, False))[free][:, free].tocsr()
    vfree = free[free < 3 * n]
    pfree = free[free >= 3 * n] - 3 * n
    comps = [vfree[(vfree >= a * n) & (vfree < (a + 1) * n)] - a * n for a in range(3)]
    amgs = [pyamg.smoothed_aggregation_solver((mu * system.K)[c][:, c].tocsr()) for c in comps]
    mp = ns3d._mass.assemble(system.Q).diagonal()[pfree] / mu
    sizes = [len(c) for c in comps]

    def apply(r):
        out = np.empty_like(r)
        k = 0
        for ml, m in zip(amgs, sizes):
            out[k:k + m] = ml.solve(r[k:k + m], tol=1e-12, maxiter=1, cycle="V")
            k += m
        out[k:] = r[k:] / mp
        return out
    count = [0]

    def cb(_):
        count[0] += 1
    x, info = spla.minres(M, rhs, M=spla.LinearOperator(M.shape, matvec=apply), rtol=1e-8, maxiter=3000,
                          callback=cb)
    return x, count[0] if info == 0 else -count[0]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--opening", type=float, default=0.5, help="tip opening [mm]")
    ap.add_argument("--mesh", choices=("coarse", "medium", "fine"), default="medium")
    args = ap.parse_args(argv)
    opts = reed3d.STUDY_MESHES[("coarse", "medium", "fine").index(args.mesh)]
    valve = reed3d.prototype_valve(opts)
    x_open = args.opening * 1e-3
    out = {"loadavg_at_start": os.getloadavg()[0], "mesh": args.mesh}
    fm = fluid_mesh(valve.reed, valve.seat, x_open, valve.shape, opts)
    system = ns3d.assemble(fm.mesh, valve.fluid)
    rhs = ns3d.traction_load(system, {"inlet": 1.0})
    free = ns3d._free_dofs(system.ndofs, system.fixed)
    out["dofs"] = int(system.ndofs)
    t = time.perf_counter()
    x = ns3d.stokes(system, rhs, np.zeros(len(system.fixed)))
    out["pardiso"] = {"seconds": round(time.perf_counter() - t, 2), "peak_rss_gb": _rss(),
                      **_outputs(system, x, valve, x_open)}
    t = time.perf_counter()
    y = np.zeros(system.ndofs)
    y[free], its = minres_amg(system, rhs[free], free)
    out["minres_amg"] = {"seconds": round(time.perf_counter() - t, 2), "iterations": its, "peak_rss_gb": _rss(),
                         **_outputs(system, y, valve, x_open)}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
