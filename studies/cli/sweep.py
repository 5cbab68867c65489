"""``valvelab sweep SPEC.toml --out DIR``: a design sweep on dask, resumable (CONTRACT.md, "Sweeps")."""

from __future__ import annotations

import sys
from pathlib import Path

from studies.cli import flags
from studies.sweeps import sweep

HELP = "run (or resume) a design-of-experiments sweep on a dask cluster"


def configure(p):
    """Add the arguments of ``valvelab sweep`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("spec", help="sweep TOML file (model, sampler, factors, fixed inputs)")
    p.add_argument("--out", default=None, help="sweep folder (default: sweep-<spec name>); rerun to resume")
    p.add_argument("--format", default="parquet", choices=sweep.FORMATS, help="results table format")
    flags.add_cluster_flags(p, "designs", "sweep")
    p.add_argument("--retry-failed", action="store_true", help="recompute designs recorded with status error")
    p.add_argument("--plot", action="store_true", help="also write main_effects.png into the sweep folder")
    p.add_argument("--model", default=None, metavar="NAME|FILE",
                   help="pump sweeps: the base pump model (a shipped one or a model file), overriding the spec's")


def run(args) -> dict:
    """Run ``valvelab sweep``: run (or resume) a design-of-experiments sweep on a dask cluster (the JSON of ``--json``;
    :mod:`studies.cli`)."""
    spec = sweep.load_spec(args.spec)
    if args.model is not None:
        spec = sweep.with_base_model(spec, args.model)
    out = Path(args.out) if args.out else Path(f"sweep-{Path(args.spec).stem}")
    from studies.outputs import check_inputs_outside

    model = spec.fixed_dict.get("model")
    check_inputs_outside(out, "--out", {"SPEC": args.spec, "the model file": model if isinstance(model, str) else None},
                         own=(sweep.SPEC_FILE,))
    flags.check_cluster_flags(args)
    try:
        summary = sweep.run_sweep(
            spec, out, fmt=args.format, scheduler=args.scheduler, n_workers=args.workers,
            batch_size=args.batch_size, force=args.force, retry_failed=args.retry_failed,
            progress=not args.no_progress,
        )
    except KeyboardInterrupt:
        sys.stderr.write(f"sweep interrupted: the designs finished so far are in {out}; "
                         "rerun the same command to resume\n")
        raise
    summary["warnings"] = table_warnings(out)
    if args.plot and summary["complete"]:
        from studies.cli.sweep_plot import main_effects_report

        summary["main_effects"] = main_effects_report(out, None, out / "main_effects.png", force=True)
    return summary


def table_warnings(folder) -> list[dict]:
    """The validity warnings of a sweep folder's designs, one entry per code.

    Parameters
    ----------
    folder : str or os.PathLike
        A sweep folder.

    Returns
    -------
    list of dict
        Count and first message per code ([] for a model without a ``warnings`` column).
    """
    from studies.sweeps.pump import summarize_warnings

    df, _ = sweep.read_results(folder)
    if "warnings" not in df.columns or not len(df):
        return []
    return summarize_warnings(zip((f"design {int(i)}" for i in df["design_id"]), df["warnings"]))


def render(r: dict) -> str:
    """The result of ``valvelab sweep`` as readable text."""
    lines = [
        f"sweep of {r['designs']} designs ({r['model']}, {r['sampler']}) in {r['out']}",
        f"  computed {r['computed']}, already done {r['skipped']}, failed {r['failed']}",
        "  status: " + ", ".join(f"{k} {v}" for k, v in r["status_counts"].items()),
        f"  {r['wall_seconds']:.1f} s wall" + (f", {r['designs_per_hour']:.0f} designs/hour" if r["computed"] else ""),
        f"  results: {r['results']}" + ("" if r["complete"] else " (incomplete: rerun to resume)"),
    ]
    if "main_effects" in r:
        lines.append(f"  main effects: {r['main_effects']['plot']}")
    return "\n".join(lines)
