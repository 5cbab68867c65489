"""Plots people would rather look at than numbers: reed shapes, Figure 3.12, ring-down fits.

Every function takes arrays (so any model, analytic or FEA, can be drawn), writes one
file with matplotlib's object API (no pyplot, no display needed) and returns its path.
Callers check the path first with :func:`studies.outputs.check_new_file`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from geometry.errors import InputError

#: file types matplotlib writes that we accept for --plot
PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def legend_outside(ax, **kwargs):
    """Place an axes' legend to the right of it, off the data.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    **kwargs
        Passed to ``matplotlib.axes.Axes.legend`` (``fontsize``, ``ncol``, ...).

    Returns
    -------
    matplotlib.legend.Legend
    """
    return ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, **kwargs)


def check_plot_suffix(path, field: str = "--plot") -> Path:
    """Check that a plot's file name has an image suffix matplotlib writes.

    Parameters
    ----------
    path : str or os.PathLike
    field : str
        The flag named by the refusal.

    Returns
    -------
    pathlib.Path
        ``path``, ending in .png, .pdf or .svg.
    """
    p = Path(path)
    if p.suffix.lower() not in PLOT_SUFFIXES:
        raise InputError(field, f"{p.name}: expected a file ending in {', '.join(PLOT_SUFFIXES)}")
    return p


def plot_reed_shapes(path, reed, shapes: dict, title: str | None = None) -> Path:
    """Draw a reed's outline (top view, grooves shaded by depth) above shapes psi(s) normalised at the tip.

    Parameters
    ----------
    path : str or os.PathLike
        The image file.
    reed : geometry.reed.Reed
    shapes : dict
        label -> (s [m], psi [-]) arrays, e.g. the static uniform-load shape and the first
        free-vibration mode of any fidelity.
    title : str, optional

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    fig = Figure(figsize=(7.0, 6.5), layout="constrained")
    ax0, ax1 = fig.subplots(2, 1, sharex=True, height_ratios=(1, 1.6))
    out = reed.outline()
    ax0.fill(out[:, 0] * 1e3, out[:, 1] * 1e3, color="0.85", ec="k", lw=1)
    if reed.grooves:  # pockets shaded by depth
        ss, yy = np.meshgrid(np.linspace(0, reed.length, 400), np.linspace(-reed.max_width / 2, reed.max_width / 2, 200))
        inside = np.abs(yy) <= reed.width(ss) / 2
        depth = np.where(inside, reed.groove_depth(ss, yy), np.nan)
        depth = np.where(depth > 0, depth, np.nan)
        ax0.contourf(ss * 1e3, yy * 1e3, depth * 1e3, levels=3, cmap="Blues", alpha=0.7)
    ax0.set_aspect("equal")
    ax0.set_ylabel("y [mm]")
    ax0.set_title(title or f"reed {reed.name}")
    for label, (s, psi) in shapes.items():
        ax1.plot(np.asarray(s) * 1e3, psi, label=label)
    ax1.axhline(0.0, color="0.6", lw=0.5)
    ax1.set_xlabel("s [mm] (clamp at 0)")
    ax1.set_ylabel(r"$\psi(s) = v(s) / v(L)$ [-]")
    legend_outside(ax1, fontsize=8)
    ax1.grid(alpha=0.3)
    fig.savefig(path, dpi=120)
    return Path(path)


