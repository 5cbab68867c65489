"""``valvelab pump``: one run of a pump model to cyclic steady state (CONTRACT.md)."""

from __future__ import annotations

import csv

from geometry.errors import InputError
from studies.cli import flags

HELP = "simulate a pump (a shipped model or your model file) with its check valves to cyclic steady state"

#: plausible ranges of the engineering-unit flags; speed, load and air content are declared once in the model
#: layer (lumped.model.pump_model, lumped.fluid.oil) and read when a flag is given (importing lumped takes
#: seconds, too long for --help)
TOL_BOUNDS = (1e-14, 0.1)
MAX_REVOLUTIONS = 100_000
#: the valve kinds shipped with valvelab, for the help (the flag accepts every registered kind: lumped.valves.kind)
SHIPPED_KINDS = ("disc", "reed", "ball")


def speed_bounds() -> tuple[float, float]:
    """The crank speed's plausible range [rpm] (lumped.model.pump_model.SPEED)."""
    from lumped.model.pump_model import SPEED

    return SPEED.bounds


def load_bounds_mpa() -> tuple[float, float]:
    """The load pressure's plausible range [MPa] (lumped.model.pump_model.LOAD_MPA)."""
    from lumped.model.pump_model import LOAD_MPA

    return LOAD_MPA.bounds


def air_bounds() -> tuple[float, float]:
    """The entrained air content's plausible range [-] (declared once, with the oil)."""
    from geometry.declare import spec_of
    from lumped.fluid.oil import Oil

    return spec_of(Oil, "air_content").bounds


def kind_names() -> tuple[str, ...]:
    """The registered valve kinds (lumped.valves.kind)."""
    from lumped.valves.kind import kind_names as names

    return names()


