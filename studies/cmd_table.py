"""``valvelab table ID``: regenerate a thesis table, computed values beside the printed ones."""

from __future__ import annotations

import importlib

from geometry.errors import InputError

HELP = "regenerate a table of the thesis (computed values beside the thesis's)"

#: table id -> "module:function"; the function takes no arguments and returns a
#: list of row dicts (thesis values in fields named ``thesis_<field>``), or a dict
#: with ``rows`` and optional ``notes``.
TABLES: dict[str, str] = {}
TABLES["3.3"] = "studies.tables_fea:table_3_3"
TABLES["3.9"] = "studies.tables_fea:table_3_9"
TABLES["3.11"] = "studies.tables_fea:table_3_11"


def configure(p):
    p.add_argument("id", help="table id, e.g. 3.3, 3.8, 5.4")


def run(args) -> dict:
    if args.id not in TABLES:
        known = ", ".join(sorted(TABLES, key=lambda t: [int(x) if x.isdigit() else x for x in t.split(".")]))
        raise InputError("ID", f"no table {args.id!r}; expected one of {known}")
    modname, func = TABLES[args.id].split(":")
    out = getattr(importlib.import_module(modname), func)()
    if isinstance(out, list):
        out = {"rows": out}
    return {"id": args.id, **out}


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def render(r: dict) -> str:
    rows = r["rows"]
    cols: list[str] = []
    for row in rows:
        cols += [k for k in row if k not in cols]
    cells = [[_fmt(row.get(c)) for c in cols] for row in rows]
    widths = [max(len(c), *(len(x[i]) for x in cells)) for i, c in enumerate(cols)]
    out = [f"Table {r['id']}", "  ".join(c.ljust(w) for c, w in zip(cols, widths))]
    out.append("  ".join("-" * w for w in widths))
    out += ["  ".join(x.ljust(w) for x, w in zip(line, widths)) for line in cells]
    out += [f"note: {n}" for n in r.get("notes", [])]
    return "\n".join(out)
