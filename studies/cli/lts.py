"""``valvelab lts``: the laser triangulation sensor's actual scale factor through air, PMMA and oil.

Computes C_act (section 5.3, eqs 5.1-5.10) and its eq 5.11 uncertainty for the thesis
manifolds or a user's setup (flags or a TOML file), optionally converts a CSV column of
sensor voltages to positions (a new file, never overwriting one) and plots x_act vs dV.
"""

from __future__ import annotations

import csv
import io
import math
import sys
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

from geometry import validate
from geometry.declare import read_table, spec_of
from geometry.errors import InputError
from instruments import lts
from studies.cli import flags
from studies.outputs import check_distinct, check_new_file

HELP = "laser triangulation scale factor through air, PMMA and oil (section 5.3); voltage -> position"

#: flag -> (LtsSetup field, factor to SI)
_OVERRIDES = {
    "apparent_scale_mm_per_v": ("apparent_scale", 1e-3),
    "c1_mm": ("c1", 1e-3),
    "c2_mm": ("c2", 1e-3),
    "standoff_mm": ("standoff", 1e-3),
    "n_air": ("n_air", 1.0),
    "n_window": ("n_window", 1.0),
    "n_fluid": ("n_fluid", 1.0),
    "air_gap_mm": ("air_gap", 1e-3),
    "window_mm": ("window_thickness", 1e-3),
}
_FIELDS = [f.name for f in fields(lts.LtsSetup)]
#: fields a setup file must give; the rest default to the thesis's sensor and materials
_REQUIRED = ("air_gap", "window_thickness")


