"""``valvelab pump``: one run of the piston pump with disc or reed check valves (CONTRACT.md)."""

from __future__ import annotations

import math
from dataclasses import replace

from geometry.errors import InputError

HELP = "simulate the piston pump with disc or reed check valves to cyclic steady state"


def configure(p):
    p.add_argument("--valve", required=True, choices=("disc", "reed"), help="check valve type")
    p.add_argument("--speed-rpm", required=True, type=float, help="crank speed [rpm]")
    p.add_argument("--load-pressure-mpa", required=True, type=float, help="(mean) load pressure [MPa, absolute]")
    p.add_argument("--air-content", type=float, default=None,
                   help="entrained air R at 1 atm, in [0, 1) (default: the thesis's 0.013 disc, 0.008 reed)")
    p.add_argument("--revolutions", type=int, default=5, help="revolutions to simulate (>= 2, default 5)")
    p.add_argument("--max-revolutions", type=int, default=None,
                   help="continue past --revolutions until cyclic steady state, at most this many")
    p.add_argument("--circuit", default="simplified", choices=("simplified", "complete"),
                   help="constant load pressure (thesis) or accumulator + needle valve + load line")
    p.add_argument("--trace", default=None, metavar="FILE.csv", help="write the last revolution's time series")
    p.add_argument("--trace-valve", default="delivery", choices=("inlet", "delivery"),
                   help="valve whose position fills the valve_position_m column (default delivery)")
    p.add_argument("--force", action="store_true", help="overwrite an existing --trace file")
    p.add_argument("--reed-geometry", default=None, metavar="PRESET|FILE",
                   help="take kappa, gamma1..3 and h_eff from this reed geometry (reed valves only)")
    p.add_argument("--reed-fidelity", default="analytic",
                   help="reed model for --reed-geometry: analytic (default), beam, plate or solid")
    p.add_argument("--dead-volume-m3", type=float, default=None,
                   help="cylinder volume at TDC [m^3] (default: Table 5.1's 2.17e-5 for the disc pump, the inferred "
                        "4.0e-5 for the reed manifolds, see docs/errata.md)")
    p.add_argument("--rtol", type=float, default=None,
                   help="integrator relative tolerance (default: 1e-6 reference, lumped.pump_fast.RTOL fast)")
    p.add_argument("--atol", type=float, default=None,
                   help="integrator absolute tolerance, in state scales (default: 1e-6 reference, "
                        "lumped.pump_fast.ATOL fast)")
    p.add_argument("--method", default="reference", choices=("reference", "fast"),
                   help="reference: scipy Radau (default); fast: the same physics compiled (Rodas4P, "
                        "lumped.pump_fast), delivery within 0.1 %% of the reference, ~300x faster; "
                        "the complete circuit always runs on the reference")


def _positive(name: str, v: float, what: str) -> float:
    if v is None or not math.isfinite(v) or v <= 0:
        raise InputError(name, f"must be a positive finite {what}, got {v}")
    return v


def run(args) -> dict:
    from lumped.params import thesis_model, with_reed_properties
    from lumped.pump import simulate, write_trace_csv
    from studies.outputs import check_new_file

    speed = _positive("--speed-rpm", args.speed_rpm, "speed in rpm")
    p_load = _positive("--load-pressure-mpa", args.load_pressure_mpa, "absolute pressure in MPa") * 1e6
    if args.air_content is not None and not (math.isfinite(args.air_content) and 0.0 <= args.air_content < 1.0):
        raise InputError("--air-content", f"must be a volume fraction in [0, 1), got {args.air_content}")
    if args.revolutions < 2:
        raise InputError("--revolutions", f"must be at least 2 (cyclic steady state compares two), got {args.revolutions}")
    if args.max_revolutions is not None and args.max_revolutions < args.revolutions:
        raise InputError("--max-revolutions", f"must be >= --revolutions ({args.revolutions}), got {args.max_revolutions}")
    for name, v in (("--rtol", args.rtol), ("--atol", args.atol)):
        if v is not None and not (math.isfinite(v) and 0 < v < 1):
            raise InputError(name, f"must be in (0, 1), got {v}")
    if args.trace is not None:
        check_new_file(args.trace, "--trace", args.force)      # fail before the run, not after

    model = thesis_model(args.valve, args.air_content)
    if args.dead_volume_m3 is not None:
        model = replace(model, pump=replace(model.pump, dead_volume=_positive(
            "--dead-volume-m3", args.dead_volume_m3, "volume in m^3")))
    source = "Table 3.13" if args.valve == "reed" else "Table 2.3"
    if args.reed_geometry is not None:
        if args.valve != "reed":
            raise InputError("--reed-geometry", "applies to --valve reed only")
        from geometry import load_reed
        from studies.cmd_reed import reed_model

        reed = load_reed(args.reed_geometry)
        fn = reed_model(args.reed_fidelity)
        try:
            props = fn(reed)
        except ImportError as exc:  # the fidelity's module is not installed on this branch
            raise InputError("--reed-fidelity", f"{args.reed_fidelity} model not available ({exc})") from None
        model = replace(model, inlet=with_reed_properties(model.inlet, props),
                        delivery=with_reed_properties(model.delivery, props))
        source = f"{args.reed_fidelity} model of {args.reed_geometry} (kappa, gammas, h_eff); Table 3.13 otherwise"

    res = simulate(args.valve, speed, p_load, params=model, revolutions=args.revolutions,
                   max_revolutions=args.max_revolutions, circuit=args.circuit, rtol=args.rtol, atol=args.atol,
                   trace=args.trace is not None, progress=True,
                   method="fast" if args.method == "fast" else "Radau")
    if args.trace is not None:
        write_trace_csv(res, args.trace, measured_valve=args.trace_valve, force=True)
    return result_json(res, source=source, trace=args.trace)


