"""``valvelab sensitivity SPEC.toml --out DIR``: Sobol indices or Morris screening of pump outputs (CONTRACT.md)."""

from __future__ import annotations

import sys
from pathlib import Path

from studies.cli import flags

HELP = ("global sensitivity of pump outputs to model parameters: Sobol indices with bootstrap intervals or Morris "
        "screening (SALib), run on a dask cluster, resumable")


def configure(p):
    """Add the arguments of ``valvelab sensitivity`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("spec", help="sensitivity spec TOML (model, operating points, variables, run.outputs)")
    p.add_argument("--out", default=None, help="study folder (default: sensitivity-<spec name>); rerun to resume")
    flags.add_cluster_flags(p, "evaluations", "study")
    p.add_argument("--model", default=None, metavar="NAME|FILE", help="the base pump model, overriding the spec's")


def run_study(args, command: str, runner) -> dict:
    """Run a design study from the command line: check the flags, load the spec, run it into its folder.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (``spec``, ``--out``, ``--model`` and the cluster flags).
    command : str
        ``sensitivity`` or ``optimize``.
    runner : callable
        ``runner(spec, out, scheduler=..., workers=..., batch_size=..., force=..., progress=...)``
        (:func:`studies.sweeps.design.sensitivity.run_sensitivity`, ``optimize.run_optimize``).

    Returns
    -------
    dict
        The study's summary.
    """
    from studies.sweeps.design.spec import load_spec

    flags.check_cluster_flags(args)
    spec = load_spec(args.spec, command, model_override=args.model)
    out = Path(args.out) if args.out else Path(f"{command}-{Path(args.spec).stem}")
    from studies.outputs import check_inputs_outside

    check_inputs_outside(out, "--out", {"SPEC": args.spec, "the model file": spec.model}, own=("spec.toml",))
    try:
        return runner(spec, out, scheduler=args.scheduler, workers=args.workers, batch_size=args.batch_size,
                      force=args.force, progress=not args.no_progress)
    except KeyboardInterrupt:
        sys.stderr.write(f"{command} interrupted: the evaluations finished so far are in {out}; "
                         "rerun the same command to resume (nothing finished is recomputed)\n")
        raise


def run(args) -> dict:
    """Run ``valvelab sensitivity``: global sensitivity of pump outputs to model parameters (Sobol or Morris) (the JSON
    of ``--json``; :mod:`studies.cli`)."""
    from studies.sweeps.design.sensitivity import run_sensitivity

    return run_study(args, "sensitivity", run_sensitivity)


def render(r: dict) -> str:
    """The result of ``valvelab sensitivity`` as readable text."""
    from studies.sweeps.design.sensitivity import describe_index

    lines = [f"{r['method']} sensitivity of {r['model']}: {len(r['variables'])} variables, {r['designs']} designs x "
             f"{len(r['operating_points'])} operating points = {r['evaluations']} evaluations in {r['out']}",
             f"  computed {r['computed']}, already done {r['skipped']}, failed {r['failed']}; "
             f"{r['wall_seconds']:.1f} s wall"
             + (f", {r['designs_per_hour']:.0f} evaluations/hour" if r["computed"] else "")]
    keys = ("S1", "ST") if r["method"] == "sobol" else ("mu_star", "sigma")
    by = {}
    for x in r["indices"]:
        by.setdefault((x["output"], x["operating_point"]), []).append(x)
    for (o, pt), rows in by.items():
        rows.sort(key=lambda x: -(x.get(keys[1] if r["method"] == "sobol" else keys[0]) or -1e300))
        lines.append(f"  {o} at {pt}:")
        for x in rows:
            lines.append(f"    {x['variable']:45s} {keys[0]} {describe_index(x[keys[0]]):>8s}  "
                         f"{keys[1]} {describe_index(x[keys[1]]):>8s}")
    lines.append(f"  table: {r['files']['markdown']}")
    return "\n".join(lines)
