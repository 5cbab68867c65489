"""The reed's 3-D flow continued in the Reynolds number at a prescribed flow rate (fea.fluid.reed_flux).

    python benchmarks/reed3d_flux.py --opening MM [--mesh coarse|default|fine] [--re 1 3 10 20 40 60] [--log FILE]
        [--grad-div GAMMA_OVER_MU] [--eigs K] [--static-inlet] [--from-rest RE]

Prints one JSON line per converged point (opening, mesh, DOFs, Re, dP, Cd, eq 3.89's Cd at that Re,
X, mesh Peclet, Newton steps, seconds, peak memory, load average) on stdout (and appends it to --log):
whether dP(Re) has a maximum (a fold of the dP-driven problem) and how Cd follows eq 3.89.
``--grad-div``: the grad-div term's gamma / mu; ``--eigs K``: the K eigenvalues nearest zero of the
bordered Jacobian at every point aimed at (``reed_flux.spectrum``: a fold or bifurcation where one reaches zero);
``--static-inlet``: the inlet's P the traction's (plain do-nothing) instead of a total pressure
(``ReedValveFlow.inlet_total``); ``--from-rest RE``: instead of the continuation, the flow-rate
pseudo-transient run from rest at RE (``reed_flux.flux_ptc``: the steady flow the time-dependent one settles to).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import asdict, replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fea.fluid import reed3d, reed_flux  # noqa: E402

MESHES = dict(zip(("coarse", "default", "fine"), reed3d.STUDY_MESHES))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--opening", type=float, required=True, help="tip opening [mm]")
    ap.add_argument("--mesh", choices=tuple(MESHES), default="default")
    ap.add_argument("--re", type=float, nargs="+", default=[1, 3, 10, 20, 40, 60])
    ap.add_argument("--log")
    ap.add_argument("--grad-div", type=float, default=0.0)
    ap.add_argument("--eigs", type=int, default=0)
    ap.add_argument("--static-inlet", action="store_true")
    ap.add_argument("--from-rest", type=float)
    args = ap.parse_args(argv)
    valve = replace(reed3d.prototype_valve(), mesh=MESHES[args.mesh], grad_div=args.grad_div,
                    inlet_total=not args.static_inlet)
    cd_law = _cd_law()
    tags = {"opening_mm": args.opening, "mesh": args.mesh, "grad_div": args.grad_div, "inlet_total": valve.inlet_total}

    def emit(p):
        row = {k: round(float(v), 7) for k, v in asdict(p).items()}
        row.update(tags, cd_eq389=round(cd_law(p.reynolds), 6), loadavg=os.getloadavg()[0])
        _write(row, args.log)

    def emit_state(prob, x, P, p):
        if args.eigs and min(abs(p.reynolds / r - 1) for r in args.re) < 1e-6:      # at the aims only
            vals = reed_flux.spectrum(prob, x, args.eigs)
            _write(dict(tags, reynolds=p.reynolds, eigenvalues=[[round(float(v.real), 6), round(float(v.imag), 6)]
                                                                 for v in vals]), args.log)
    if args.from_rest:
        _from_rest(valve, args.opening * 1e-3, args.from_rest, lambda p, prob, x: (emit(p), emit_state(prob, x, 0, p)))
        return
    reed_flux.flow_sweep(valve, args.opening * 1e-3, args.re, on_point=emit, on_state=emit_state)


def _from_rest(valve, opening: float, reynolds: float, out) -> None:
    """The flow-rate PTC from rest (zero velocity, P = 0) at ``reynolds``: ``out(point, problem, state)``."""
    import time

    import numpy as np

    t0 = time.perf_counter()
    prob = reed_flux.flux_problem(valve, opening)
    x, P, steps, factor = reed_flux.flux_ptc(prob, reed_flux._flux_of(valve, reynolds), np.zeros(prob.system.ndofs),
                                             0.0, progress=True)
    factor.free()
    out(reed3d.point_outputs(prob.system, x, valve, opening, P, steps, time.perf_counter() - t0), prob, x)


def _write(row: dict, log: str | None) -> None:
    line = json.dumps(row)
    print(line, flush=True)
    if log:
        with open(log, "a") as fh:
            fh.write(line + "\n")


def _cd_law():
    """Cd(Re) of eq 3.89 with the thesis-reed model's constants (the flow bench's fit)."""
    import math

    from lumped.fluid.orifice import discharge_coefficient
    from lumped.model.model_file import load_model

    v = load_model("thesis-reed").inlet
    return lambda re: float(discharge_coefficient(math.sqrt(re), v.cd_inf, v.cd_a, v.cd_b, v.cd_c))


if __name__ == "__main__":
    main()