def configure(p):
    """Add the arguments of ``valvelab lts`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("setup", nargs="?", default="all",
                   help="disc_inlet, disc_delivery, reed, all (default) or a setup TOML file ([lts] table)")
    g = p.add_argument_group("override an input (applies to every selected setup)")
    for flag, (name, factor) in _OVERRIDES.items():
        spec = spec_of(lts.LtsSetup, name)
        unit = {1e-3: spec.unit.replace("m", "mm", 1)}.get(factor, spec.unit)
        g.add_argument("--" + flag.replace("_", "-"), help=f"{spec.doc or name} [{unit}]",
                       type=flags.number(unit, tuple(b / factor for b in spec.bounds), positive=spec.positive))
    p.add_argument("--indices", choices=lts.INDEX_SOURCES, default="table_b_2",
                   help="n_o, n_p of the thesis setups: as printed in Table B.2 (default) or recomputed "
                        "from Table B.1 by eq B.2 (appendix_b)")
    p.add_argument("--x-max-mm", type=flags.number("mm", (1e-3, 100.0), positive=True), default=None, help="largest actual displacement of the fit [mm] (1.2)")
    p.add_argument("--points", type=flags.integer(3, 10_001), default=None, help="points of the least-squares fit (11)")
    c = p.add_argument_group("convert your own sensor voltages")
    c.add_argument("--voltages", metavar="CSV", help="CSV file with a column of sensor voltages [V]")
    c.add_argument("--column", help="name of the voltage column (needed when the CSV has several)")
    c.add_argument("--zero-voltage", type=flags.number("V", (-1e3, 1e3)), default=0.0,
                   help="voltage at the zero position; dV = V - this [V] (default 0)")
    c.add_argument("--exact", action="store_true",
                   help="invert eqs 5.7-5.9 exactly instead of the linear eq 5.10")
    c.add_argument("--out", metavar="CSV", help="output file (default: <input>_position.csv beside the input)")
    p.add_argument("--plot", metavar="PNG", help="plot x_act vs voltage (like Figures 5.3, 5.4)")
    p.add_argument("--force", action="store_true", help="replace an existing output file")


# ------------------------------------------------------------------ setups

def load_setup_file(path: Path, indices: str = "table_b_2") -> tuple[str, lts.LtsSetup, dict]:
    """A setup from a TOML file with an ``[lts]`` table (SI) and an optional ``[lts.uncertainty]``.

    Parameters
    ----------
    path : pathlib.Path
    indices : str
        Where the refractive indices of the keys not given come from (:func:`instruments.lts.thesis_setup`).

    Returns
    -------
    tuple
        (name, :class:`instruments.lts.LtsSetup`, {input: absolute uncertainty}).
    """
    if not path.exists():
        raise InputError(str(path), "no such file; expected disc_inlet, disc_delivery, reed, all or a setup TOML file")
    data = validate.read_toml(path, str(path))
    validate.keys(data, ("lts",), str(path), required=("lts",))
    t = data["lts"]
    if not isinstance(t, dict):
        raise InputError("lts", "expected a table [lts]")
    base, deltas = lts.thesis_setup("disc_inlet", indices=indices)
    unc = t.pop("uncertainty", {})
    name = t.pop("name", path.stem)
    if not isinstance(name, str):
        raise InputError("lts.name", f"expected a string, got {name!r}")
    vals = read_table(lts.LtsSetup, t, "lts")        # a misspelt key first: it names the key it meant
    for k in _REQUIRED:
        if k not in t:
            raise InputError(f"lts.{k}", "missing; expected a length in m")
    validate.keys(unc, _FIELDS, "lts.uncertainty")
    for k, v in unc.items():
        deltas[k] = validate.number(v, f"lts.uncertainty.{k}", unit=spec_of(lts.LtsSetup, k).unit, bounds=(0.0, 1.0))
    setup = replace(base, **vals)
    _validate(setup, "lts.")
    return name, setup, deltas


def _validate(setup, prefix):
    lts.validate(setup, prefix)
    try:
        lts.oil_gap(setup)
    except InputError as exc:
        raise InputError(prefix + exc.field, exc.message) from None


def select_setups(args) -> list[tuple[str, lts.LtsSetup, dict]]:
    """The setups to analyse: thesis manifolds or a file, with the command line's overrides applied.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    list of tuple
        (name, setup, uncertainties) each.
    """
    if args.setup == "all":
        chosen = [(m, *lts.thesis_setup(m, indices=args.indices)) for m in lts.MANIFOLDS]
    elif args.setup in lts.MANIFOLDS:
        chosen = [(args.setup, *lts.thesis_setup(args.setup, indices=args.indices))]
    else:
        chosen = [load_setup_file(Path(args.setup), args.indices)]
    over = {}
    for flag, (name, factor) in _OVERRIDES.items():
        v = getattr(args, flag)
        if v is not None:
            over[name] = (v * factor, "--" + flag.replace("_", "-"))
    out = []
    for name, setup, deltas in chosen:
        if over:
            setup = replace(setup, **{k: v for k, (v, _) in over.items()})
            try:
                lts.validate(setup)
                lts.oil_gap(setup)
            except InputError as exc:
                flag = over.get(exc.field, (None, exc.field))[1]
                raise InputError(flag, exc.message) from None
        out.append((name, setup, deltas))
    return out


# --------------------------------------------------------------- conversion

def _read_voltages(path: Path, column: str | None) -> tuple[list[str], list[list[str]], str, np.ndarray]:
    """(header, rows as text, column name, voltages [V]) of a CSV; the rows are kept verbatim for the output."""
    text = validate.read_text(path, "--voltages")
    try:
        table = [r for r in csv.reader(io.StringIO(text, newline="")) if r]
    except csv.Error as exc:
        raise InputError(str(path), f"not a readable CSV ({exc})") from None
    if len(table) < 2:
        raise InputError(str(path), "needs a header row and at least one data row")
    header, rows = validate.columns(table[0], str(path)), table[1:]
    if column is None:
        if len(header) != 1:
            raise InputError("--column", "the CSV has several columns (" + ", ".join(header) + "); name the voltage column")
        column = header[0]
    if column not in header:
        raise InputError("--column", f"no column {column!r} in {path}; columns: " + ", ".join(header))
    if "position_m" in header:
        raise InputError(str(path), "already has a column 'position_m'; rename it first")
    j = header.index(column)
    v = np.empty(len(rows))
    for i, r in enumerate(rows):
        try:
            v[i] = float(r[j])
        except (IndexError, ValueError):
            v[i] = np.nan
        if not math.isfinite(v[i]):
            raise InputError(f"{path}: {column}", f"line {i + 2} is not a finite number "
                                                  f"({r[j] if j < len(r) else 'missing'!r})")
    return header, rows, column, v


def _output_path(args) -> Path:
    """The conversion's output file, checked before any work: new, or ours with --force, never the input."""
    src = Path(args.voltages)
    out = Path(args.out) if args.out else src.with_name(src.stem + "_position.csv")
    if out.resolve() == src.resolve():
        raise InputError("--out", f"{out} is the input file; refusing to overwrite it")
    return check_new_file(out, "--out", args.force)