def __getattr__(name: str):
    """``AIR_BOUNDS``: :func:`air_bounds`, computed when first asked for (PEP 562)."""
    if name == "AIR_BOUNDS":
        return air_bounds()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def configure(p):
    """Add the arguments of ``valvelab pump`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("--model", default=None, metavar="NAME|FILE",
                   help="pump model: a shipped one (thesis-disc, thesis-reed, thesis-ball, ...) or a model TOML file "
                        "(default: the shipped model of --valve)")
    p.add_argument("--valve", default=None, type=flags.choice(kind_names, "a valve kind:"), metavar="KIND",
                   help=f"valve kind ({', '.join(SHIPPED_KINDS)} or one an extension registers): the shipped model "
                        "of that kind (thesis-<kind>) when no --model")
    p.add_argument("--speed-rpm", type=flags.number("rpm", speed_bounds), default=None,
                   help="crank speed [rpm] (default: the model's)")
    p.add_argument("--load-pressure-mpa", type=flags.number("MPa", load_bounds_mpa), default=None,
                   help="(mean) load pressure [MPa, absolute] (default: the model's)")
    p.add_argument("--air-content", type=flags.number("-", air_bounds), default=None,
                   help="entrained air R at 1 atm, in [0, 0.5) (default: the model's oil.air_content)")
    p.add_argument("--revolutions", type=flags.integer(2, MAX_REVOLUTIONS), default=5, help="revolutions to simulate (>= 2, default 5)")
    p.add_argument("--max-revolutions", type=flags.integer(2, MAX_REVOLUTIONS), default=None,
                   help="continue past --revolutions until cyclic steady state, at most this many")
    p.add_argument("--circuit", default=None, choices=("simplified", "complete"),
                   help="constant load pressure or accumulator + needle valve + load line (default: the model's)")
    p.add_argument("--trace", default=None, metavar="FILE.csv", help="write the last revolution's time series")
    p.add_argument("--trace-valve", default="delivery", choices=("inlet", "delivery"),
                   help="valve whose position fills the valve_position_m column (default delivery)")
    p.add_argument("--plot", default=None, metavar="FILE.png", help="draw valve openings and pressures")
    p.add_argument("--force", action="store_true", help="overwrite an existing --trace or --plot file")
    p.add_argument("--reed-geometry", default=None, metavar="PRESET|FILE",
                   help="reed valves: derive kappa, gamma1..3 and h_eff from this reed geometry")
    p.add_argument("--reed-fidelity", default=None,
                   help="reed model for --reed-geometry: analytic (default), beam, plate or solid")
    p.add_argument("--dead-volume-m3", type=flags.number("m^3", positive=True), default=None, help="cylinder volume at TDC [m^3]")
    p.add_argument("--rtol", type=flags.number("-", TOL_BOUNDS), default=None,
                   help="integrator relative tolerance (default: fast 1e-3, reference 1e-6)")
    p.add_argument("--atol", type=flags.number("-", TOL_BOUNDS), default=None,
                   help="integrator absolute tolerance in state scales (default: fast 1e-5, reference 1e-6)")
    p.add_argument("--uncertainty", action="store_true",
                   help="add u_num (tolerance ladder) and u_input (the model's declared input uncertainties, "
                        "Monte Carlo) of the delivery and the valve angles (ASME V&V 20)")
    p.add_argument("--method", default="fast", choices=("fast", "reference"),
                   help="fast: compiled Rodas4P (default; delivery within 0.1 %% and valve timing within 0.5 deg of "
                        "the reference, README); reference: scipy Radau")


def model_for(args, field: str = "--model"):
    """The pump model the flags describe: ``--model`` (or thesis-<``--valve``>) with the override flags applied.

    Parameters
    ----------
    args : argparse.Namespace
    field : str
        The flag named by a refusal of the model.

    Returns
    -------
    lumped.model.pump_model.PumpModel
    """
    from lumped.model.model_file import kind_default_model, load_model, with_values

    if args.model is None and args.valve is None:
        raise InputError("--model", "give a model (--model thesis-disc, thesis-reed, thesis-ball or a model file) or --valve")
    model = load_model(args.model if args.model is not None else kind_default_model(args.valve), field=field)
    if args.valve is not None and args.model is not None and set(model.kinds) != {args.valve}:
        raise InputError("--valve", f"the model {model.name!r} has {model.label} valves, not {args.valve}")
    values = {}
    if args.dead_volume_m3 is not None:
        values["pump.dead_volume"] = args.dead_volume_m3
    if args.reed_fidelity is not None:
        from lumped.reed.fidelities import reed_model

        reed_model(args.reed_fidelity, "--reed-fidelity")      # an unknown name, before anything else
    if args.reed_geometry is not None or args.reed_fidelity is not None:
        if "reed" not in model.kinds:
            flag = "--reed-geometry" if args.reed_geometry is not None else "--reed-fidelity"
            raise InputError(flag, f"the model {model.name!r} has no reed valve")
        for pos, kind in zip(("inlet", "delivery"), model.kinds):
            if kind == "reed":
                geo = args.reed_geometry or model.valve(pos).geometry
                if geo is None:
                    raise InputError("--reed-fidelity", "needs --reed-geometry (the model's reed has none)")
                values[f"valves.{pos}.geometry"] = geo
                values[f"valves.{pos}.fidelity"] = args.reed_fidelity or "analytic"
    try:
        return with_values(model, values)
    except InputError as exc:
        flag = {"pump.dead_volume": "--dead-volume-m3"}.get(exc.field)
        if flag is None and ".fidelity" in exc.field:
            flag = "--reed-fidelity"
        if flag is None and ".geometry" in exc.field:
            flag = "--reed-geometry"
        raise InputError(flag or exc.field, exc.message) from None


def _check_args(args) -> None:
    """What the flags' own types cannot see: one flag against another."""
    if args.max_revolutions is not None and args.max_revolutions < args.revolutions:
        raise InputError("--max-revolutions", f"expected at least --revolutions ({args.revolutions}), "
                                              f"got {args.max_revolutions}")


