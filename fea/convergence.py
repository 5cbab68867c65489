"""Mesh convergence: Richardson extrapolation with a check of the asymptotic range, error estimates, plot.

With three meshes of sizes h1 > h2 > h3 in a constant ratio r = h1/h2 = h2/h3 and values
f1, f2, f3, the observed order is p = ln((f1 - f2)/(f2 - f3)) / ln r and the extrapolated
value f_inf = f3 + (f3 - f2)/(r^p - 1) (Richardson; Roache 1998). The estimated
discretisation error of mesh k is |f_k - f_inf| / |f_inf|. That holds only in the
asymptotic range, which :func:`richardson` checks:

- the changes have one sign (``monotonic``) and shrink (``converging``);
- the observed order is plausible: between :data:`MIN_ORDER` (1.0) and 1.25 times the
  element's theoretical order for smooth solutions (:data:`ELEMENT_ORDER`). The reeds' step
  corners, clamped-free corners and clamp edge are singular points of plate theory and 3-D
  elasticity; they lower the order of omega_n and kappa to about 1.1-1.9 for every element
  (measured: docs/fea.md), so an order near 1.3 is in range while an order above the
  element's (noise cancelling) or below 1 (pre-asymptotic) is not.

:func:`convergence_study` uses meshes (2h, h, h/2) around the default size h. gmsh meshes
at sqrt(2) steps alternate between two families (how element counts round along the short
edges), which scatters the observed order (from -8 to 3 on stepped reed #2); halving keeps
one family. When a quantity fails the checks the study refines further (h/4, if the
memory estimate allows) and repeats them on the finest three meshes; if it still fails, the
estimate is flagged ``reliable = False`` and made conservative: first-order convergence
from the finest change (the remaining error equals the last change for r = 2).

Measured on stepped reed #2 against much finer meshes (docs/fea.md): the estimate is
within a factor 1.3 of the actual error of the default mesh (solid and plate); the old
sqrt(2) study underestimated it about twice.
"""

from __future__ import annotations

import math
import sys
from dataclasses import asdict, dataclass, replace

import numpy as np

#: theoretical order of convergence of omega_n and kappa for smooth solutions (eigenvalue and
#: energy error ~ h^(2k) for degree-k elements in the energy norm): Hermite cubic beam h^4,
#: Argyris quintic plate h^8, triquadratic solid h^4
ELEMENT_ORDER = {"beam": 4.0, "plate": 8.0, "solid": 4.0}
#: below this observed order the meshes are not in the asymptotic range: the corner and edge
#: singularities of these problems (clamped-free corners and edges, 270 deg re-entrant step
#: corners of plates and 3-D elasticity) have eigenvalue convergence orders 2 alpha >= ~1.1;
#: lower observed orders came from pre-asymptotic meshes (stepped #1's plate: 0.51 on 4, 2,
#: 1 mm, then 1.06 and 1.30)
MIN_ORDER = 1.0
#: an observed order above this multiple of the element's is noise, not convergence
MAX_ORDER_FACTOR = 1.25
#: default refinement ratio of the study (see the module docstring)
RATIO = 2.0
#: module of each FEA fidelity (for its default mesh size)


@dataclass(frozen=True)
class Richardson:
    """Result of a Richardson extrapolation of one quantity on three meshes (coarse to fine)."""

    sizes: tuple[float, ...]
    values: tuple[float, ...]
    ratio: float
    order: float | None
    extrapolated: float
    error_pct: tuple[float, ...]   # estimated discretisation error of each mesh [%]
    monotonic: bool                # the changes have one sign
    converging: bool               # ... and shrink
    asymptotic: bool = False       # ... and the observed order is plausible: Richardson applies
    reliable: bool = False         # the error estimate can be trusted (asymptotic range reached)
    theoretical_order: float | None = None
    note: str = ""

    def as_dict(self) -> dict:
        return asdict(self)

    def error_of(self, value: float) -> float:
        """Estimated discretisation error [%] of a value of this quantity on any mesh of the study."""
        f_inf = self.extrapolated
        if self.reliable:
            return float(abs(value - f_inf) / abs(f_inf) * 100)
        d1, d2 = self.values[0] - self.values[1], self.values[1] - self.values[2]
        tail = abs(d2) / (self.ratio - 1.0)
        bound = max(abs(d1), abs(d2)) / abs(f_inf) * 100
        return float(max(bound, (abs(value - f_inf) + tail) / abs(f_inf) * 100))