def convert(args, out: Path, name: str, setup: lts.LtsSetup, scale: float, x_max: float) -> dict:
    """Convert a CSV of sensor voltages to positions: the input's columns plus ``position_m``.

    Parameters
    ----------
    args : argparse.Namespace
        ``--voltages``, ``--column``, ``--zero-voltage`` [V], ``--exact``.
    out : pathlib.Path
        The output CSV.
    name : str
        The setup's name.
    setup : instruments.lts.LtsSetup
    scale : float
        C_act [m/V] (eq 5.10).
    x_max : float
        The fitted range's end [m] (positions beyond it are counted: eq 5.10 extrapolates).

    Returns
    -------
    dict
        The conversion's summary (rows, method, scale, the positions' range [m], how many lie outside).
    """
    src = Path(args.voltages)
    header, rows, column, v = _read_voltages(src, args.column)
    x = lts.position_from_voltage(setup, v - args.zero_voltage, exact=args.exact, scale=scale)
    outside = int(np.sum((x < 0) | (x > x_max)))
    if outside:
        sys.stderr.write(f"valvelab lts: warning: {outside} of {len(x)} positions lie outside the fitted range "
                         f"0-{x_max * 1e3:g} mm{'' if args.exact else ' (eq 5.10 extrapolates)'}\n")
    with out.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([*header, "position_m"])
        w.writerows([*r, f"{xi:.9g}"] for r, xi in zip(rows, x))
    return {
        "setup": name, "input": str(src), "column": column, "output": str(out), "rows": int(len(x)),
        "method": "exact (eqs 5.7-5.9 inverted)" if args.exact else "linear (eq 5.10)",
        "scale_factor_m_per_v": scale, "zero_voltage_v": args.zero_voltage,
        "position_min_m": float(x.min()), "position_max_m": float(x.max()),
        "outside_fitted_range": outside,
    }


# ------------------------------------------------------------------ plotting

def plot(path: Path, results: list[dict], setups: dict) -> None:
    """Draw x_act [mm] against dV [V] with the least-squares line for each setup, and the residuals (Figures 5.3, 5.4).

    Parameters
    ----------
    path : pathlib.Path
        The image file.
    results : list of dict
        :func:`instruments.lts.analyse`'s results with their ``setup`` name.
    setups : dict
        {name: LtsSetup}.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from studies.plots import legend_outside

    fig, (ax, ar) = plt.subplots(2, 1, figsize=(6.4, 6.4), sharex=True, height_ratios=(2, 1))
    for r, marker in zip(results, "os^dv<>"):
        s = setups[r["setup"]]
        x, v = lts.sweep(s, r["x_max_m"], r["points"])
        fit = r["scale_factor_m_per_v"] * v + r["intercept_m"]
        line = ax.plot(v, x * 1e3, marker, ms=5, mfc="none")[0]
        ax.plot(v, fit * 1e3, "-", lw=1, color=line.get_color(),
                label=f"{r['setup']}: C_act = {r['scale_factor_m_per_v'] * 1e3:.4f} mm/V "
                      f"(+/-{r['uncertainty_pct']:.2f} %)")
        ar.plot(v, (x - fit) * 1e6, marker + "-", ms=4, mfc="none", color=line.get_color())
    ax.set_ylabel("actual change in position x_act [mm]")
    ax.set_title("LTS actual scale factor through air, PMMA and oil (eqs 5.1-5.10)")
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=8)
    ar.set_xlabel("sensor voltage change dV [V]")
    ar.set_ylabel("x_act - fit [um]")
    ar.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ----------------------------------------------------------------------- run

def _implausible(args, chosen) -> list[dict]:
    """``implausible_input`` warnings: a setup's value outside what real setups use (a value in m given to a flag in
    mm: ``--air-gap-mm 0.09067``), naming the flag that set it, else the setup's key."""
    from geometry.declare import atypical

    flag_of = {name: "--" + flag.replace("_", "-") for flag, (name, _) in _OVERRIDES.items()
               if getattr(args, flag, None) is not None}
    out = []
    for setup_name, setup, _ in chosen:
        for key, msg in atypical(setup, "lts"):
            field = key.split(".", 1)[1]
            out.append({"code": "implausible_input", "message": f"{setup_name}: {flag_of.get(field, key)}: {msg}"})
    return out


