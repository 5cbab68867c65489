"""``valvelab table ID``: regenerate a thesis table, computed values beside the printed ones."""

from __future__ import annotations

from geometry.errors import InputError
from studies.tables import Table, registry

HELP = "regenerate a table of the thesis (computed values beside the thesis's)"
#: the tables that take seconds: what they run and its units of work (studies.costs); the others take less
COSTS = {"3.3": ("a solid FEA of each thesis reed", {"fea__solid": 4}),
         "3.9": ("a solid FEA of stepped reed #1", {"fea__solid": 1}),
         "3.11": ("a solid FEA of each thesis reed", {"fea__solid": 4}),
         "5.4": ("the six disc pump cases of Table 5.4 on the fast path", {"pump__fast": 6}),
         "5.6": ("the six reed pump cases of Table 5.6 on the fast path", {"pump__fast": 6})}

def configure(p):
    """Add the arguments of ``valvelab table`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("id", help="table id, e.g. 3.3, 3.8, 5.4")
    p.add_argument("--plot", default=None, metavar="FILE.png", help="also draw the table's figure (3.8: Figure 3.12)")
    p.add_argument("--force", action="store_true", help="let --plot replace an existing file")


def run(args) -> dict:
    """Run ``valvelab table``: regenerate a table of the thesis (computed values beside the thesis's) (the JSON of
    ``--json``; :mod:`studies.cli`)."""
    TABLES = registry()
    if args.id not in TABLES:
        # (0, int) before (1, str): "B.2" sorts after the numbered chapters instead of failing
        known = ", ".join(sorted(TABLES, key=lambda t: [(0, int(x), "") if x.isdigit() else (1, 0, x) for x in t.split(".")]))
        raise InputError("ID", f"no table {args.id!r}; expected one of {known}")
    plot = getattr(args, "plot", None)
    if plot is not None:
        if TABLES[args.id].figure is None:
            with_figure = ", ".join(t for t, v in TABLES.items() if v.figure is not None)
            raise InputError("--plot", f"table {args.id} has no figure; tables with one: {with_figure}")
        from studies.outputs import check_new_file
        from studies.plots import check_plot_suffix

        plot = check_new_file(check_plot_suffix(plot), "--plot", args.force)
    if args.id in COSTS:
        from studies import costs
        from studies.outputs import announce

        what, units = COSTS[args.id]
        announce("table", f"Table {args.id}: {what}", costs.estimate(**units),
                 "measured per-unit cost" + (costs.compile_note() if "pump__fast" in units else ""))
    out = TABLES[args.id].compute()
    if isinstance(out, list):
        out = {"rows": out}
    out = {"id": args.id, **out}
    if plot is not None:
        out["plot"] = str(TABLES[args.id].figure(plot))
    return out


def render(r: dict) -> str:
    """The result of ``valvelab table`` as readable text."""
    return Table.of(r, f"Table {r['id']}").to_text()
