"""``valvelab sweep-plot DIR``: main effects of a sweep (mean response against each factor)."""

from __future__ import annotations

from pathlib import Path

from geometry.errors import InputError
from studies.cli import flags
from studies.sweeps import sweep
from studies.outputs import check_new_file

HELP = "plot the main effects of a sweep's factors on its responses"


def configure(p):
    """Add the arguments of ``valvelab sweep-plot`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("folder", help="sweep folder written by valvelab sweep")
    p.add_argument("--response", action="append", default=None,
                   help="output column to plot (repeatable; default: the model's main responses)")
    p.add_argument("--bins", type=flags.integer(2, 100), default=8, help="quantile bins for a continuous factor (default 8)")
    p.add_argument("--output", default=None, help="PNG file (default: DIR/main_effects.png)")
    p.add_argument("--force", action="store_true", help="replace an existing plot file")


def main_effects_report(folder: Path, responses, png: Path, bins: int = 8, force: bool = False,
                        png_field: str = "--output") -> dict:
    """The main effects of a sweep, plotted to a PNG.

    Parameters
    ----------
    folder : pathlib.Path
        The sweep folder.
    responses : list of str or None
        The responses (default the model's ``MAIN_RESPONSES``).
    png : pathlib.Path
        The plot.
    bins : int
        Quantile bins of a sampled range.
    force : bool
        Replace an existing plot.
    png_field : str
        Names the plot path in messages (``--output``, or the folder when the plot goes there by default).

    Returns
    -------
    dict
        ``plot`` and per response and factor the means (:func:`studies.sweeps.main_effects.main_effects`).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(str(folder), "no such folder; expected a sweep folder written by valvelab sweep")
    png = Path(png)           # the output next: refused before any work
    # a plot in a valvelab folder may be replaced; its data (results, spec) never
    ours = (png.parent / ".valvelab-output").exists() and not png.is_dir() and png.suffix.lower() == ".png"
    check_new_file(png, png_field, force or ours)
    df, spec = sweep.read_results(folder)
    model = sweep.load_model(spec.model)
    numeric = [k for k, t in model.OUTPUTS.items() if t in ("float64", "int64")]
    responses = responses or list(getattr(model, "MAIN_RESPONSES", numeric[:3]))
    for r in responses:
        if r not in numeric:
            raise InputError("--response", f"{r!r} is not a numeric output of model {spec.model}; "
                                           f"expected one of {', '.join(numeric)}")
    if not (df["status"] == "ok").any():
        raise InputError(str(folder), "no design with status ok to plot")
    effects = sweep.main_effects(df, spec, responses, bins)
    units = dict(getattr(model, "UNITS", {}))
    if spec.model == "pump":
        from studies.sweeps.pump import input_units

        units.update(input_units([f.name for f in spec.factors], spec.fixed_dict))
    sweep.plot_main_effects(effects, png, title=f"{spec.model}: {len(df)} designs ({spec.sampler})", units=units)
    return {"plot": str(png), "designs": int(len(df)), "ok": int((df["status"] == "ok").sum()), "effects": effects}


def run(args) -> dict:
    """Run ``valvelab sweep-plot``: plot the main effects of a sweep's factors on its responses (the JSON of
    ``--json``; :mod:`studies.cli`)."""
    folder = Path(args.folder)
    png = Path(args.output) if args.output else folder / "main_effects.png"
    field = "--output" if args.output else f"{folder} (its main_effects.png)"
    return {"folder": str(folder), **main_effects_report(folder, args.response, png, args.bins, args.force, field)}


def render(r: dict) -> str:
    """The result of ``valvelab sweep-plot`` as readable text."""
    lines = [f"main effects of {r['folder']} ({r['ok']} of {r['designs']} designs ok): {r['plot']}"]
    for resp, per in r["effects"].items():
        ranked = sorted(per.items(), key=lambda kv: -kv[1]["span"])
        lines.append(f"  {resp}: " + ", ".join(f"{f} {e['span']:.4g}" for f, e in ranked))
    return "\n".join(lines)
