"""``valvelab synth OUT``: a synthetic measured dataset with chosen effects hidden in it."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from geometry.errors import InputError
from studies.cli import flags
from studies.cli.pump import SHIPPED_KINDS, air_bounds, kind_names

if TYPE_CHECKING:     # the model layers and the discrepancy machinery load when the command runs, not for --help
    from lumped.model.effects import Applied
    from studies.discrepancy.synth import Condition

HELP = "write a synthetic measured dataset from the model with chosen effects hidden in it"


def configure(p):
    """Add the arguments of ``valvelab synth`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("out", help="dataset folder to write (refused if it holds files valvelab did not write)")
    p.add_argument("--valve", default=None, type=flags.choice(kind_names, "a valve kind:"), metavar="KIND",
                   help=f"valve kind ({', '.join(SHIPPED_KINDS)} or one an extension registers; default disc): the "
                        "shipped model of that kind when no --model")
    p.add_argument("--effect", action="append", default=[], metavar="NAME[@TARGET][:PARAM=VALUE,...]",
                   help="effect to hide, e.g. seat_compliance@delivery:k_seat=1.5e6 (repeatable; parameters "
                        "default to the effect's prior; TARGET inlet/delivery for one-valve effects)")
    p.add_argument("--condition", action="append", default=[], metavar="RPM:MPA[:VALVE]",
                   help="operating condition (speed rpm, load pressure MPa, measured valve inlet/delivery/both); "
                        "repeatable; default: the thesis's six runs for the valve type (Tables 5.3, 5.5)")
    p.add_argument("--air-content", type=flags.number("-", air_bounds), default=None,
                   help="air content R stated in every run.toml (default: not stated)")
    p.add_argument("--noise-um", type=flags.number("um", (0.0, 1e4)), default=10.0, help="white position noise [um] (default 10)")
    p.add_argument("--pressure-noise-kpa", type=flags.number("kPa", (0.0, 1e4)), default=10.0, help="white pressure noise [kPa] (default 10)")
    p.add_argument("--delivery-noise-pct", type=flags.number("%", (0.0, 50.0)), default=0.3,
                   help="standard deviation of the measured delivery [%%] (default 0.3)")
    p.add_argument("--scale-error", type=flags.number("-", (-0.2, 0.2)), default=None,
                   help="position-sensor scale error of both valves, e.g. 0.01 (default: drawn within +-1.12 %%)")
    p.add_argument("--time-offset-ms", type=flags.number("ms", (-5.0, 5.0)), default=None,
                   help="sensor lag behind the crank angle [ms] (default: drawn within +-0.2 ms)")
    p.add_argument("--sample-rate-hz", type=flags.number("Hz", (1e3, 1e7)), default=1.0e4, help="sampling rate (default 10 kHz, as the thesis)")
    p.add_argument("--revolutions", type=flags.integer(1, 1000), default=1, help="revolutions written per run (default 1)")
    p.add_argument("--seed", type=flags.integer(0, 2**32 - 1), default=0, help="random seed (default 0)")
    p.add_argument("--workers", type=flags.integer(1, 256), default=1, help="parallel simulations (default 1)")
    p.add_argument("--model", default=None, metavar="NAME|FILE",
                   help="pump model to synthesise from (a shipped one or a model file; default thesis-<--valve>); "
                        "the data come from its baseline (every candidate effect off, as the workflow starts "
                        "from) with the --effect list hidden in it")
    p.add_argument("--simulator", default=None, metavar="MODULE",
                   help="another model altogether: a module with simulate(condition, effects) and LIBRARY")
    p.add_argument("--force", action="store_true", help="write into a folder valvelab did not create")


def parse_effect(spec: str, library, valve_type) -> Applied:
    """An applied effect from the command line's ``NAME[@TARGET][:PARAM=VALUE,...]``.

    Parameters
    ----------
    spec : str
    library : lumped.model.effect_library.Library
    valve_type : str or lumped.model.pump_model.PumpModel
        The valve kind, or the pump model whose declarations check the values.

    Returns
    -------
    Applied
        Unset parameters at their prior.
    """
    from lumped.model.effects import Applied

    head, _, tail = spec.partition(":")
    name, _, target = head.partition("@")
    if name not in library:
        raise InputError("--effect", f"unknown effect {name!r}; expected one of {', '.join(library.names())}")
    eff = library[name]
    target = target or ("both" if "both" in eff.targets else eff.targets[-1])
    if target not in eff.targets:
        raise InputError("--effect", f"{name}: target {target!r}; expected one of {', '.join(eff.targets)}")
    if not eff.applies_to(valve_type, target):
        what = valve_type if isinstance(valve_type, str) else valve_type.kind_at(target)
        raise InputError("--effect", f"{name} does not apply to the {what} valve")
    values = eff.prior_values(valve_type, target)
    given = {}
    for item in filter(None, tail.split(",")):
        k, eq, v = item.partition("=")
        if not eq:
            raise InputError("--effect", f"{name}: expected PARAM=VALUE, got {item!r}")
        if k not in values:
            raise InputError("--effect", f"{name}: unknown parameter {k!r}; expected "
                             + (", ".join(p.name for p in eff.parameters_for(valve_type, target)) or "none (a switch)"))
        x = flags.from_text(v, f"--effect {name}:{k}")
        par = eff.parameter(k, valve_type, target)
        if par.log and x <= 0:
            raise InputError(f"--effect {name}:{k}", f"must be positive ({par.unit}), got {x:g}")
        values[k] = x
        given[k] = x
    if given and not isinstance(valve_type, str):    # a pump model: each value against its declared field
        from lumped.model.effect_library import check_values

        check_values(eff, given, valve_type, target, f"--effect {name}")
    return Applied.of(name, target, values)


def parse_condition(spec: str, air: float | None) -> Condition:
    """A measured condition from the command line's ``RPM:MPA[:VALVE]``.

    Parameters
    ----------
    spec : str
    air : float or None
        The oil's air content (volume fraction) stated for the condition.

    Returns
    -------
    Condition
        Speed [rpm], load pressure [Pa], the measured valve.
    """
    from lumped.model.pump_model import LOAD_MPA, SPEED
    from studies.discrepancy.measured import MEASURED_VALVES
    from studies.discrepancy.synth import Condition

    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise InputError("--condition", f"expected RPM:MPA[:VALVE], got {spec!r}")
    rpm = flags.from_text(parts[0], "--condition (speed)", "rpm", SPEED.bounds)
    mpa = flags.from_text(parts[1], "--condition (load pressure)", "MPa", LOAD_MPA.bounds)
    valve = parts[2] if len(parts) == 3 else "delivery"
    if valve not in MEASURED_VALVES:
        raise InputError("--condition", f"measured valve {valve!r}; expected one of {', '.join(MEASURED_VALVES)}")
    return Condition(rpm, mpa * 1e6, valve, air)


def run(args) -> dict:
    """Run ``valvelab synth``: write a synthetic measured dataset from the model with chosen effects hidden in it (the
    JSON of ``--json``; :mod:`studies.cli`)."""
    from geometry import validate
    from studies.discrepancy.model_choice import choose
    from studies.discrepancy.synth import (MAX_SAMPLES_PER_RUN, Noise, check_rerun, synthesize, thesis_conditions,
                                           write_synthetic)
    from studies.outputs import check_output_dir

    check_output_dir(args.out, "OUT", args.force, kind="dataset")          # before any simulation
    check_rerun(args.out, "OUT", args.force, {"--model": args.model})
    if args.model is not None and args.valve is not None:
        raise InputError("--valve", "the valves come from --model; give one or the other")
    sim = choose(args.model, args.simulator, valve_type=args.valve or "disc")
    valve_type = sim.context.label if sim.context is not None else (args.valve or "disc")
    ctx = sim.context if sim.context is not None else valve_type
    truth = tuple(parse_effect(s, sim.library, ctx) for s in args.effect)
    names = [a.name for a in truth]
    if len(set(names)) != len(names):
        raise InputError("--effect", "each effect at most once")
    conds = ([parse_condition(c, args.air_content) for c in args.condition] if args.condition
             else thesis_conditions(sim.context if sim.context is not None else valve_type, args.air_content))
    if not conds:
        raise InputError("--condition", f"the thesis ran no pump like {sim.name!r}: give the operating conditions")
    for c in conds:                                         # the trace size, before any simulation
        validate.size(args.revolutions * 60.0 / c.speed_rpm * args.sample_rate_hz, "--revolutions",
                      limit=MAX_SAMPLES_PER_RUN, unit="samples per run", bytes_each=80.0,
                      how=f"at {c.speed_rpm:g} rpm lower --revolutions or --sample-rate-hz")
    noise = Noise(
        position_m=args.noise_um * 1e-6, pressure_pa=args.pressure_noise_kpa * 1e3,
        delivery_frac=args.delivery_noise_pct / 100.0,
        scale_error=None if args.scale_error is None else (args.scale_error, args.scale_error),
        time_offset_s=None if args.time_offset_ms is None else args.time_offset_ms * 1e-3,
        sample_rate_hz=args.sample_rate_hz, revolutions=args.revolutions,
    )
    runs, truth_doc = synthesize(sim.simulate, valve_type, conds, truth, noise, seed=args.seed,
                                 workers=args.workers)     # a ModelFailure: exit 1, one line (studies.cli)
    model_file = None
    if sim.context is not None and args.model is not None:
        from lumped.model.model_file import SHIPPED, to_toml

        if args.model in SHIPPED:
            runs = [replace(r, model=args.model) for r in runs]
        else:   # the dataset carries its model, resolved (the workflow reads it from run.toml)
            model_file = to_toml(sim.context)
            runs = [replace(r, model="../model.toml") for r in runs]
        truth_doc["model"] = sim.name
    folder = write_synthetic(Path(args.out), runs, truth_doc, force=args.force)
    if model_file is not None:
        (folder / "model.toml").write_text(model_file)
    from studies.cli._warnings import at_conditions

    return {"dataset": str(folder), "runs": [r.name for r in runs], "truth": truth_doc,
            "warnings": at_conditions(sim.simulate, conds, truth, [r.name for r in runs])}


def render(r: dict) -> str:
    """The result of ``valvelab synth`` as readable text."""
    eff = ", ".join(f"{e['name']}@{e['target']}" for e in r["truth"]["effects"]) or "none"
    return f"wrote {len(r['runs'])} runs to {r['dataset']} (hidden effects: {eff}; truth in truth.toml)"