def figure_3_12(path) -> Path:
    """Draw the mode functions of the uniform and stepped reeds in free vibration and under uniform load.

    Exact Euler-Bernoulli shapes (:func:`lumped.reed.euler_bernoulli.shape`) against s / L, and
    stepped #2's rigid-tip approximation (eqs 3.42-3.45).

    Parameters
    ----------
    path : str or os.PathLike
        The image file.

    Returns
    -------
    pathlib.Path
        ``path``.

    References
    ----------
    Knutson (2016), Figure 3.12 and Table 3.4.
    """
    from geometry import load_reed
    from lumped.reed import euler_bernoulli as rb

    fig = Figure(figsize=(7.0, 4.5), layout="constrained")
    ax = fig.subplots()
    styles = {"free": "-", "load": "--", "three_section": ":"}
    names = {"free": "free vibration", "load": "uniform load", "three_section": "uniform load, rigid tip"}
    for reed_name, kinds in (("uniform", ("free", "load")), ("stepped1", ("free", "load")),
                             ("stepped2", ("free", "load", "three_section"))):
        reed = load_reed(reed_name)
        s = np.linspace(0.0, reed.length, 301)
        color = None
        for kind in kinds:
            _, psi = rb.shape(reed, kind, s)
            (line,) = ax.plot(s / reed.length, psi, styles[kind], color=color,
                              label=f"{reed_name}, {names[kind]}")
            color = line.get_color()
    ax.set_xlabel("s / L [-]")
    ax.set_ylabel(r"mode function $\psi$ [-]")
    ax.set_title("Mode functions (cf. thesis Figure 3.12; exact Euler-Bernoulli)")
    ax.grid(alpha=0.3)
    legend_outside(ax, fontsize=8)
    fig.savefig(path, dpi=120)
    return Path(path)


def plot_ringdown(path, traces, fits, title: str = "plucked reed: eq 3.67 fits") -> Path:
    """Draw plucked-reed ring-down traces with their fits of eq 3.67.

    Parameters
    ----------
    path : str or os.PathLike
        The image file.
    traces : sequence of (t, v)
        Time [s] and signal (the sensor's unit) of each run.
    fits : sequence of lumped.reed.ringdown.RingdownFit
        One per trace.
    title : str

    Returns
    -------
    pathlib.Path
        ``path``.

    References
    ----------
    Knutson (2016), eq 3.67 (damped oscillation of the plucked reed) and section 3.6.
    """
    from lumped.reed.ringdown import ringdown

    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.subplots()
    for i, ((t, v), f) in enumerate(zip(traces, fits)):
        t = np.asarray(t, float)
        off = 1.5 * i * max(f.amplitude, 1e-300)
        ax.plot((t - t[0]) * 1e3, np.asarray(v) + off, ".", ms=1.5, color="k")
        ax.plot((t - t[0]) * 1e3, ringdown(t - t[0], f.amplitude, f.sigma, f.omega_d, f.phase, f.offset) + off,
                lw=0.8, label=f"run {i + 1}: omega_d {f.omega_d:.0f} rad/s, c_c {f.c_c:.1f} Pa s/m")
    ax.set_xlabel("t [ms]")
    ax.set_ylabel("signal [sensor unit] (runs offset)")
    ax.set_title(title)
    legend_outside(ax, fontsize=7)
    fig.savefig(path, dpi=120)
    return Path(path)