def run(args) -> dict:
    """Run ``valvelab pump``: simulate a pump (a shipped model or your model file) with its check valves to cyclic
    steady state (the JSON of ``--json``; :mod:`studies.cli`)."""
    from lumped.run.simulate import simulate
    from studies.outputs import check_distinct

    _check_args(args)
    check_distinct({"--trace": args.trace, "--plot": args.plot},
                   {"--model": args.model, "--reed-geometry": args.reed_geometry})
    outputs = _output_files(args)
    model = model_for(args)
    speed, load = _operating_point(args, model)
    from lumped.model.plausible import input_warnings

    implausible = [w.to_dict() for w in input_warnings(model)]     # with the run's own (JSON and stderr)
    res = simulate(model, speed, load, air_content=args.air_content, revolutions=args.revolutions,
                   max_revolutions=args.max_revolutions, circuit=args.circuit, rtol=args.rtol, atol=args.atol,
                   trace=bool(outputs), progress=True, method=args.method)
    out = res.to_dict()
    out["warnings"] = implausible + list(out.get("warnings") or [])
    from lumped.model.model_file import SHIPPED

    out["model"] = model.name if model.name in SHIPPED and model.source.startswith("lumped/") else model.source
    out["reed_parameters"] = _reed_source(model)
    out["fluid"] = {pos: getattr(model.valve(pos), "fluid", "empirical") for pos in ("inlet", "delivery")}
    if args.uncertainty:
        out["uncertainty"] = _uncertainty(args, model, (speed, load), res)
    out["trace"] = None
    if "--trace" in outputs:
        write_trace_csv(res, outputs["--trace"], args.trace_valve)
        out["trace"] = str(outputs["--trace"])
    if "--plot" in outputs:
        res.plot(outputs["--plot"], force=True)      # checked above, --force included
        out["plot"] = str(outputs["--plot"])
    return out


def _output_files(args) -> dict:
    """{flag: path} of the files the run writes (--trace, --plot), each checked before the run, not after."""
    from studies.outputs import check_new_file

    outputs = {}
    for flag, path in (("--trace", args.trace), ("--plot", args.plot)):
        if path is not None:
            if flag == "--plot":
                from studies.plots import check_plot_suffix
                path = check_plot_suffix(path)
            outputs[flag] = check_new_file(path, flag, args.force, writable=True)
    return outputs


def _operating_point(args, model) -> tuple[float, float]:
    """(speed [rpm], load [Pa]) from the flags, else the model's [operating]; refused below the tank pressure."""
    speed = args.speed_rpm if args.speed_rpm is not None else model.operating.speed_rpm
    load = args.load_pressure_mpa * 1e6 if args.load_pressure_mpa is not None else model.operating.load_pressure
    if speed is None:
        raise InputError("--speed-rpm", f"missing: the model {model.name!r} has no [operating] speed_rpm")
    if load is None:
        raise InputError("--load-pressure-mpa", f"missing: the model {model.name!r} has no [operating] load_pressure")
    if load < model.pump.tank_pressure:
        flag = "--load-pressure-mpa" if args.load_pressure_mpa is not None else "operating.load_pressure"
        raise InputError(flag, f"{load / 1e6:g} MPa is below the tank pressure {model.pump.tank_pressure / 1e6:g} MPa "
                               "(absolute): a pump delivers into a load above its inlet")
    return speed, load


def _uncertainty(args, model, operating: tuple[float, float], res) -> dict:
    """u_num and u_input of the run's outputs at ``operating`` (speed [rpm], load [Pa]) for ``--uncertainty``,
    the cost announced first."""
    from lumped.model.model_file import with_values
    from studies import costs
    from studies.outputs import announce
    from studies.validation import input_uncertainty as iu
    from studies.validation.numerical import LADDER
    from studies.validation.point import Point
    from studies.validation.vv20 import point_uncertainty

    first, most = iu.SCRAMBLES * 2 ** iu.FIRST_POWER, iu.SCRAMBLES * 2 ** iu.MAX_POWER
    announce("pump", f"u_num from {len(LADDER)} runs of a tolerance ladder; u_input from {first} Monte Carlo "
                     "draws of the model's declared input uncertainties, doubled until precise to "
                     f"{iu.TARGET_PRECISION:.0%} (at most {most})",
             costs.estimate(pump__fast=len(LADDER), pump__draw=first), f"measured per-run costs, {first} draws")
    m = model if args.air_content is None else with_values(model, {"oil.air_content": args.air_content})
    point = Point("point", m, *operating, args.revolutions, args.max_revolutions, args.circuit)
    return point_uncertainty(point, res, progress=True)


