"""``valvelab table ID``: regenerate a thesis table, computed values beside the printed ones."""

from __future__ import annotations

import importlib

from geometry.errors import InputError
from studies.outputs import format_cell

HELP = "regenerate a table of the thesis (computed values beside the thesis's)"

#: table id -> "module:function"; the function takes no arguments and returns a
#: list of row dicts (thesis values in fields named ``thesis_<field>``), or a dict
#: with ``rows`` and optional ``notes``.
TABLES: dict[str, str] = {
    "5.2": "studies.tables_lts:table_5_2",
    "B.2": "studies.tables_lts:table_b_2",
    "3.3": "studies.tables_fea:table_3_3",
    "3.8": "studies.tables_reed:table_3_8",
    "3.9": "studies.tables_fea:table_3_9",
    "3.11": "studies.tables_fea:table_3_11",
    "3.12": "studies.tables_reed:table_3_12",
    "3.13": "studies.tables_reed:table_3_13",
    "2.3": "studies.tables_pump:table_2_3",
    "5.4": "studies.tables_pump:table_5_4",
    "5.6": "studies.tables_pump:table_5_6",
}


#: table id -> "module:function(path)" drawing the figure that goes with it (``--plot``)
PLOTS: dict[str, str] = {
    "3.8": "studies.plots:figure_3_12",
}


def configure(p):
    p.add_argument("id", help="table id, e.g. 3.3, 3.8, 5.4")
    p.add_argument("--plot", default=None, metavar="FILE.png", help="also draw the table's figure (3.8: Figure 3.12)")
    p.add_argument("--force", action="store_true", help="let --plot replace an existing file")


def run(args) -> dict:
    if args.id not in TABLES:
        # (0, int) before (1, str): "B.2" sorts after the numbered chapters instead of failing
        known = ", ".join(sorted(TABLES, key=lambda t: [(0, int(x), "") if x.isdigit() else (1, 0, x) for x in t.split(".")]))
        raise InputError("ID", f"no table {args.id!r}; expected one of {known}")
    plot = getattr(args, "plot", None)
    if plot is not None:
        if args.id not in PLOTS:
            raise InputError("--plot", f"table {args.id} has no figure; tables with one: {', '.join(PLOTS)}")
        from studies.outputs import check_new_file
        from studies.plots import check_plot_suffix

        plot = check_new_file(check_plot_suffix(plot), "--plot", args.force)
    modname, func = TABLES[args.id].split(":")
    out = getattr(importlib.import_module(modname), func)()
    if isinstance(out, list):
        out = {"rows": out}
    out = {"id": args.id, **out}
    if plot is not None:
        modname, func = PLOTS[args.id].split(":")
        out["plot"] = str(getattr(importlib.import_module(modname), func)(plot))
    return out


def render(r: dict) -> str:
    rows = r["rows"]
    cols: list[str] = []
    for row in rows:
        cols += [k for k in row if k not in cols]
    cells = [[format_cell(row.get(c)) for c in cols] for row in rows]
    widths = [max(len(c), *(len(x[i]) for x in cells)) for i, c in enumerate(cols)]
    out = [f"Table {r['id']}", "  ".join(c.ljust(w) for c, w in zip(cols, widths))]
    out.append("  ".join("-" * w for w in widths))
    out += ["  ".join(x.ljust(w) for x, w in zip(line, widths)) for line in cells]
    out += [f"note: {n}" for n in r.get("notes", [])]
    return "\n".join(out)
