"""``valvelab discrepancy DATASET``: find what the model is missing, add it, show the gap shrink."""

from __future__ import annotations

import sys
from pathlib import Path

from geometry.errors import InputError
from studies.cli import flags

HELP = "name the effects the baseline model misses in a measured dataset, fit them, report the gap"


def configure(p):
    """Add the arguments of ``valvelab discrepancy`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("dataset", nargs="?", default=None,
                   help="folder of run folders (run.toml, trace.csv), or one run folder")
    p.add_argument("--demo", action="store_true",
                   help="the thesis's own story: first write DATASET (default thesis_oring_demo) synthesised "
                        "with the delivery valve's O-ring compliance hidden (sections 2.4.3.2, 5.4.5), then run")
    p.add_argument("--seed", type=flags.integer(0, 2**32 - 1), default=0, help="seed of the --demo dataset (default 0)")
    p.add_argument("--report", default=None,
                   help="report folder (default: <dataset name>_discrepancy in the current folder)")
    p.add_argument("--no-report", action="store_true", help="print the result only")
    p.add_argument("--force", action="store_true", help="write the report into a folder valvelab did not create")
    p.add_argument("--holdout", action="append", default=None, metavar="RUN",
                   help="run held out from fitting (repeatable; default: every third operating condition)")
    p.add_argument("--position-tolerance-um", type=flags.number("um", (1e-3, 1e4), positive=True), default=20.0,
                   help="position RMS gap worth one unit [um] (default 20)")
    p.add_argument("--delivery-tolerance-pct", type=flags.number("%", (1e-4, 100.0), positive=True), default=0.5,
                   help="delivery error worth one unit [%%] (default 0.5)")
    p.add_argument("--min-improvement-pct", type=flags.number("%", (0.0, 99.9), positive=True), default=30.0,
                   help="how much an effect must shrink the held-out gap to be added [%%] (default 30)")
    p.add_argument("--min-gain-units", type=flags.number("-", (0.0, 1e6), positive=True), default=None,
                   help="how much an effect must shrink the held-out gap in tolerance units (default 1.5 when "
                        "the model's discharge-coefficient factor is fitted as a nuisance, else 3: above what "
                        "a 3 %% discharge-coefficient error lets a wrong effect gain; left at the default, 0.5 "
                        "for an effect that also lowers the fit cost by 5 %% or more)")
    p.add_argument("--max-rounds", type=flags.integer(0, 20), default=3, help="most effects added (default 3)")
    p.add_argument("--workers", type=flags.integer(1, 256), default=2, help="parallel simulations (default 2)")
    p.add_argument("--model", default=None, metavar="NAME|FILE",
                   help="pump model (a shipped one or a model file; default: run.toml's model, else the thesis "
                        "model of the runs' valve type); the baseline is it with every candidate effect off")
    p.add_argument("--simulator", default=None, metavar="MODULE",
                   help="another model altogether: a module with simulate(condition, effects) and LIBRARY")


def demo_dataset(folder, seed: int, workers: int, force: bool):
    """Write the thesis's O-ring story as a dataset.

    The six disc runs of Tables 5.3/5.4 with the delivery valve's compliant seat (the thesis-disc
    model's own effect: the O-ring's 1.5e6 N/m, section 2.4.3.2) and the thesis's air content
    stated; the baseline will assume a rigid seat.

    Parameters
    ----------
    folder : str or os.PathLike
    seed : int
        The noise's seed.
    workers : int
    force : bool
        Write into a folder valvelab did not create.
    """
    from studies.discrepancy.model_choice import choose
    from studies.discrepancy.synth import Noise, synthesize, thesis_conditions, write_synthetic

    sim = choose(model="thesis-disc")
    truth = sim.context.effects                    # the O-ring: seat_compliance on the delivery valve
    conds = thesis_conditions("disc", sim.context.oil.air_content)
    sys.stderr.write(f"discrepancy: writing the O-ring demonstration dataset to {folder}\n")
    runs, truth_doc = synthesize(sim.simulate, "disc", conds, truth, Noise(), seed=seed, workers=workers)
    write_synthetic(folder, runs, truth_doc, force=force)


def _announce(args, runs, model: str) -> None:
    """Say what the search runs and about how long, from the measured cost per run of the shipped pump models
    (no estimate for a ``--simulator`` of the user's)."""
    from studies import costs
    from studies.outputs import announce

    seconds = costs.estimate(discrepancy__run=len(runs)) if args.simulator is None else None
    announce("discrepancy", f"{len(runs)} runs against {model}, at most {args.max_rounds} rounds over the candidate "
                            f"effects on {args.workers} worker{'s' if args.workers > 1 else ''}", seconds,
             basis="the median of 99 measured datasets; up to 4x where two effects trade")


def run(args) -> dict:
    """Run ``valvelab discrepancy``: name the effects the baseline model misses in a measured dataset, fit them, report
    the gap (the JSON of ``--json``; :mod:`studies.cli`)."""
    # the machinery loads here, not with the parser: ``valvelab discrepancy --help`` imports no model
    from studies.discrepancy.gap import GapScales
    from studies.discrepancy.measured import implausible, read_dataset
    from studies.discrepancy.model_choice import check_demo_model, choose
    from studies.discrepancy.report import write_report
    from studies.discrepancy.workflow import Settings, Workflow
    from studies.outputs import check_output_dir

    scales = GapScales(args.position_tolerance_um * 1e-6, args.delivery_tolerance_pct / 100.0)
    rel = args.min_improvement_pct / 100.0
    gain = args.min_gain_units
    if args.demo:
        args.dataset = args.dataset or "thesis_oring_demo"
        check_output_dir(args.dataset, "DATASET", args.force, kind="dataset")
        from studies.discrepancy.synth import check_rerun

        check_rerun(args.dataset, "DATASET", args.force, {"--model": args.model})
        check_demo_model(args.model, args.simulator)        # before the demo dataset is written
    elif args.dataset is None:
        raise InputError("DATASET", "missing; give a dataset folder (or --demo)")
    report = None
    if args.no_report and args.report is not None:
        raise InputError("--report", "and --no-report contradict each other; give one")
    if not args.no_report:       # refuse an unusable report folder before minutes of search
        report = Path(args.report) if args.report else Path(f"{Path(args.dataset).resolve().name}_discrepancy")
        if Path(args.dataset).resolve() in (report.resolve(), *report.resolve().parents):
            raise InputError("--report", f"{report} is or lies inside the dataset folder DATASET; the report would "
                                         "mix with its runs: choose another folder")
        check_output_dir(report, "--report", args.force, kind="report")
    if args.demo:
        demo_dataset(args.dataset, args.seed, args.workers, args.force)
    runs = read_dataset(args.dataset)
    sim = choose(args.model, args.simulator, runs)
    _announce(args, runs, sim.name)
    settings = Settings(scales=scales, min_rel_improvement=rel, min_abs_improvement=gain,
                        max_rounds=args.max_rounds, holdout=tuple(args.holdout) if args.holdout else None,
                        workers=args.workers)
    # a ModelFailure is not a user mistake: exit 1 with one line (studies.cli)
    outcome = Workflow(runs, sim.simulate, sim.library, settings, progress=True, context=sim.context).run()
    result = outcome.as_contract()
    result["dataset"] = str(args.dataset)
    result["model"] = sim.name
    result["report"] = None
    from studies.cli._warnings import at_conditions

    # the validity envelope of the model found (its effects and fitted nuisances) at each run's condition
    result["warnings"] = implausible(runs) + at_conditions(sim.simulate, runs,
                                                           tuple(outcome.model) + tuple(outcome.nuisances))
    if report is not None:
        result["report"] = str(report)
        write_report(report, outcome, runs, result, force=args.force)
    return result


def render(r: dict) -> str:
    """The result of ``valvelab discrepancy`` as readable text."""
    from studies.discrepancy.records import values_text
    from studies.discrepancy.validation import sentence as validation_sentence

    def gap(g):
        p = "-" if g["position_rms_m"] is None else f"{g['position_rms_m'] * 1e3:.3f} mm"
        d = "-" if g["delivery_error_pct"] is None else f"{g['delivery_error_pct']:.2f} %"
        return f"position RMS {p}, delivery error {d}"

    lines = [f"dataset {r['dataset']}: {len(r['runs'])} runs"]
    v = r.get("validation") or {}
    if v:
        lines += ["outputs of the baseline beyond their validation uncertainty (|E| > U_val, ASME V&V 20):"]
        lines += [f"  - {validation_sentence(b)}" for b in v.get("beyond", [])] or ["  none"]
    lines += ["disagreements of the baseline:"]
    lines += [f"  - {s}" for s in r["disagreements"]] or ["  none beyond the tolerances"]
    if r["effects_added"]:
        for name in r["effects_added"]:
            vals = values_text(r["parameters"][name], r.get("parameter_units", {}).get(name, {}))
            lines.append(f"added {name} ({r['targets'][name]}): {vals}")
    else:
        lines.append("no effect added: no candidate shrinks the held-out gap significantly")
    for d in r.get("indistinguishable") or []:
        lines.append(f"indistinguishable: {d['sentence']}")
    # the same three groups as the report's gap_bars.png: every run, the fitted ones, the held-out ones
    lines.append(f"gap before, all {len(r['runs'])} runs: {gap(r['gap_before'])}")
    lines.append(f"gap after,  all {len(r['runs'])} runs: {gap(r['gap_after'])}")
    fitted = r.get("fitted")
    if fitted and r["held_out"]:
        lines.append(f"fitted ({len(fitted['runs'])} runs): before {gap(fitted['gap_before'])}; "
                     f"after {gap(fitted['gap_after'])}")
    if r["held_out"]:
        held = r["held_out"]["runs"]
        lines.append(f"held out ({len(held)} runs: {', '.join(held)}): before {gap(r['held_out']['gap_before'])}; "
                     f"after {gap(r['held_out']['gap_after'])}")
    for s in (r.get("unexplained") or {}).get("sentences", []):
        lines.append(f"left unexplained: {s}")
    if r["report"]:
        lines.append(f"report: {r['report']}")
    return "\n".join(lines)
