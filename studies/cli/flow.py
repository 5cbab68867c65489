"""``valvelab flow``: a valve's flow by one fluid fidelity at given lifts and Reynolds numbers (CONTRACT.md).

VALVE is ``MODEL[:inlet|delivery]`` (a shipped model or a model file; inlet by default), the
fidelity one of :data:`fea.fluid.FIDELITIES` that models its kind. Every input is checked
before the first solve; a run longer than a few seconds says what it will do and about how
long on stderr first, then one line per point.
"""

from __future__ import annotations

import math
import sys
import time

from geometry.errors import InputError
from studies.cli import flags

HELP = "flow through a valve by a fluid fidelity (orifice laws, thin film, axisymmetric Navier-Stokes): Cd, force"
#: rough seconds per point of each fidelity on the 2-core machine (default mesh; benchmarks/bench_fluid.py)
SECONDS = {"orifice": 0.001, "thin_film": 0.1, "axisymmetric": 6.0, "3d": 180.0}
#: cost of the options relative to one solve (the GCI ladder: meshes 1/4, 1 and ~5 of the default;
#: the moving-disc solves: three more Newton solves and a Stokes one)
GCI_FACTOR, MOVING_FACTOR = 6.0, 2.5


def configure(p):
    p.add_argument("valve", metavar="VALVE", help="MODEL[:inlet|delivery]: a shipped model (thesis-disc) or a "
                   "model file, and the valve position (default inlet)")
    p.add_argument("--fidelity", required=True, help="orifice, thin_film, axisymmetric (disc), 3d (reed, if installed)")
    p.add_argument("--lift-mm", default=None, help="valve openings [mm], comma-separated (default: half the stop)")
    p.add_argument("--reynolds", default="20", help="Reynolds numbers of eq 2.46 (3.87 for a reed), comma-separated "
                   "(default 20)")
    p.add_argument("--squeeze", action="store_true", help='add "film": C1, C2 (eqs 2.13-2.15) and F4')
    p.add_argument("--displacement", action="store_true", help='add "displacement": f1, f2, A_Q (eq 2.42), c_visc')
    p.add_argument("--gci", action="store_true", help="three meshes per point: u_num of every output by the GCI")
    p.add_argument("--resolution", type=flags.number("-", (1.0, 64.0), positive=True), default=None,
                   help="mesh refinement (axisymmetric: cells across the film, default 4; thin_film: radial cells, "
                   "default 16)")
    p.add_argument("--plot", default=None, help="figure of Cd(Re) against eq 2.48 (and the axisymmetric flow field)")
    p.add_argument("--force", action="store_true", help="overwrite the --plot file")


def _numbers(text: str, field: str, unit: str, scale: float = 1.0) -> list[float]:
    items = [t.strip() for t in str(text).split(",") if t.strip()]
    if not items:
        raise InputError(field, f"expected one or more numbers in {unit}, comma-separated")
    out = []
    for t in items:
        try:
            v = float(t)
        except ValueError:
            raise InputError(field, f"expected numbers in {unit}, got {t!r}") from None
        if not math.isfinite(v):
            raise InputError(field, f"expected finite numbers in {unit}, got {t!r}")
        out.append(v * scale)
    return out


def _plan(args):
    """Every input checked: (valve, fidelity, lifts [m], Reynolds numbers, options, plot path)."""
    from fea import fluid
    from fea.fluid.point import check_lift, check_reynolds, load_fluid_valve

    valve = load_fluid_valve(args.valve, "VALVE")
    fid = fluid.get(args.fidelity, valve.kind, "--fidelity")
    lifts = (_numbers(args.lift_mm, "--lift-mm", "mm", 1e-3) if args.lift_mm is not None
             else [0.5 * valve.params.stop_gap])
    lifts = [check_lift(valve, x, "--lift-mm") for x in lifts]
    res = [check_reynolds(r, "--reynolds") for r in _numbers(args.reynolds, "--reynolds", "-")]
    if fid.name == "axisymmetric":
        from fea.fluid.valve_mesh import disc_domain

        disc_domain(valve.params)            # the housing and port fit the disc (InputError names the field)
    opts = {"squeeze": args.squeeze, "displacement": args.displacement, "gci": args.gci, "progress": False}
    if args.resolution is not None:
        opts["divisions" if fid.name == "thin_film" else "resolution"] = args.resolution
    if fid.name == "3d":
        from fea.fluid.reed3d import check_point_options, point_flow

        check_point_options(opts)
        point_flow(valve)                    # the reed to mesh exists and fits its seat (InputError names the field)
        opts["progress"] = True              # minutes per point: Newton's steps on stderr
    plot = None
    if args.plot is not None:
        from studies.outputs import check_new_file
        from studies.plots import check_plot_suffix

        plot = check_new_file(check_plot_suffix(args.plot), "--plot", args.force, writable=True)
        opts["keep_solution"] = fid.name == "axisymmetric"
    return valve, fid, lifts, res, opts, plot


