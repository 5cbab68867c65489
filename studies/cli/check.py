"""``valvelab check GEOMETRY``: analytic vs beam, plate and solid FEA for one reed, side by side.

Given a pump model with disc valves instead (``thesis-disc``, ``my_pump.toml[:inlet|delivery]``), the
``fluid`` section: its fluid fidelities side by side (:mod:`studies.validation.fluid`).
"""

from __future__ import annotations

import sys

from geometry import PRESETS, load_reed
from geometry.errors import InputError
from studies.cli import flags
from studies.outputs import announce

HELP = ("multi-fidelity check of a reed (analytic, beam, plate and solid FEA) or of a disc-valve model's fluid "
        "(orifice laws, thin film, axisymmetric Navier-Stokes) with % deviations")
FIDELITY_NAMES = ("analytic", "beam", "plate", "solid")
#: studies.validation.reed_check.DEFAULT_TOLERANCE_PCT, for the help (importing that module imports the
#: models: seconds); tests/test_cli_startup.py keeps the two equal
DEFAULT_TOLERANCE_PCT = 4.0


def configure(p):
    """Add the arguments of ``valvelab check`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("geometry", help=f"preset ({', '.join(PRESETS)}) or reed TOML file")
    p.add_argument("--fidelities", default=",".join(FIDELITY_NAMES),
                   help="comma-separated subset of analytic,beam,plate,solid (default: all four)")
    p.add_argument("--tolerance-pct", type=flags.number("%", (0.0, 100.0), positive=True), default=DEFAULT_TOLERANCE_PCT,
                   help=f"flag deviations from the reference above this [%%] (default {DEFAULT_TOLERANCE_PCT:g})")
    p.add_argument("--mesh-size", type=flags.number("m", (1e-7, 10.0), positive=True), default=None,
                   help="FEA element size [m] for every FEA fidelity (default: each one's converged size)")
    p.add_argument("--modes", type=flags.integer(0, 50), default=4, metavar="N",
                   help="compare the first N natural frequencies across fidelities by nodal pattern "
                        "(default 4; 0: only omega_n)")
    p.add_argument("--convergence", action="store_true",
                   help="also run a mesh convergence study of each FEA fidelity (2h, h, h/2, refined further "
                        "when not asymptotic; slow)")
    p.add_argument("--out", default=None,
                   help="folder for plots (shapes, convergence) and VTU files of the solid modes")
    p.add_argument("--force", action="store_true", help="write into an existing folder valvelab did not make")
    p.add_argument("--dynamics", action="store_true",
                   help="instead of the fidelity check: the reed in the pump with one mode (eq 3.21), 1, 2, 3 and 6 "
                        "modes and the whole FE reed, on the six cases of Table 5.6, for this reed and five made "
                        "from it (twice and three times as long and half as thick, an off-axis port, a port near "
                        "the clamp, a heavy tip); how many modes each needs (slow: about 20 minutes on two "
                        "cores; the estimate is printed before it starts)")
    p.add_argument("--quick", action="store_true",
                   help="with --dynamics: this reed only, at the first case of Table 5.6 only: eq 3.21, 1, 2, 3 and "
                        "6 modes and the whole FE reed (under a minute on two cores)")
    p.add_argument("--markdown", action="store_true",
                   help="with --dynamics: print the study's tables in Markdown (also written to --out as "
                        "reed_dynamics.md)")
    p.add_argument("--revolutions", type=flags.integer(2, 50), default=3, metavar="N",
                   help="with --dynamics: revolutions per run (default 3)")


def _fidelities(text: str) -> tuple[str, ...]:
    fids = tuple(f.strip() for f in text.split(",") if f.strip())
    bad = [f for f in fids if f not in FIDELITY_NAMES]
    if not fids or bad:
        raise InputError("--fidelities", f"expected a comma-separated subset of {','.join(FIDELITY_NAMES)}, got {text!r}")
    return fids


def run(args) -> dict:
    """Run ``valvelab check``: multi-fidelity check of a reed: analytic, beam, plate and solid FEA with % deviations
    (the JSON of ``--json``; :mod:`studies.cli`)."""
    from studies.validation.fluid import disc_model_spec

    if disc_model_spec(args.geometry):
        from studies.validation.fluid import fluid_check

        return {"geometry": args.geometry, "fluid": fluid_check(args.geometry, progress=True)}
    reed = load_reed(args.geometry)
    if args.dynamics:
        return _run_dynamics(reed, args)
    for flag, given in (("--quick", args.quick), ("--revolutions", args.revolutions != 3),
                        ("--markdown", args.markdown)):
        if given:
            raise InputError(flag, "applies to the pump study (--dynamics)")
    fids = _fidelities(args.fidelities)
    from studies.cli.reed import check_modes_count
    from studies.validation.reed_check import check_as_json, multi_fidelity_check

    n_modes = check_modes_count(args.modes, allow_zero=True)
    out_dir = None
    if args.out is not None:
        from studies.outputs import prepare_output_dir

        out_dir = prepare_output_dir(args.out, "--out", args.force, kind="check")
    _announce_check(reed, fids, out_dir is not None, args.convergence)
    check = multi_fidelity_check(reed, fids, args.tolerance_pct, args.mesh_size, progress=True, modes=n_modes)
    result = check_as_json(check)
    result["geometry"] = args.geometry
    if args.convergence:
        from fea.convergence import convergence_study, default_sizes, plot_convergence

        studies = {}
        for fid in fids:
            if fid == "analytic":
                continue
            sizes = default_sizes(args.mesh_size) if args.mesh_size else None
            studies[fid] = convergence_study(reed, fid, sizes=sizes)
            if out_dir is not None:
                plot_convergence(studies[fid], out_dir / f"convergence_{fid}.png")
        result["convergence"] = studies
    if out_dir is not None:
        result["files"] = _write_outputs(reed, fids, args.mesh_size, out_dir)
    return result


def _announce_check(reed, fids: tuple, shapes: bool, convergence: bool) -> None:
    """Say what the fidelity check runs and about how long (studies.costs; the convergence study not counted)."""
    from studies import costs

    fea = [f for f in fids if f != "analytic"]
    units = {f"fea__{f}": 1 for f in fids}
    if shapes:
        units.update({f"shapes__{f}": 1 for f in fea})
    what = (f"reed {reed.name} by {', '.join(fids)}" + (f"; with --out the {', '.join(fea)} shapes and VTU files"
                                                         if shapes and fea else ""))
    basis = "measured per-solve costs at the default meshes"
    if convergence and fea:
        what += f"; then a mesh convergence study of {', '.join(fea)} (three meshes or more each)"
        basis += ", the convergence study not counted: minutes"
    announce("check", what, costs.estimate(**units), basis, always=convergence and bool(fea))


def _run_dynamics(reed, args) -> dict:
    """``--dynamics``: studies.validation.reed_dynamics for this reed and the five made from it."""
    from studies.validation import reed_dynamics as rd
    from studies.validation.chain import cases

    if args.convergence:
        raise InputError("--convergence", "belongs to the fidelity check, not the pump study (--dynamics)")
    out_dir = None
    if args.out is not None:
        from studies.outputs import prepare_output_dir

        out_dir = prepare_output_dir(args.out, "--out", args.force, kind="check")
    ops, reeds = cases(valve="reed"), rd.study_reeds(reed)
    if args.quick:
        ops, reeds = ops[:1], reeds[:1]
    numerics = not args.quick          # the fast stepper's check: a compilation on a fresh install
    announce("check", rd.plan_words(reeds, ops, args.revolutions, numerics=numerics),
             rd.estimate_seconds(reeds, ops, args.revolutions, numerics=numerics),
             "measured per-run costs" + ("; the fast stepper compiles once on a fresh install, about 2 min"
                                         if numerics else ""))
    study = rd.dynamics_study(reeds, ops, revolutions=args.revolutions, progress=True, traces=out_dir is not None,
                              numerics=numerics)
    result = {"geometry": args.geometry, "dynamics": rd.as_json(study)}
    if args.markdown:
        result["markdown"] = rd.markdown(study)
    if out_dir is not None:
        result["files"] = [str(p) for p in rd.write_outputs(study, out_dir)]
    return result


def _write_outputs(reed, fids, mesh_size, out_dir) -> list[str]:
    """Shapes of every FEA fidelity (static and free vibration) and VTU of the solid's modes."""
    import matplotlib

    from fea.fidelities import get

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from studies.plots import legend_outside

    files = []
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
    for fid in fids:
        if fid == "analytic":
            continue
        print(f"check {reed.name}: shapes and modes of {fid}", file=sys.stderr, flush=True)
        mod = get(fid).module
        kw = {"torsion": True} if fid == "solid" else {}
        r = mod.solve(reed, mesh_size, **kw)
        if fid == "plate":
            path = out_dir / "plate_modes.vtu"
            mod.write_modes_vtu(r, path)
            files.append(str(path))
        a1.plot(r.s * 1e3, r.psi_mode, label=f"{fid}: {r.omega_n:.0f} rad/s")
        a2.plot(r.s * 1e3, r.psi_static, label=f"{fid}: {r.kappa / 1e6:.3f} MPa/m")
        if fid == "solid":
            from fea.solid import write_modes_vtu

            path = out_dir / "solid_modes.vtu"
            write_modes_vtu(r, path)
            files.append(str(path))
    for ax, title in ((a1, "free vibration (first bending mode)"), (a2, "uniform load")):
        ax.set_xlabel("s [mm]")
        ax.set_title(title, fontsize=10)
        legend_outside(ax, fontsize=8)
        ax.grid(alpha=0.3)
    a1.set_ylabel("psi = v(s) / v(L) on the centre line [-]")
    fig.suptitle(f"reed {reed.name}")
    fig.tight_layout()
    path = out_dir / "shapes.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    files.append(str(path))
    files += [str(p) for p in sorted(out_dir.glob("convergence_*.png"))]
    return files


def render(r: dict) -> str:
    """The result of ``valvelab check`` as readable text."""
    if "fluid" in r:
        from studies.validation.fluid import render_check as render_fluid

        return render_fluid(r["fluid"])
    if "dynamics" in r:
        from studies.validation.reed_dynamics import render as render_dynamics

        head = r["markdown"] if "markdown" in r else render_dynamics(r["dynamics"])
        return "\n".join([head] + [f"wrote {f}" for f in r.get("files", [])])
    from studies.validation.reed_check import render_check

    text = render_check(r)
    for fid, st in r.get("convergence", {}).items():
        for q, c in st["quantities"].items():
            state = (f"p = {c['order']:.2f}" if c["reliable"] and c["order"] else c["note"])
            text += (f"\nconvergence {fid} {q}: {', '.join(f'{v:.6g}' for v in c['values'])} -> "
                     f"{c['extrapolated']:.6g} ({state}); error at the default mesh {c['default_error_pct']:.3f} %"
                     + ("" if c["reliable"] else " (UNRELIABLE)"))
        for note in st.get("notes", []):
            text += f"\n  note ({fid}): {note}"
    for f in r.get("files", []):
        text += f"\nwrote {f}"
    return text