def _reed_source(model) -> str | None:
    """Where the reed valves' kappa, gammas and h_eff come from (None without reed valves)."""
    srcs = []
    for pos, kind in zip(("inlet", "delivery"), model.kinds):
        if kind == "reed":
            v = model.valve(pos)
            srcs.append(f"{v.fidelity} model of {v.geometry} (kappa, gammas, h_eff); Table 3.13 otherwise"
                        if v.geometry is not None else "Table 3.13")
    return None if not srcs else (srcs[0] if len(set(srcs)) == 1 else "; ".join(srcs))


def write_trace_csv(result, path, measured_valve: str = "delivery") -> None:
    """Write a result's trace in the measured-trace format of CONTRACT.md.

    Parameters
    ----------
    result : lumped.run.simulate.PumpResult
        With a trace.
    path : str or os.PathLike
    measured_valve : str
        The valve whose position is ``valve_position_m`` [m].
    """
    from studies.discrepancy.measured import TRACE_COLUMNS      # the measured-data format

    tr = result.trace
    pos = tr.signals[f"{measured_valve}_position"]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(TRACE_COLUMNS)
        for row in zip(tr.time, pos, tr.cylinder_pressure, tr.load_pressure, tr.inlet_position,
                       tr.delivery_position):
            w.writerow([f"{v:.9g}" for v in row])


def render(r: dict) -> str:
    """The result of ``valvelab pump`` as readable text."""
    def deg(d, k):
        return "-" if d[k] is None else f"{d[k]:.1f}"

    lines = [
        f"{r['model']}: {r['valve']} valves, {r['speed_rpm']:.0f} rpm, load {r['load_pressure_pa'] / 1e6:.3f} MPa, "
        f"R = {r['air_content']:g}, {r['circuit']} circuit",
        f"  delivery      {r['delivery_cc_per_rev']:.4f} cc/rev, volumetric efficiency "
        f"{r['volumetric_efficiency'] * 100:.2f} % (last of {r['revolutions']} revolutions; "
        f"cyclic steady: {'yes' if r['cyclic_steady'] else 'NO'}, change {r['cycle_change']:.1e})",
        f"  peak opening  inlet {r['peak_opening_m']['inlet'] * 1e3:.3f} mm, "
        f"delivery {r['peak_opening_m']['delivery'] * 1e3:.3f} mm",
        f"  opens/closes  inlet {deg(r['opening_angle_deg'], 'inlet')} / {deg(r['closing_angle_deg'], 'inlet')} deg, "
        f"delivery {deg(r['opening_angle_deg'], 'delivery')} / {deg(r['closing_angle_deg'], 'delivery')} deg",
        f"  valve losses  inlet {r['valve_loss_j_per_rev']['inlet'] * 1e3:.2f} mJ, "
        f"delivery {r['valve_loss_j_per_rev']['delivery'] * 1e3:.2f} mJ per revolution",
        f"  cylinder      {r['min_cylinder_pressure_pa'] / 1e6:.4f} to {r['max_cylinder_pressure_pa'] / 1e6:.3f} MPa"
        + (f", cavitating {r['cavitation_deg']:.1f} deg" if r["cavitation_deg"] > 0 else ""),
        f"  mass balance  {r['mass_balance_error']:.1e} (relative, last revolution)",
        f"  cpu           {r['cpu_seconds']:.3g} s ({r['cpu_seconds_per_simulated_second'] * 1e3:.3g} ms per "
        f"simulated s, {r.get('method', 'fast')} path)",
    ]
    if r["reed_parameters"]:
        lines.append(f"  reed data     {r['reed_parameters']}")
    for name, u in (r.get("uncertainty") or {}).items():
        top = ", ".join(f"{k} {v:.2g}" for k, v in u["contributors"]) or "none declared"
        num = "-" if u["u_num"] is None else f"{u['u_num']:.2g}"
        inp = "-" if u["u_input"] is None else f"{u['u_input']:.3g}"
        lines.append(f"  u {name:26s} u_num {num} {u['unit']}, u_input {inp} {u['unit']} ({top})")
    for k in ("trace", "plot"):
        if r.get(k):
            lines.append(f"  {k:13s} {r[k]}")
    return "\n".join(lines)
