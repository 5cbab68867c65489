"""``valvelab reed GEOMETRY --fidelity F``: natural frequency, stiffness and mode parameters of a reed."""

from __future__ import annotations

from geometry import PRESETS, load_reed
from geometry.errors import InputError
from studies.cli import flags

HELP = "first bending frequency, stiffness and mode-function parameters of a reed (and its first N modes)"


def check_modes_count(n, field: str = "--modes", allow_zero: bool = False) -> int | None:
    """The number of modes asked for, checked.

    Parameters
    ----------
    n : int or None
    field : str
        Named by the refusal.
    allow_zero : bool

    Returns
    -------
    int or None
        ``n`` (1 to 50, or 0 with ``allow_zero``); None stays None.
    """
    if n is None:
        return None
    if not (isinstance(n, int) and (n >= 1 or (allow_zero and n == 0)) and n <= 50):
        low = 0 if allow_zero else 1
        raise InputError(field, f"expected a whole number of modes from {low} to 50, got {n}")
    return n


def configure(p):
    """Add the arguments of ``valvelab reed`` to its parser (the command protocol: :mod:`studies.cli`)."""
    p.add_argument("geometry", help=f"preset ({', '.join(PRESETS)}) or reed TOML file")
    p.add_argument("--fidelity", default="analytic", help="analytic (default), beam, plate or solid")
    p.add_argument("--mesh-size", type=flags.number("m", (1e-7, 10.0), positive=True), default=None,
                   help="FEA element size [m] (default: converged size scaled to the reed)")
    p.add_argument("--modes", type=flags.integer(1, 50), default=None, metavar="N",
                   help="also report the first N natural frequencies [rad/s] (JSON: frequencies, ascending) and "
                        "their mode kinds (JSON: mode_kinds)")
    p.add_argument("--plot", default=None, metavar="FILE.png",
                   help="draw the outline, the uniform-load shape and the free-vibration mode shape")
    p.add_argument("--force", action="store_true", help="let --plot replace an existing file")


def run(args) -> dict:
    """Run ``valvelab reed``: first bending frequency, stiffness and mode-function parameters of a reed (and its first
    N modes) (the JSON of ``--json``; :mod:`studies.cli`)."""
    reed = load_reed(args.geometry)
    plot = getattr(args, "plot", None)
    if plot is not None:  # refuse a bad or existing file before any computation
        from studies.outputs import check_distinct, check_new_file
        from studies.plots import check_plot_suffix

        check_distinct({"--plot": plot}, {"GEOMETRY": args.geometry})
        plot = check_new_file(check_plot_suffix(plot), "--plot", args.force)
    from fea.fidelities import get

    fidelity = get(args.fidelity)
    n_modes = check_modes_count(getattr(args, "modes", None))
    if n_modes is None:
        props = fidelity.reed_properties(reed, mesh_size=args.mesh_size)
        out = props.as_contract(args.geometry)
    else:
        props, result = fidelity.properties_and_modes(reed, n_modes, mesh_size=args.mesh_size)
        out = props.as_contract(args.geometry)
        freqs, kinds = result.first(n_modes)
        out["frequencies"] = freqs
        out["mode_kinds"] = kinds
    if plot is not None:
        out["plot"] = str(_plot(plot, reed, args.fidelity, props, args.mesh_size))
    from geometry.declare import atypical
    from lumped.validity import beam_warnings

    # possible but likely a slip (a 2 m reed), or beyond the fidelity's theory (a wide reed as a beam)
    out["warnings"] = [{"code": "implausible_input", "message": f"{k}: {m}"}
                       for k, m in atypical(reed, "reed") + beam_warnings(reed, args.fidelity)]
    return out


def _plot(path, reed, fidelity, props, mesh_size):
    """Outline, static shape and (when the fidelity's module offers ``free_mode_shape``) the free mode."""
    from studies.plots import plot_reed_shapes

    from fea.fidelities import get

    shapes = {"uniform pressure (static)": (props.s, props.psi)}
    free = get(fidelity).free_mode_shape
    if free is not None:
        shapes["first free-vibration mode"] = free(reed, mesh_size=mesh_size)
    return plot_reed_shapes(path, reed, shapes, title=f"reed {reed.name} ({fidelity})")


def render(r: dict) -> str:
    """The result of ``valvelab reed`` as readable text."""
    lines = [
        f"reed {r['geometry']} ({r['fidelity']})",
        f"  omega_n = {r['omega_n']:.6g} rad/s ({r['omega_n'] / 6.283185307:.6g} Hz)",
        f"  kappa   = {r['kappa'] / 1e6:.6g} MPa/m",
        f"  gamma1..3 = {r['gamma1']:.4f}, {r['gamma2']:.4f}, {r['gamma3']:.4f}",
        f"  h_eff   = {r['h_eff'] * 1e3:.5g} mm",
    ]
    if r["dofs"] is not None:
        lines.append(f"  dofs = {r['dofs']}, mesh size = {r['mesh_size'] * 1e3:.4g} mm")
    for k, (w, kind) in enumerate(zip(r.get("frequencies", []), r.get("mode_kinds", []))):
        lines.append(f"  mode {k + 1}: {w:.6g} rad/s ({w / 6.283185307:.5g} Hz)  {kind}")
    return "\n".join(lines)