def plot_mode_shapes(path, reed, s, y, w, omega, labels, title: str | None = None) -> Path:
    """Draw the shapes of any number of modes, one panel each, with units on every axis.

    Parameters
    ----------
    path : str or os.PathLike
        The image file.
    reed : geometry.reed.Reed
    s : numpy.ndarray
        Stations along the reed [m], (ns,).
    y : numpy.ndarray
        Positions across the width at each station [m], (ns, ny).
    w : numpy.ndarray
        Normalised deflections (max |w| = 1), (n, ns, ny): ny = 1 draws w(s) of a one-dimensional
        model, ny > 1 draws u_z over the face (s, y) as filled contours with its nodal lines (w = 0).
    omega : sequence of float
        Natural frequencies [rad/s].
    labels : sequence of str
        Mode names (``torsion 1``) titling each panel.
    title : str, optional

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    w = np.asarray(w, dtype=float)
    n = w.shape[0]
    cols = min(n, 3)
    rows = int(np.ceil(n / cols))
    two_d = w.shape[2] > 1
    aspect = float(reed.max_width / reed.length) if two_d else 0.5
    panel_h = max(1.6, min(3.2, 3.6 * aspect + 0.9)) if two_d else 2.4
    fig = Figure(figsize=(4.0 * cols, panel_h * rows + 0.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    scale, unit = (1.0, "m") if reed.length > 1.0 else (1e3, "mm")   # lengths in m or mm
    s_mm = np.asarray(s) * scale
    for k in range(n):
        ax = axes[k]
        if two_d:
            S = np.repeat(s_mm[:, None], w.shape[2], axis=1)
            cs = ax.contourf(S, np.asarray(y) * scale, w[k], levels=np.linspace(-1, 1, 21), cmap="RdBu_r")
            ax.contour(S, np.asarray(y) * scale, w[k], levels=[0.0], colors="k", linewidths=0.8)
            out = reed.outline()
            ax.plot(out[:, 0] * scale, out[:, 1] * scale, color="0.3", lw=0.6)
            ax.set_aspect("equal")
            ax.set_ylabel(f"y [{unit}]")
            fig.colorbar(cs, ax=ax, label=r"$u_z / \max|u_z|$ [-]", shrink=0.85, ticks=[-1, 0, 1])
        else:
            ax.plot(s_mm, w[k, :, 0], color="C0")
            ax.axhline(0.0, color="0.6", lw=0.5)
            ax.set_ylabel(r"$w / \max|w|$ [-]")
            ax.grid(alpha=0.3)
        ax.set_xlabel(f"s [{unit}] (clamp at 0)")
        ax.set_title(f"{labels[k]}: {omega[k]:.4g} rad/s ({omega[k] / (2 * np.pi):.4g} Hz)", fontsize=9)
    for ax in axes[n:]:
        ax.set_visible(False)
    fig.suptitle(title or f"mode shapes of reed {reed.name}")
    fig.savefig(path, dpi=110)
    return Path(path)


def plot_flow(path, points: list, cd_reference, title: str, solution=None,
              equations: tuple[str, str, str] = ("2.48", "2.46", "2.44")) -> Path:
    """The ``valvelab flow`` figure: Cd(Re) of the points (one line per lift) against a reference
    correlation ``cd_reference(re)`` (eq 2.48), and with a ``solution`` (fea.fluid FlowSolution) its
    pressure [kPa] and velocity magnitude [m/s] over the (r, z) plane [mm]. ``equations``: the
    numbers of the reference correlation, Re and Cd definitions (a reed's: 3.89, 3.87, 3.84)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.tri as mtri
    import numpy as np

    panels = 3 if solution is not None else 1
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 4.6), squeeze=False)
    ax = axes[0][-1]
    re_all = sorted({pt["reynolds"] for pt in points})
    grid = np.geomspace(max(min(re_all) / 2, 0.1), max(re_all) * 1.5, 200)
    ax.semilogx(grid, [cd_reference(r) for r in grid], "k-", lw=1, label=f"eq {equations[0]} (bench fit)")
    for lift in sorted({pt["lift"] for pt in points}):
        sel = sorted((pt for pt in points if pt["lift"] == lift), key=lambda q: q["reynolds"])
        ax.semilogx([q["reynolds"] for q in sel], [q["cd"] for q in sel], "o--", ms=4,
                    label=f"x = {lift * 1e3:.3g} mm")
    ax.set_xlabel(f"Reynolds number Re (eq {equations[1]}) [-]")
    ax.set_ylabel(f"discharge coefficient Cd (eq {equations[2]}) [-]")
    ax.set_title("Cd(Re)", fontsize=9)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, frameon=False)
    if solution is not None:
        mesh = solution.pbasis.mesh
        tri = mtri.Triangulation(mesh.p[0] * 1e3, mesh.p[1] * 1e3, mesh.t.T)
        ur, uz, p = solution.probe(mesh.p[0], mesh.p[1])
        for a, (field, label) in zip(axes[0][:2], ((p / 1e3, "pressure [kPa]"), (np.hypot(ur, uz), "velocity magnitude [m/s]"))):
            cs = a.tripcolor(tri, field, shading="gouraud", cmap="viridis")
            fig.colorbar(cs, ax=a, label=label)
            a.set_aspect("equal")
            a.set_xlabel("r [mm]")
            a.set_ylabel("z [mm]")
            a.set_title(label.split(" [")[0], fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return Path(path)
