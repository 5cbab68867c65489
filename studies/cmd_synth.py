"""``valvelab synth OUT``: a synthetic measured dataset with chosen effects hidden in it."""

from __future__ import annotations

import math
import sys
from pathlib import Path

from geometry.errors import InputError
from lumped.effects import Applied

from .measured import MEASURED_VALVES, VALVE_TYPES
from .model_choice import load_model
from .discrepancy import ModelFailure
from .synth import Condition, Noise, synthesize, write_synthetic
from .thesis import experiments

HELP = "write a synthetic measured dataset from the model with chosen effects hidden in it"


def configure(p):
    p.add_argument("out", help="dataset folder to write (refused if it holds files valvelab did not write)")
    p.add_argument("--valve", default="disc", help="disc (default) or reed")
    p.add_argument("--effect", action="append", default=[], metavar="NAME[@TARGET][:PARAM=VALUE,...]",
                   help="effect to hide, e.g. seat_compliance@delivery:k_seat=1.5e6 (repeatable; parameters "
                        "default to the effect's prior; TARGET inlet/delivery for one-valve effects)")
    p.add_argument("--condition", action="append", default=[], metavar="RPM:MPA[:VALVE]",
                   help="operating condition (speed rpm, load pressure MPa, measured valve inlet/delivery/both); "
                        "repeatable; default: the thesis's six runs for the valve type (Tables 5.3, 5.5)")
    p.add_argument("--air-content", type=float, default=None,
                   help="air content R stated in every run.toml (default: not stated)")
    p.add_argument("--noise-um", type=float, default=10.0, help="white position noise [um] (default 10)")
    p.add_argument("--pressure-noise-kpa", type=float, default=10.0, help="white pressure noise [kPa] (default 10)")
    p.add_argument("--delivery-noise-pct", type=float, default=0.3,
                   help="standard deviation of the measured delivery [%%] (default 0.3)")
    p.add_argument("--scale-error", type=float, default=None,
                   help="position-sensor scale error of both valves, e.g. 0.01 (default: drawn within +-1.12 %%)")
    p.add_argument("--time-offset-ms", type=float, default=None,
                   help="sensor lag behind the crank angle [ms] (default: drawn within +-0.2 ms)")
    p.add_argument("--sample-rate-hz", type=float, default=1.0e4, help="sampling rate (default 10 kHz, as the thesis)")
    p.add_argument("--revolutions", type=int, default=1, help="revolutions written per run (default 1)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--workers", type=int, default=1, help="parallel simulations (default 1)")
    p.add_argument("--model", default=None, help="model module (default studies.pump_sim)")
    p.add_argument("--force", action="store_true", help="write into a folder valvelab did not create")