def richardson(sizes, values, theoretical_order: float | None = None) -> Richardson:
    """Richardson extrapolation of ``values`` on three meshes of ``sizes`` [m] (coarse to fine, constant ratio).

    Checks the asymptotic range (module docstring); outside it, f_inf is the finest value
    and every error estimate is at least the largest change between meshes (``reliable``
    False).
    """
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
    p_max = None if theoretical_order is None else MAX_ORDER_FACTOR * theoretical_order
    if converging:
        p = math.log(d1 / d2) / math.log(r)
        f_inf = f[2] - d2 / (r**p - 1.0)
        err = tuple(float(abs(v - f_inf) / abs(f_inf) * 100) for v in f)
        plausible = p >= MIN_ORDER and (p_max is None or p <= p_max)
        if plausible:
            note = f"asymptotic: observed order {p:.2f}"
            if theoretical_order is not None and p < 0.75 * theoretical_order:
                note += f" (element order {theoretical_order:g}, lowered by singularities: corners, the clamp edge, a rounded tip)"
        else:
            note = (f"observed order {p:.2f} outside [{MIN_ORDER:g}, {p_max:g}]: not in the asymptotic range"
                    if p_max is not None else f"observed order {p:.2f} below {MIN_ORDER:g}: not in the asymptotic range")
        return Richardson(sizes=tuple(map(float, h)), values=tuple(map(float, f)), ratio=r, order=p,
                          extrapolated=float(f_inf), error_pct=err, monotonic=True, converging=True,
                          asymptotic=plausible, reliable=plausible, theoretical_order=theoretical_order,
                          note=note)
    if d1 == 0 and d2 == 0:
        return Richardson(sizes=tuple(map(float, h)), values=tuple(map(float, f)), ratio=r, order=None,
                          extrapolated=float(f[2]), error_pct=(0.0, 0.0, 0.0), monotonic=True, converging=False,
                          asymptotic=True, reliable=True, theoretical_order=theoretical_order,
                          note="identical on every mesh")
    note = ("not monotonic" if not monotonic else "changes do not shrink") + \
        ": not in the asymptotic range; the error estimate is a rough bound (first-order convergence assumed)"
    out = Richardson(sizes=tuple(map(float, h)), values=tuple(map(float, f)), ratio=r, order=None,
                     extrapolated=float(f[2]), error_pct=(0.0, 0.0, 0.0), monotonic=bool(monotonic),
                     converging=False, asymptotic=False, reliable=False, theoretical_order=theoretical_order,
                     note=note)
    # conservative: first-order convergence from the finest change (r = 2: the remaining error
    # equals the last change), never below the largest change seen
    return replace(out, error_pct=tuple(out.error_of(v) for v in f))


def default_sizes(mesh_size: float, ratio: float = RATIO) -> tuple[float, float, float]:
    """The three sizes of a study around a mesh size: (r h, h, h / r), r = 2 by default."""
    return (mesh_size * ratio, mesh_size, mesh_size / ratio)


def default_mesh_size(reed, fidelity: str) -> float:
    """The default element size [m] of an FEA fidelity (beam, plate, solid) for ``reed``."""
    from .fidelities import get

    return get(fidelity, "fidelity").default_mesh_size(reed)


def _fits(reed, fidelity: str, size: float) -> bool:
    """Whether one more mesh of ``size`` [m] fits the memory the machine has now (fea.resources)."""
    from geometry.errors import InputError

    from . import mesh as fm
    from .fidelities import get

    mod = get(fidelity, "fidelity").module
    from .mesh import check_face_mesh
    from .resources import check_memory

    try:
        if fidelity == "beam":
            check_memory("beam", *mod.estimate(reed, size))
        elif fidelity == "plate":
            check_face_mesh(reed, size)
            check_memory("plate", *mod.estimate(fm.face_mesh(reed, size)))
        else:
            sm = fm.solid_mesh(reed, size, layers=mod.default_layers(reed), half=fm.is_symmetric(reed))
            check_memory("solid", *mod.estimate(reed, sm))
    except InputError:
        return False
    return True


