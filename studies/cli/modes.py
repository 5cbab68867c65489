"""``valvelab modes``: natural frequencies and mode shapes of reeds at any fidelity (plots, VTU)."""

from __future__ import annotations

import sys

from geometry import THESIS_PRESETS, load_reed
from studies.cli import flags

HELP = "natural frequencies and mode shapes of reeds at any fidelity: plots of every mode and VTU files"

#: modes computed per reed unless --modes says otherwise
DEFAULT_MODES = 6


def configure(p):
    """Add the arguments of ``valvelab modes`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("geometries", nargs="*", default=list(THESIS_PRESETS),
                   help="presets or reed TOML files (default: the four thesis reeds)")
    p.add_argument("--fidelity", default="solid", help="analytic, beam, plate or solid (default solid)")
    p.add_argument("--modes", type=flags.integer(1, 50), default=DEFAULT_MODES, metavar="N",
                   help=f"number of modes per reed (default {DEFAULT_MODES})")
    p.add_argument("--out", default="out/modes", help="output folder (default out/modes)")
    p.add_argument("--force", action="store_true", help="write into an existing folder valvelab did not make")
    p.add_argument("--mesh-size", type=flags.number("m", (1e-7, 10.0), positive=True), default=None,
                   help="FEA element size [m] (default: converged size scaled to each reed)")


def _shapes(fidelity, mod, result, reed, n):
    """(s [m], y [m] (ns, ny), w (n, ns, ny)) of the first n modes, each max |w| = 1."""
    import numpy as np

    if fidelity == "analytic":
        w = result.shapes[:, :n].T
        return result.s, np.zeros((len(result.s), 1)), w[:, :, None]
    ms = mod.mode_shapes(result, reed, n)
    return ms.s, ms.y, ms.w


def run(args) -> dict:

    """Run ``valvelab modes``: natural frequencies and mode shapes of reeds at any fidelity: plots of every mode and
    VTU files (the JSON of ``--json``; :mod:`studies.cli`)."""
    from fea.fidelities import get as get_fidelity
    from studies.cli.reed import check_modes_count
    from studies.outputs import prepare_output_dir
    from studies.plots import plot_mode_shapes
    from studies.tables.fea import figure_3_12

    n = check_modes_count(args.modes)
    mod = get_fidelity(args.fidelity).module
    reeds = [load_reed(g) for g in args.geometries]  # validate every input before writing
    if args.mesh_size is not None and args.fidelity != "analytic":
        from fea.mesh import check_size

        for reed in reeds:
            check_size(reed, args.mesh_size)
    out = prepare_output_dir(args.out, "--out", args.force, kind="modes")
    from studies import costs
    from studies.outputs import announce

    announce("modes", f"{n} modes of {len(reeds)} reed{'s' if len(reeds) > 1 else ''} ({', '.join(args.geometries)}) "
                      f"at the {args.fidelity} fidelity: each reed's plot and VTU file, then Figure 3.12 from "
                      "every reed again", costs.estimate(**{f"modes__{args.fidelity}": 2 * len(reeds)}),
             "measured per-reed cost at the default mesh")
    files, modes = [], {}
    for k, (g, reed) in enumerate(zip(args.geometries, reeds)):
        print(f"modes: {args.fidelity} {reed.name} ({n} modes; reed {k + 1}/{len(reeds)})", file=sys.stderr,
              flush=True)
        _, result = mod.properties_and_modes(reed, n, mesh_size=args.mesh_size)
        freqs, labels = result.first(n)
        families = getattr(result, "kinds", ["bending"] * len(labels))
        modes[g] = [{"omega": w, "kind": k, "label": lab} for w, k, lab in zip(freqs, families, labels)]
        if args.fidelity != "analytic":
            path = out / f"{reed.name}_{args.fidelity}_modes.vtu"
            if args.fidelity == "beam":
                mod.write_modes_vtu(result, reed, path)
            else:
                mod.write_modes_vtu(result, path)
            files.append(str(path))
        s, y, w = _shapes(args.fidelity, mod, result, reed, n)
        png = plot_mode_shapes(out / f"{reed.name}_{args.fidelity}_mode_shapes.png", reed, s, y, w, freqs, labels,
                               title=f"reed {reed.name}: first {n} modes ({args.fidelity})")
        files.append(str(png))
    fig = out / "mode_shapes.png"
    figure_3_12(fig, reeds=args.geometries, mesh_size=args.mesh_size, fidelity=args.fidelity)
    files.append(str(fig))
    return {"fidelity": args.fidelity, "modes": modes, "files": files}


def render(r: dict) -> str:
    """The result of ``valvelab modes`` as readable text."""
    lines = []
    for g, ms in r["modes"].items():
        lines.append(f"{g} ({r.get('fidelity', 'solid')}): " + ", ".join(f"{m['omega']:.5g} rad/s {m['label']}" for m in ms))
    lines += [f"wrote {f}" for f in r["files"]]
    return "\n".join(lines)
