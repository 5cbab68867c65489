"""``valvelab optimize SPEC.toml --out DIR``: optimise model-file parameters against pump outputs (CONTRACT.md)."""

from __future__ import annotations

from studies.cli import flags
from studies.cli.sensitivity import run_study

HELP = ("optimise pump and valve parameters (NSGA-II for several objectives, differential evolution for one) over "
        "operating points with constraints; re-check the front with the solid FEA and the reference integrator; "
        "write the designs as model files")


def configure(p):
    """Add the arguments of ``valvelab optimize`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("spec", help="optimisation spec TOML (model, operating points, variables, run.objectives, "
                                "[constraints])")
    p.add_argument("--out", default=None, help="study folder (default: optimize-<spec name>); rerun to resume")
    flags.add_cluster_flags(p, "evaluations", "study")
    p.add_argument("--model", default=None, metavar="NAME|FILE", help="the base pump model, overriding the spec's")


def run(args) -> dict:
    """Run ``valvelab optimize``: optimise pump and valve parameters over operating points with constraints (the JSON
    of ``--json``; :mod:`studies.cli`)."""
    from studies.sweeps.design.optimize import run_optimize

    return run_study(args, "optimize", run_optimize)


def _f(v) -> str:
    return "-" if v is None else f"{v:#.5g}"


def render(r: dict) -> str:
    """The result of ``valvelab optimize`` as readable text."""
    objs = r["objectives"]
    n_pts = len(r["operating_points"])
    lines = [f"{r['algorithm']} optimisation of {r['model']}: {len(r['variables'])} variable"
             f"{'s' if len(r['variables']) != 1 else ''}, {r['generations']} generations of up to "
             f"{r['population']} designs: {r['evaluated_designs']} designs ({r['feasible_designs']} feasible) x "
             f"{n_pts} operating point{'s' if n_pts != 1 else ''} in {r['out']}",
             f"  computed {r['computed']} evaluations, already done {r['skipped']}; {r['wall_seconds']:.1f} s wall"
             + (f", {r['designs_per_hour']:.0f} evaluations/hour in the loop" if r["computed"] else "")]
    head = "  " + " ".join(f"{o['sense']} {o['aggregate']}({o['output']}) [{o['unit']}]".rjust(30) for o in objs)
    b = r.get("baseline")
    if b:
        lines.append(f"  baseline {b['name']}: " + ", ".join(f"{o['output']} = {_f(b['objectives'][o['output']])}"
                                                             for o in objs)
                     + ("" if b.get("constraints_met", True) else " (violates a constraint)"))
    lines.append(head)
    for d in r["designs"]:
        tag = ("front" if d["on_front"] else "dominated") + (", FEA-flagged" if d["fea_flagged"] else "") \
            + ("" if d["constraints_met"] else ", VIOLATES " + "; ".join(d["violations"])) \
            + (", dominates the baseline" if d.get("dominates_baseline") else "")
        lines.append(f"  {d['name']}" + " ".join(_f(d["objectives"][o["output"]]).rjust(30) for o in objs)
                     + f"  ({tag})")
    lines.append(f"  designs dominating the baseline: {r['dominating_baseline']} of {len(r['designs'])}")
    lines.append(f"  table: {r['files']['csv']}; front: {r['files'].get('front_plot')}")
    return "\n".join(lines)