def _number(text: str, field: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(field, f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise InputError(field, f"expected a finite number, got {text!r}")
    return v


def parse_effect(spec: str, library, valve_type: str) -> Applied:
    """``NAME[@TARGET][:PARAM=VALUE,...]`` -> an applied effect (unset parameters at their prior)."""
    head, _, tail = spec.partition(":")
    name, _, target = head.partition("@")
    if name not in library:
        raise InputError("--effect", f"unknown effect {name!r}; expected one of {', '.join(library.names())}")
    eff = library[name]
    if valve_type not in eff.valve_types:
        raise InputError("--effect", f"{name} does not apply to the {valve_type} valve")
    target = target or eff.targets[-1]
    if target not in eff.targets:
        raise InputError("--effect", f"{name}: target {target!r}; expected one of {', '.join(eff.targets)}")
    values = eff.prior_values(valve_type)
    for item in filter(None, tail.split(",")):
        k, eq, v = item.partition("=")
        if not eq:
            raise InputError("--effect", f"{name}: expected PARAM=VALUE, got {item!r}")
        if k not in values:
            raise InputError("--effect", f"{name}: unknown parameter {k!r}; expected "
                             + (", ".join(p.name for p in eff.parameters_for(valve_type)) or "none (a switch)"))
        x = _number(v, f"--effect {name}:{k}")
        par = eff.parameter(k, valve_type)
        if par.log and x <= 0:
            raise InputError(f"--effect {name}:{k}", f"must be positive ({par.unit}), got {x:g}")
        values[k] = x
    return Applied.of(name, target, values)


def parse_condition(spec: str, air: float | None) -> Condition:
    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise InputError("--condition", f"expected RPM:MPA[:VALVE], got {spec!r}")
    rpm = _number(parts[0], "--condition")
    mpa = _number(parts[1], "--condition")
    valve = parts[2] if len(parts) == 3 else "delivery"
    if not 10 <= rpm <= 20000:
        raise InputError("--condition", f"speed {rpm:g} rpm out of range 10-20000")
    if not 0.01 <= mpa <= 100:
        raise InputError("--condition", f"load pressure {mpa:g} MPa out of range 0.01-100 (it is in MPa)")
    if valve not in MEASURED_VALVES:
        raise InputError("--condition", f"measured valve {valve!r}; expected one of {', '.join(MEASURED_VALVES)}")
    return Condition(rpm, mpa * 1e6, valve, air)


def thesis_conditions(valve_type: str, air: float | None) -> list[Condition]:
    """The six measured runs of the thesis for a valve type (Tables 5.3-5.6): speed, load, measured valve."""
    return [Condition(c["speed_rpm"], c["load_pressure"], c["measured_valve"], air)
            for c in experiments() if c["valve"] == valve_type]


def run(args) -> dict:
    if args.valve not in VALVE_TYPES:
        raise InputError("--valve", f"expected one of {', '.join(VALVE_TYPES)}, got {args.valve!r}")
    if args.air_content is not None and not 0 <= args.air_content < 0.5:
        raise InputError("--air-content", f"a volume fraction 0 <= R < 0.5, got {args.air_content:g}")
    for flag, v in (("--noise-um", args.noise_um), ("--pressure-noise-kpa", args.pressure_noise_kpa),
                    ("--delivery-noise-pct", args.delivery_noise_pct)):
        if not (math.isfinite(v) and v >= 0):
            raise InputError(flag, f"must be a non-negative number, got {v}")
    if args.scale_error is not None and not abs(args.scale_error) < 0.2:
        raise InputError("--scale-error", f"a fraction such as 0.01, got {args.scale_error:g}")
    if args.time_offset_ms is not None and not abs(args.time_offset_ms) < 5:
        raise InputError("--time-offset-ms", f"a few tenths of a ms at most, got {args.time_offset_ms:g}")
    if args.sample_rate_hz < 1000 or args.revolutions < 1:
        raise InputError("--sample-rate-hz", "at least 1000 Hz and one revolution")
    simulate, library = load_model(args.model)
    truth = tuple(parse_effect(s, library, args.valve) for s in args.effect)
    names = [a.name for a in truth]
    if len(set(names)) != len(names):
        raise InputError("--effect", "each effect at most once")
    conds = ([parse_condition(c, args.air_content) for c in args.condition] if args.condition
             else thesis_conditions(args.valve, args.air_content))
    noise = Noise(
        position_m=args.noise_um * 1e-6, pressure_pa=args.pressure_noise_kpa * 1e3,
        delivery_frac=args.delivery_noise_pct / 100.0,
        scale_error=None if args.scale_error is None else (args.scale_error, args.scale_error),
        time_offset_s=None if args.time_offset_ms is None else args.time_offset_ms * 1e-3,
        sample_rate_hz=args.sample_rate_hz, revolutions=args.revolutions,
    )
    try:
        runs, truth_doc = synthesize(simulate, args.valve, conds, truth, noise, seed=args.seed, workers=args.workers)
    except ModelFailure as exc:   # not a user mistake: exit 1 with one line, no traceback
        sys.stderr.write(f"valvelab synth: error: {exc}\n")
        raise SystemExit(1) from None
    folder = write_synthetic(Path(args.out), runs, truth_doc, force=args.force)
    return {"dataset": str(folder), "runs": [r.name for r in runs], "truth": truth_doc}


def render(r: dict) -> str:
    eff = ", ".join(f"{e['name']}@{e['target']}" for e in r["truth"]["effects"]) or "none"
    return f"wrote {len(r['runs'])} runs to {r['dataset']} (hidden effects: {eff}; truth in truth.toml)"