def result_json(res, source: str = "", trace: str | None = None) -> dict:
    """CONTRACT's JSON of one pump run (plus documented extensions)."""
    def deg(a):
        return None if a is None else round(math.degrees(a), 3)

    return {
        "valve": res.valve, "speed_rpm": res.speed_rpm, "load_pressure_pa": res.load_pressure,
        "delivery_cc_per_rev": res.delivery_per_rev * 1e6, "revolutions": res.revolutions,
        "cpu_seconds": res.cpu_seconds, "mass_balance_error": res.mass_balance_error,
        "air_content": res.air_content, "circuit": res.circuit,
        "cyclic_steady": res.cyclic_steady, "cycle_change": res.cycle_change,
        "deliveries_cc": [d * 1e6 for d in res.deliveries],
        "cpu_seconds_per_simulated_second": res.cpu_per_simulated_second,
        "peak_opening_m": {"inlet": res.peak_opening[0], "delivery": res.peak_opening[1]},
        "opening_angle_deg": {"inlet": deg(res.opening_angle[0]), "delivery": deg(res.opening_angle[1])},
        "closing_angle_deg": {"inlet": deg(res.closing_angle[0]), "delivery": deg(res.closing_angle[1])},
        "stop_contacts": {"inlet": res.stop_contacts[0], "delivery": res.stop_contacts[1]},
        "mean_load_pressure_pa": res.mean_load_pressure, "needle_area_m2": res.needle_area,
        "reed_parameters": source if res.valve == "reed" else None, "trace": trace,
        "method": "fast" if res.method == "fast" else "reference", "rtol": res.rtol, "atol": res.atol,
    }


def render(r: dict) -> str:
    lines = [
        f"{r['valve']} valves, {r['speed_rpm']:.0f} rpm, load {r['load_pressure_pa'] / 1e6:.3f} MPa, "
        f"R = {r['air_content']:g}, {r['circuit']} circuit",
        f"  delivery      {r['delivery_cc_per_rev']:.4f} cc/rev (last of {r['revolutions']} revolutions; "
        f"cyclic steady: {'yes' if r['cyclic_steady'] else 'NO'}, change {r['cycle_change']:.1e})",
        f"  peak opening  inlet {r['peak_opening_m']['inlet'] * 1e3:.3f} mm, "
        f"delivery {r['peak_opening_m']['delivery'] * 1e3:.3f} mm",
        f"  opens/closes  inlet {r['opening_angle_deg']['inlet']} / {r['closing_angle_deg']['inlet']} deg, "
        f"delivery {r['opening_angle_deg']['delivery']} / {r['closing_angle_deg']['delivery']} deg",
        f"  mass balance  {r['mass_balance_error']:.1e} (relative, last revolution)",
        f"  cpu           {r['cpu_seconds']:.3g} s ({r['cpu_seconds_per_simulated_second']:.3g} s per simulated s, "
        f"{r.get('method', 'reference')} path)",
    ]
    if r["reed_parameters"]:
        lines.append(f"  reed data     {r['reed_parameters']}")
    if r["trace"]:
        lines.append(f"  trace         {r['trace']}")
    return "\n".join(lines)