def run(args) -> dict:
    valve, fid, lifts, res, opts, plot = _plan(args)
    n = len(lifts) * len(res)
    est = n * SECONDS.get(fid.name, 60.0) * (GCI_FACTOR if args.gci else 1.0) * \
        (MOVING_FACTOR if (args.squeeze or args.displacement) and fid.name in ("axisymmetric", "3d") else 1.0)
    if est > 3.0:
        span = f" ({est / 3:.0f}-{est * 3:.0f} s with the machine's load)" if fid.name == "3d" else ""
        print(f"valvelab flow: {n} point(s) of {valve.name} by {fid.name}"
              f"{' on three meshes each' if args.gci else ''}: about {est:.0f} s{span}", file=sys.stderr, flush=True)
    t0 = time.process_time()
    points, solution, shown = [], None, None
    for i, x in enumerate(lifts):
        for r in sorted(res):
            if est > 3.0:
                print(f"valvelab flow: point {len(points) + 1}/{n}: lift {x * 1e3:.4g} mm, Re {r:g}",
                      file=sys.stderr, flush=True)
            pt = fid.point(valve, x, r, opts)
            d = pt.as_dict()
            sol = d.pop("solution", None)
            if sol is not None and i == 0:      # the field shown: the first lift's highest Re
                solution, shown = sol, d
            d.pop("u_num_all", None)
            points.append(d)
    out = {"valve": valve.name, "fidelity": fid.name, "points": points,
           "mesh": points[0].get("mesh"), "cpu_seconds": time.process_time() - t0}
    for key in ("film", "displacement"):
        if any(key in p for p in points):
            out[key] = {**points[0][key], "lift": points[0]["lift"], "reynolds": points[0]["reynolds"]}
    if plot is not None:
        from lumped.fluid.orifice import discharge_coefficient
        from studies.plots import plot_flow

        reed = valve.kind == "reed"
        bench = (0.5740, 6.144, 0.3661, 0.3379) if reed else (0.9720, -1.0801, 0.1058, 0.9505)

        def reference(re):                   # the bench fits: eq 2.48 (disc), eq 3.89 (reed)
            return float(discharge_coefficient(math.sqrt(re), *bench))

        field = "" if solution is None else \
            f" (field at x = {shown['lift'] * 1e3:.3g} mm, Re = {shown['reynolds']:g})"
        plot_flow(plot, points, reference, f"{valve.name}: {fid.name}{field}", solution,
                  equations=("3.89", "3.87", "3.84") if reed else ("2.48", "2.46", "2.44"))
        out["plot"] = str(plot)
    return out


def render(result: dict) -> str:
    lines = [f"{result['valve']}, {result['fidelity']}:",
             f"{'lift [mm]':>10} {'Re':>8} {'dP [kPa]':>10} {'Cd':>8} {'F [N]':>9} {'F/(dP A)':>9} {'F_flow [N]':>10}"]
    for p in result["points"]:
        ff = "-" if p["flow_force"] is None else f"{p['flow_force']:.4g}"
        lines.append(f"{p['lift'] * 1e3:10.4g} {p['reynolds']:8.4g} {p['dp'] / 1e3:10.4g} {p['cd']:8.4f} "
                     f"{p['force']:9.4g} {p['force_coefficient']:9.4f} {ff:>10}")
    for key in ("film", "displacement"):
        if key in result:
            lines.append(f"{key}: " + ", ".join(f"{k} = {v:.4g}" for k, v in result[key].items()
                                               if isinstance(v, float)))
    if result.get("plot"):
        lines.append(f"figure: {result['plot']}")
    return "\n".join(lines)
