"""``valvelab gci V1,V2,V3 --cells N1,N2,N3``: the Grid Convergence Index of two or three solutions (Celik et al. 2008)."""

from __future__ import annotations

import math

from geometry.errors import InputError

HELP = ("Grid Convergence Index of two or three solutions, fine to coarse (Celik, Ghia and Roache 2008): observed "
        "order, extrapolated value, GCI of the fine and the second solution, asymptotic-range ratio")


def configure(p):
    """Add the arguments of ``valvelab gci`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("values", help="the solutions, fine to coarse, comma-separated: V1,V2,V3 (or V1,V2)")
    p.add_argument("--cells", default=None, metavar="N1,N2,N3",
                   help="cell (element, node) counts of the meshes, fine to coarse (decreasing)")
    p.add_argument("--sizes", default=None, metavar="H1,H2,H3",
                   help="representative sizes instead of --cells, fine to coarse (increasing), any unit")
    p.add_argument("--dim", type=int, default=2, help="dimension for h = (1/N)^(1/dim) from --cells (1, 2 or 3; default 2)")
    p.add_argument("--order", type=float, default=None,
                   help="two solutions only: the method's formal order assumed (default 2); Fs = 3")


def _numbers(text: str, flag: str, count: int | None = None) -> list[float]:
    parts = [t.strip() for t in str(text).split(",")]
    out = []
    for t in parts:
        try:
            x = float(t)
        except ValueError:
            raise InputError(flag, f"expected comma-separated numbers, got {t!r} in {text!r}") from None
        if not math.isfinite(x):
            raise InputError(flag, f"expected finite numbers, got {t!r}")
        out.append(x)
    if count is not None and len(out) != count:
        raise InputError(flag, f"expected {count} numbers (one per solution), got {len(out)}")
    return out


def run(args) -> dict:
    """Run ``valvelab gci``: the Grid Convergence Index of two or three solutions (Celik, Ghia and Roache 2008) (the
    JSON of ``--json``; :mod:`studies.cli`)."""
    from fea.convergence import gci, representative_sizes

    values = _numbers(args.values, "values")
    if len(values) not in (2, 3):
        raise InputError("values", f"expected two or three solutions (fine to coarse), got {len(values)}")
    if (args.cells is None) == (args.sizes is None):
        raise InputError("--cells", "give the meshes as --cells N1,N2,... or --sizes H1,H2,... (one of them)")
    if args.cells is not None:
        if args.dim not in (1, 2, 3):
            raise InputError("--dim", f"expected 1, 2 or 3, got {args.dim}")
        cells = _numbers(args.cells, "--cells", len(values))
        if any(c <= 0 or c != int(c) for c in cells):
            raise InputError("--cells", f"expected positive whole counts, got {args.cells}")
        if not all(a > b for a, b in zip(cells, cells[1:])):
            raise InputError("--cells", f"expected counts decreasing from the finest mesh to the coarsest, got {args.cells}")
        sizes = representative_sizes(cells, args.dim)
    else:
        sizes = _numbers(args.sizes, "--sizes", len(values))
        if any(h <= 0 for h in sizes):
            raise InputError("--sizes", f"expected positive sizes, got {args.sizes}")
        if not all(a < b for a, b in zip(sizes, sizes[1:])):
            raise InputError("--sizes", f"expected sizes increasing from the finest mesh to the coarsest, got {args.sizes}")
    order = None
    if len(values) == 2:
        order = 2.0 if args.order is None else args.order
        if not (math.isfinite(order) and order > 0):
            raise InputError("--order", f"expected a positive order, got {args.order}")
    elif args.order is not None:
        raise InputError("--order", "applies to two solutions; three give the observed order")
    g = gci(values, sizes=sizes, order=order)
    return {"order": g.order, "extrapolated": g.extrapolated, "gci_fine_pct": g.gci_fine_pct,
            "gci_coarse_pct": g.gci_coarse_pct, "asymptotic_ratio": g.asymptotic_ratio, "converging": g.converging,
            "values": list(g.values), "sizes": list(g.sizes), "ratios": list(g.ratios), "order_assumed": g.order_assumed,
            "safety_factor": g.safety_factor, "oscillatory": g.oscillatory,
            "approx_error_pct": list(g.approx_error_pct), "extrapolated_error_pct": g.extrapolated_error_pct,
            "note": g.note}


def render(r: dict) -> str:
    """The result of ``valvelab gci`` as readable text."""
    def f(x, spec=".4g"):
        return "-" if x is None else format(x, spec)

    return "\n".join([
        f"GCI of {', '.join(f'{v:g}' for v in r['values'])} (fine to coarse), ratios "
        + ", ".join(f"{x:.4g}" for x in r["ratios"]),
        f"  order          {f(r['order'], '.3f')}{' (assumed)' if r['order_assumed'] else ''}",
        f"  extrapolated   {f(r['extrapolated'], '.6g')}",
        f"  GCI fine       {f(r['gci_fine_pct'], '.3f')} %   GCI coarse {f(r['gci_coarse_pct'], '.3f')} %  (Fs = {r['safety_factor']:g})",
        f"  asymptotic     {f(r['asymptotic_ratio'], '.4f')} (about 1 in the asymptotic range)",
        f"  {r['note']}",
    ])
