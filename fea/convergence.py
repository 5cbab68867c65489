"""Mesh convergence: three refinements, Richardson extrapolation, discretisation error, plot.

With three meshes of sizes h1 > h2 > h3 in a constant ratio r = h1/h2 = h2/h3 and values
f1, f2, f3, the observed order is p = ln((f1 - f2)/(f2 - f3)) / ln r and the extrapolated
value f_inf = f3 + (f3 - f2)/(r^p - 1). The estimated discretisation error of mesh k is
|f_k - f_inf| / |f_inf|. That needs the asymptotic range: changes of one sign that shrink
(``converging``). Otherwise (not ``monotonic``, or monotonic changes that do not shrink, as
near stress singularities like re-entrant corners and groove edges) no order is observed:
f_inf is then the finest value and every mesh's error estimate is at least the largest
change between meshes.
"""

from __future__ import annotations

import math
import sys
from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class Richardson:
    """Result of a three-mesh Richardson extrapolation of one quantity."""

    sizes: tuple[float, ...]
    values: tuple[float, ...]
    ratio: float
    order: float | None
    extrapolated: float
    error_pct: tuple[float, ...]   # estimated discretisation error of each mesh [%]
    monotonic: bool                # the changes have one sign
    converging: bool               # ... and shrink: Richardson applies

    def as_dict(self) -> dict:
        return asdict(self)


def richardson(sizes, values) -> Richardson:
    """Richardson extrapolation of ``values`` on meshes of ``sizes`` (coarse to fine, constant ratio)."""
    h = np.asarray(sizes, dtype=float)
    f = np.asarray(values, dtype=float)
    if h.shape != (3,) or f.shape != (3,):
        raise ValueError("Richardson extrapolation needs exactly three meshes")
    if not (h[0] > h[1] > h[2] > 0):
        raise ValueError("mesh sizes must decrease")
    r = math.sqrt(h[0] / h[2])
    d1, d2 = f[0] - f[1], f[1] - f[2]
    monotonic = d1 * d2 > 0 or (d1 == 0 and d2 == 0)
    converging = d1 * d2 > 0 and abs(d2) < abs(d1)
    if converging:
        p = math.log(d1 / d2) / math.log(r)
        f_inf = f[2] - d2 / (r**p - 1.0)
        err = tuple(float(abs(v - f_inf) / abs(f_inf) * 100) for v in f)
    elif d1 == 0 and d2 == 0:
        p, f_inf = None, float(f[2])
        err = (0.0, 0.0, 0.0)
    else:
        p, f_inf = None, float(f[2])
        bound = max(abs(d1), abs(d2)) / abs(f_inf) * 100
        err = tuple(float(max(bound, abs(v - f_inf) / abs(f_inf) * 100)) for v in f)
    return Richardson(
        sizes=tuple(map(float, h)), values=tuple(map(float, f)), ratio=r, order=p,
        extrapolated=float(f_inf), error_pct=err, monotonic=bool(monotonic), converging=bool(converging),
    )


def default_sizes(mesh_size: float, ratio: float = math.sqrt(2.0)) -> tuple[float, float, float]:
    """The three sizes of a study around a mesh size: (r h, h, h / r)."""
    return (mesh_size * ratio, mesh_size, mesh_size / ratio)


def convergence_study(reed, fidelity: str, sizes=None, quantities=("omega_n", "kappa", "gamma1"),
                      progress: bool = True) -> dict:
    """Run one FEA fidelity (beam, plate, solid) on three meshes and extrapolate each quantity.

    Returns ``{"fidelity", "sizes", "dofs", "quantities": {name: Richardson.as_dict()}}``.
    """
    from studies.cmd_reed import reed_model  # the registry of fidelities

    model = reed_model(fidelity)
    if sizes is None:
        default = {"beam": "fea.beam", "plate": "fea.plate", "solid": "fea.solid"}.get(fidelity)
        if default is None:
            raise ValueError(f"no mesh for fidelity {fidelity!r}")
        import importlib

        mod = importlib.import_module(default)
        base = mod.default_mesh_size(reed) if hasattr(mod, "default_mesh_size") else mod.DEFAULT_MESH_SIZE
        sizes = default_sizes(base)
    props = []
    for k, h in enumerate(sizes):
        if progress:
            print(f"convergence {fidelity}: mesh {k + 1}/3, size {h * 1e3:.3f} mm", file=sys.stderr, flush=True)
        props.append(model(reed, mesh_size=h))
    return {
        "fidelity": fidelity,
        "sizes": [float(h) for h in sizes],
        "dofs": [int(p.dofs) for p in props],
        "quantities": {
            q: richardson(sizes, [getattr(p, q) for p in props]).as_dict() for q in quantities
        },
    }


def plot_convergence(study: dict, path) -> None:
    """Plot each quantity against DOFs with its extrapolated value (matplotlib, Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    qs = study["quantities"]
    fig, axes = plt.subplots(1, len(qs), figsize=(4.2 * len(qs), 3.4), squeeze=False)
    for ax, (name, r) in zip(axes[0], qs.items()):
        ax.semilogx(study["dofs"], r["values"], "o-", label="FEA")
        ax.axhline(r["extrapolated"], color="k", ls="--", lw=0.8,
                   label=f"Richardson (p = {r['order']:.2f})" if r["order"] else "finest (not asymptotic)")
        ax.set_xlabel("degrees of freedom")
        ax.set_title(f"{name}: error {r['error_pct'][-1]:.3f} % on the finest mesh", fontsize=9)
        ax.legend(fontsize=8)
    fig.suptitle(f"mesh convergence, {study['fidelity']}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
