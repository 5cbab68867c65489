"""``valvelab modes --out DIR``: mode-shape figure (cf. thesis Figure 3.12) and VTU files of the solid modes."""

from __future__ import annotations

import sys

from geometry import load_reed

HELP = "mode shapes of reeds (Figure 3.12 style plot) and VTU files of their 3-D solid modes"


def configure(p):
    p.add_argument("geometries", nargs="*", default=["uniform", "stepped1", "stepped2", "prototype"],
                   help="presets or reed TOML files (default: the four thesis reeds)")
    p.add_argument("--out", default="out/modes", help="output folder (default out/modes)")
    p.add_argument("--force", action="store_true", help="write into an existing folder valvelab did not make")
    p.add_argument("--mesh-size", type=float, default=None, help="solid element size [m] (default: converged)")


def run(args) -> dict:
    from fea.solid import solve, write_modes_vtu
    from geometry.errors import InputError

    from .outputs import prepare_output_dir
    from .tables_fea import figure_3_12

    if args.mesh_size is not None and not args.mesh_size > 0:
        raise InputError("--mesh-size", f"must be a positive length in m, got {args.mesh_size}")
    reeds = [load_reed(g) for g in args.geometries]  # validate every input before writing
    out = prepare_output_dir(args.out, "--out", args.force)
    files, modes = [], {}
    for g, reed in zip(args.geometries, reeds):
        print(f"modes: solid {reed.name} (bending and torsion)", file=sys.stderr, flush=True)
        r = solve(reed, args.mesh_size, torsion=True)
        path = out / f"{reed.name}_solid_modes.vtu"
        write_modes_vtu(r, path)
        files.append(str(path))
        modes[g] = [{"omega": float(w), "kind": k} for w, k in zip(r.omega, r.kinds)]
    fig = out / "mode_shapes.png"
    figure_3_12(fig, reeds=args.geometries, mesh_size=args.mesh_size)
    files.append(str(fig))
    return {"modes": modes, "files": files}


def render(r: dict) -> str:
    lines = []
    for g, ms in r["modes"].items():
        lines.append(f"{g}: " + ", ".join(f"{m['omega']:.0f} rad/s {m['kind']}" for m in ms))
    lines += [f"wrote {f}" for f in r["files"]]
    return "\n".join(lines)