def convergence_study(reed, fidelity: str, sizes=None, quantities=("omega_n", "kappa", "gamma1"),
                      progress: bool = True, model=None, max_extra: int = 1) -> dict:
    """Run one FEA fidelity (beam, plate, solid) on three meshes, check the asymptotic range and extrapolate.

    ``sizes``: three decreasing sizes [m] in a constant ratio (default (2h, h, h/2) around
    the default size h). A quantity outside the asymptotic range triggers up to
    ``max_extra`` finer meshes (while the memory estimate allows); its estimate is then
    taken from the finest three. ``model(reed, mesh_size=...) -> ReedProperties`` defaults
    to the fidelity's ``reed_properties``.

    Returns ``{"fidelity", "sizes", "dofs", "default_index", "quantities": {name:
    Richardson.as_dict() + {"default_error_pct"}}, "reliable", "notes"}``; ``error_pct``
    lists every mesh, ``default_error_pct`` is that of the mesh at ``default_index`` (the
    second mesh: the default size when ``sizes`` is None).
    """
    if model is None:
        from .fidelities import get

        model = get(fidelity, "fidelity").reed_properties
    if sizes is None:
        sizes = default_sizes(default_mesh_size(reed, fidelity))
    sizes = [float(h) for h in sizes]
    ratio = sizes[0] / sizes[1]
    p_th = ELEMENT_ORDER.get(fidelity)
    props = []

    def run(h):
        if progress:
            print(f"convergence {fidelity}: mesh {len(props) + 1}, size {h:.4g} m", file=sys.stderr, flush=True)
        props.append(model(reed, mesh_size=h))

    for h in sizes:
        run(h)

    def analyse():
        k = len(sizes)
        return {q: richardson(sizes[k - 3:], [getattr(p, q) for p in props[k - 3:]], p_th) for q in quantities}

    res = analyse()
    notes = []
    extra = 0
    while extra < max_extra and not all(r.asymptotic for r in res.values()):
        h = sizes[-1] / ratio
        bad = ", ".join(q for q, r in res.items() if not r.asymptotic)
        if not _fits(reed, fidelity, h):
            notes.append(f"{bad} not in the asymptotic range; a finer mesh ({h:.4g} m) does not fit in memory")
            break
        notes.append(f"{bad} not in the asymptotic range on the first three meshes: refined to {h:.4g} m")
        sizes.append(h)
        run(h)
        extra += 1
        res = analyse()
    default_index = 1
    out_q = {}
    for q, r in res.items():
        d = r.as_dict()
        # every mesh's error from the (finest three) meshes' extrapolation or bound
        vals = [getattr(p, q) for p in props]
        errs = [r.error_of(v) for v in vals]
        d.update(sizes=list(sizes), values=[float(v) for v in vals], error_pct=[float(e) for e in errs],
                 default_error_pct=float(errs[default_index]))
        out_q[q] = d
    reliable = all(r.reliable for r in res.values())
    if not reliable:
        notes.append("unreliable error estimate for " + ", ".join(q for q, r in res.items() if not r.reliable)
                     + ": treat it as a rough bound")
    return {
        "fidelity": fidelity,
        "sizes": [float(h) for h in sizes],
        "dofs": [int(p.dofs) for p in props],
        "default_index": default_index,
        "quantities": out_q,
        "reliable": reliable,
        "notes": notes,
    }


def plot_convergence(study: dict, path) -> None:
    """Plot each quantity against DOFs with its extrapolated value (matplotlib, Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    qs = study["quantities"]
    fig, axes = plt.subplots(1, len(qs), figsize=(4.2 * len(qs), 3.4), squeeze=False)
    units = {"omega_n": "rad/s", "kappa": "Pa/m"}
    for ax, (name, r) in zip(axes[0], qs.items()):
        ax.semilogx(study["dofs"], r["values"], "o-", label="FEA")
        ax.axhline(r["extrapolated"], color="k", ls="--", lw=0.8,
                   label=f"Richardson (p = {r['order']:.2f})" if r["reliable"] and r["order"] else
                   "finest (not asymptotic)")
        ax.set_xlabel("degrees of freedom [-]")
        ax.set_ylabel(f"{name} [{units.get(name, '-')}]")
        ax.set_title(f"{name}: default mesh error {r['default_error_pct']:.3f} %"
                     + ("" if r["reliable"] else " (unreliable)"), fontsize=9)
        ax.legend(fontsize=8)
    fig.suptitle(f"mesh convergence, {study['fidelity']}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
