"""``valvelab synth OUT``: a synthetic measured dataset with chosen effects hidden in it."""

from __future__ import annotations

import math
import sys
from dataclasses import replace
from pathlib import Path

from geometry.errors import InputError
from lumped.effects import Applied

from .measured import MEASURED_VALVES
from .model_choice import choose
from .discrepancy import ModelFailure
from .synth import Condition, Noise, synthesize, write_synthetic
from .thesis import experiments

HELP = "write a synthetic measured dataset from the model with chosen effects hidden in it"


def configure(p):
    p.add_argument("out", help="dataset folder to write (refused if it holds files valvelab did not write)")
    p.add_argument("--valve", default=None, help="disc (default) or reed: the thesis model of that valve type "
                                                  "when no --model")
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
    p.add_argument("--model", default=None, metavar="NAME|FILE",
                   help="pump model to synthesise from (a shipped one or a model file; default thesis-<--valve>); "
                        "the data come from its baseline (every candidate effect off, as the workflow starts "
                        "from) with the --effect list hidden in it")
    p.add_argument("--simulator", default=None, metavar="MODULE",
                   help="another model altogether: a module with simulate(condition, effects) and LIBRARY")
    p.add_argument("--force", action="store_true", help="write into a folder valvelab did not create")


def _number(text: str, field: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(field, f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise InputError(field, f"expected a finite number, got {text!r}")
    return v


def parse_effect(spec: str, library, valve_type) -> Applied:
    """``NAME[@TARGET][:PARAM=VALUE,...]`` -> an applied effect (unset parameters at their prior)."""
    head, _, tail = spec.partition(":")
    name, _, target = head.partition("@")
    if name not in library:
        raise InputError("--effect", f"unknown effect {name!r}; expected one of {', '.join(library.names())}")
    eff = library[name]
    target = target or eff.targets[-1]
    if target not in eff.targets:
        raise InputError("--effect", f"{name}: target {target!r}; expected one of {', '.join(eff.targets)}")
    if not eff.applies_to(valve_type, target):
        what = valve_type if isinstance(valve_type, str) else valve_type.kind_at(target)
        raise InputError("--effect", f"{name} does not apply to the {what} valve")
    values = eff.prior_values(valve_type, target)
    for item in filter(None, tail.split(",")):
        k, eq, v = item.partition("=")
        if not eq:
            raise InputError("--effect", f"{name}: expected PARAM=VALUE, got {item!r}")
        if k not in values:
            raise InputError("--effect", f"{name}: unknown parameter {k!r}; expected "
                             + (", ".join(p.name for p in eff.parameters_for(valve_type, target)) or "none (a switch)"))
        x = _number(v, f"--effect {name}:{k}")
        par = eff.parameter(k, valve_type, target)
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
    if args.valve is not None and args.valve not in ("disc", "reed"):
        raise InputError("--valve", f"expected disc or reed, got {args.valve!r}")
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
    if args.model is not None and args.valve is not None:
        raise InputError("--valve", "the valves come from --model; give one or the other")
    sim = choose(args.model, args.simulator, valve_type=args.valve or "disc")
    valve_type = sim.context.label if sim.context is not None else (args.valve or "disc")
    ctx = sim.context if sim.context is not None else valve_type
    truth = tuple(parse_effect(s, sim.library, ctx) for s in args.effect)
    names = [a.name for a in truth]
    if len(set(names)) != len(names):
        raise InputError("--effect", "each effect at most once")
    if not args.condition and valve_type not in ("disc", "reed"):
        raise InputError("--condition", f"the thesis ran no {valve_type} pump: give the operating conditions")
    conds = ([parse_condition(c, args.air_content) for c in args.condition] if args.condition
             else thesis_conditions(valve_type, args.air_content))
    noise = Noise(
        position_m=args.noise_um * 1e-6, pressure_pa=args.pressure_noise_kpa * 1e3,
        delivery_frac=args.delivery_noise_pct / 100.0,
        scale_error=None if args.scale_error is None else (args.scale_error, args.scale_error),
        time_offset_s=None if args.time_offset_ms is None else args.time_offset_ms * 1e-3,
        sample_rate_hz=args.sample_rate_hz, revolutions=args.revolutions,
    )
    try:
        runs, truth_doc = synthesize(sim.simulate, valve_type, conds, truth, noise, seed=args.seed,
                                     workers=args.workers)
    except ModelFailure as exc:   # not a user mistake: exit 1 with one line, no traceback
        sys.stderr.write(f"valvelab synth: error: {exc}\n")
        raise SystemExit(1) from None
    model_file = None
    if sim.context is not None and args.model is not None:
        from lumped.model_file import SHIPPED, to_toml

        if args.model in SHIPPED:
            runs = [replace(r, model=args.model) for r in runs]
        else:   # the dataset carries its model, resolved (the workflow reads it from run.toml)
            model_file = to_toml(sim.context)
            runs = [replace(r, model="../model.toml") for r in runs]
        truth_doc["model"] = sim.name
    folder = write_synthetic(Path(args.out), runs, truth_doc, force=args.force)
    if model_file is not None:
        (folder / "model.toml").write_text(model_file)
    return {"dataset": str(folder), "runs": [r.name for r in runs], "truth": truth_doc}


def render(r: dict) -> str:
    eff = ", ".join(f"{e['name']}@{e['target']}" for e in r["truth"]["effects"]) or "none"
    return f"wrote {len(r['runs'])} runs to {r['dataset']} (hidden effects: {eff}; truth in truth.toml)"