def run(args) -> dict:
    """Run ``valvelab lts``: laser triangulation scale factor through air, PMMA and oil (section 5.3); voltage ->
    position (the JSON of ``--json``; :mod:`studies.cli`)."""
    x_max = None if args.x_max_mm is None else args.x_max_mm * 1e-3
    out = (Path(args.out) if args.out else Path(args.voltages).with_name(Path(args.voltages).stem + "_position.csv")) \
        if args.voltages else None
    check_distinct({"--plot": args.plot, "--out": out}, {"--voltages": args.voltages, "SETUP": args.setup})
    plot_path = check_new_file(args.plot, "--plot", args.force) if args.plot else None
    out_path = _output_path(args) if args.voltages else None
    chosen = select_setups(args)
    if args.voltages and len(chosen) != 1:
        raise InputError("--voltages", "converting voltages needs one setup: disc_inlet, disc_delivery, reed "
                                       "or a setup TOML file")
    if args.voltages:  # read (and check) the voltages before the slower analysis
        _read_voltages(Path(args.voltages), args.column)
    results = []
    for i, (name, setup, deltas) in enumerate(chosen):
        sys.stderr.write(f"valvelab lts: {name} ({i + 1}/{len(chosen)})\n")
        results.append({"setup": name, **lts.analyse(setup, deltas, x_max, args.points)})
    out = {"setups": results, "warnings": _implausible(args, chosen)}
    if args.voltages:
        name, setup, _ = chosen[0]
        out["conversion"] = convert(args, out_path, name, setup, results[0]["scale_factor_m_per_v"],
                                    results[0]["x_max_m"])
    if plot_path is not None:
        plot(plot_path, results, {n: s for n, s, _ in chosen})
        out["plot"] = str(plot_path)
    return out


def render(r: dict) -> str:
    """The result of ``valvelab lts`` as readable text."""
    lines = ["LTS actual scale factor, x_act = C_act dV (eq 5.10); uncertainty by eq 5.11",
             f"{'setup':<16}{'C_act mm/V':>11}{'+/- mm/V':>10}{'+/- %':>8}{'oil gap mm':>12}"
             f"{'nonlinearity um':>17}"]
    for s in r["setups"]:
        lines.append(f"{s['setup']:<16}{s['scale_factor_m_per_v'] * 1e3:>11.4f}{s['uncertainty_m_per_v'] * 1e3:>10.4f}"
                     f"{s['uncertainty_pct']:>8.3f}{s['oil_gap_m'] * 1e3:>12.3f}{s['max_residual_m'] * 1e6:>17.4f}")
    if "conversion" in r:
        c = r["conversion"]
        lines.append(f"converted {c['rows']} voltages of column {c['column']!r} ({c['method']}) -> {c['output']}")
    if "plot" in r:
        lines.append(f"plot: {r['plot']}")
    return "\n".join(lines)
