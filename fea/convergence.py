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


def observed_order(sizes, values, max_iter: int = 200, tol: float = 1e-12) -> tuple[float | None, int, bool]:
    """Observed order of convergence of three solutions on sizes h1 < h2 < h3 (fine to coarse), any refinement
    ratios (Celik et al. 2008, eqs 3-5).

    Parameters
    ----------
    sizes : sequence of float
        h1, h2, h3 [m] (or any length unit).
    values : sequence of float
        f1, f2, f3.
    max_iter : int
        Fixed-point iterations.
    tol : float
        Relative tolerance of p.

    Returns
    -------
    tuple
        (p or None, s, shrinking): s = sign(eps32 / eps21) (-1: oscillatory); shrinking: the fine pair's change is
        the smaller one in the sense of the order.

    Notes
    -----
    Celik et al. (2008, J. Fluids Eng. 130, 078001), eqs 3-5: with eps21 = f2 - f1,
    eps32 = f3 - f2, s = sign(eps32 / eps21) (-1: oscillatory convergence) and
    r21 = h2 / h1, r32 = h3 / h2, p solves p = |ln|eps32 / eps21| + q(p)| / ln r21 with
    q(p) = ln((r21^p - s) / (r32^p - s)) (fixed-point iteration; q = 0 for a constant ratio).

    Returns ``(p, s, shrinking)``: p None when a change is zero or the iteration fails;
    ``shrinking`` is whether the fine pair's change is the smaller one in the sense of the
    order (the expression inside the absolute value is positive).

    References
    ----------
    Celik, Ghia, Roache & Freitas (2008), J. Fluids Eng. 130, 078001.
    """
    h1, h2, h3 = (float(x) for x in sizes)
    f1, f2, f3 = (float(x) for x in values)
    e21, e32 = f2 - f1, f3 - f2
    if e21 == 0.0 or e32 == 0.0:
        return None, 1, False
    s = 1 if e32 / e21 > 0 else -1
    r21, r32 = h2 / h1, h3 / h2
    ln_ratio = math.log(abs(e32 / e21))
    p = abs(ln_ratio) / math.log(r21)
    inner = ln_ratio
    for _ in range(max_iter):
        a, b = r21**p - s, r32**p - s
        if a <= 0.0 or b <= 0.0:
            return None, s, False
        inner = ln_ratio + math.log(a / b)
        p_new = abs(inner) / math.log(r21)
        if abs(p_new - p) <= tol * max(1.0, p):
            p = p_new
            break
        p = p_new
    else:
        return None, s, False
    return (p if p > 0.0 else None), s, inner > 0.0


def extrapolate(f_fine: float, f_coarse: float, ratio: float, order: float) -> float:
    """Richardson's extrapolated value of a pair of solutions, (r^p f_fine - f_coarse) / (r^p - 1).

    Parameters
    ----------
    f_fine, f_coarse : float
        The two solutions.
    ratio : float
        r = h_coarse / h_fine > 1.
    order : float
        p.

    Returns
    -------
    float
        f_ext.

    References
    ----------
    Celik et al. (2008), eq 6; Roache (1998).

    Examples
    --------
    >>> round(extrapolate(6.063, 5.972, 1.5, 1.5339690206281054), 4)      # Celik et al. (2008), Table 1: 6.1685
    6.1685
    """
    rp = ratio**order
    return (rp * f_fine - f_coarse) / (rp - 1.0)


#: factors of safety of the GCI (Roache 1998): three solutions converging monotonically, else
FS_THREE = 1.25
FS_TWO = 3.0


@dataclass(frozen=True)
class GCI:
    """Grid Convergence Index of two or three solutions (Celik et al. 2008), fine to coarse.

    ``gci_fine_pct`` is GCI21, the relative band of the finest solution; ``gci_coarse_pct``
    the band of the second solution (GCI32 from the coarser pair with three solutions,
    Roache's coarse-grid GCI of the pair with two). ``u_fine``/``u_coarse`` are the same bands
    in the quantity's units. A sequence that does not converge monotonically (oscillating,
    diverging, a zero change) gets no extrapolation and the conservative band Fs = 3 times
    the largest change, never hidden (``converging`` False, ``note`` says why).
    """

    sizes: tuple[float, ...]
    values: tuple[float, ...]
    ratios: tuple[float, ...]
    order: float | None
    order_assumed: bool
    extrapolated: float
    safety_factor: float
    converging: bool | None
    oscillatory: bool
    approx_error_pct: tuple[float | None, ...]
    extrapolated_error_pct: float | None
    gci_fine_pct: float | None
    gci_coarse_pct: float | None
    u_fine: float
    u_coarse: float
    asymptotic_ratio: float | None
    note: str

    def as_dict(self) -> dict:
        return asdict(self)

    def band(self, index: int) -> float:
        """Absolute band (quantity units) of solution ``index`` (0 the finest, 1 the second)."""
        return (self.u_fine, self.u_coarse)[index]


def representative_sizes(cells, dim: int) -> tuple[float, ...]:
    """Representative cell sizes of meshes of equal cells, h = (1 / N)^(1 / dim) (Celik et al. 2008, eq 1).

    Parameters
    ----------
    cells : sequence of int
        Cell counts N.
    dim : int
        2 or 3.

    Returns
    -------
    tuple of float
        h (in the unit of the domain's size to the 1/dim).
    """
    return tuple((1.0 / float(n)) ** (1.0 / dim) for n in cells)


def _pct(u: float, f: float) -> float | None:
    return None if f == 0.0 else float(abs(u / f) * 100.0)


def gci(values, sizes=None, cells=None, dim: int | None = None, order: float | None = None) -> GCI:
    """Grid Convergence Index of two or three solutions, fine to coarse (Celik, Ghia, Roache & Freitas 2008, steps
    1-5).

    Parameters
    ----------
    values : sequence of float
        The solutions, finest first.
    sizes : sequence of float, optional
        Representative sizes, increasing.
    cells : sequence of int, optional
        Cell counts, decreasing (with ``dim``).
    dim : int, optional
        2 or 3.
    order : float, optional
        Two solutions: the assumed (formal) order.

    Returns
    -------
    GCI
        The observed order, extrapolated value (eq 6), errors (eqs 7-8), GCI21 and GCI32 [%] (eq 9; Fs = 1.25 for
        three solutions, 3 for two), the asymptotic-range ratio.

    Notes
    -----
    ``sizes`` increasing (fine to coarse) representative sizes, or ``cells`` decreasing cell
    counts with ``dim``. Three solutions: the observed order (:func:`observed_order`, iterated
    for unequal ratios, with the sign term), extrapolated value (eq 6), approximate and
    extrapolated relative errors (eqs 7-8), GCI21 and GCI32 with Fs = 1.25 (eq 9) and the
    asymptotic-range ratio GCI32 / (r21^p GCI21) (Roache 1998; ~1 in the asymptotic range).
    Two solutions: ``order`` is the assumed (formal) order and Fs = 3.

    References
    ----------
    Celik et al. (2008), J. Fluids Eng. 130, 078001; Roache (1998).

    Examples
    --------
    >>> g = gci((6.063, 5.972, 5.863), cells=(18000, 8000, 4500), dim=2)     # Celik et al. (2008), Table 1
    >>> round(g.order, 2), round(g.gci_fine_pct, 2)                             # p 1.53, GCI21 2.17 %
    (1.53, 2.17)
    """
    f, h = _gci_inputs(values, sizes, cells, dim, order)
    ratios = tuple(b / a for a, b in zip(h, h[1:]))
    ea = tuple(_pct(b - a, a) for a, b in zip(f, f[1:]))
    g = _gci_two(h, f, ratios, ea, order) if len(f) == 2 else _gci_three(h, f, ratios, ea)
    numbers = [x for x in (g.order, g.extrapolated, g.gci_fine_pct, g.gci_coarse_pct, g.u_fine, g.u_coarse,
                           g.asymptotic_ratio, g.extrapolated_error_pct, *g.approx_error_pct) if x is not None]
    if not all(math.isfinite(x) for x in numbers):
        # e.g. 1e308, -1e308: their differences overflow a float; a user's numbers, not a failed model
        from geometry.errors import InputError
        raise InputError("values", f"the differences between {', '.join(f'{v:g}' for v in f)} overflow a floating "
                                   "point number; give the solutions in a unit that keeps them below ~1e300")
    return g


def _gci_inputs(values, sizes, cells, dim, order) -> tuple[tuple, tuple]:
    """The solutions and representative sizes of :func:`gci` as floats; InputError naming ``values``, ``sizes``,
    ``cells``, ``dim`` or ``order`` for anything else (strings, NaN, neither sizes nor cells, wrong lengths)."""
    from geometry import validate
    from geometry.errors import InputError

    def seq(x, name, **kw):
        if isinstance(x, (str, bytes)) or not hasattr(x, "__len__"):
            raise InputError(name, f"expected a sequence of numbers, got {x!r}")
        return tuple(float(validate.number(v, f"{name}[{i}]", **kw)) for i, v in enumerate(x))

    f = seq(values, "values")
    if len(f) not in (2, 3):
        raise InputError("values", f"expected two or three solutions (fine to coarse), got {len(f)}")
    if (sizes is None) == (cells is None):
        raise InputError("sizes", "give the meshes as sizes (increasing) or as cells (decreasing) with dim, one of them")
    if sizes is None:
        n = seq(cells, "cells", positive=True, integer=True)
        if dim not in (1, 2, 3) or isinstance(dim, bool):
            raise InputError("dim", f"expected 1, 2 or 3 with cells, got {dim!r}")
        if not all(a > b for a, b in zip(n, n[1:])):
            raise InputError("cells", f"expected counts decreasing from the finest mesh to the coarsest, got {n}")
        h = representative_sizes(n, dim)
    else:
        h = seq(sizes, "sizes", positive=True)
        if not all(a < b for a, b in zip(h, h[1:])):
            raise InputError("sizes", f"expected sizes increasing from the finest mesh to the coarsest, got {h}")
    if len(h) != len(f):
        raise InputError("sizes" if cells is None else "cells", f"expected {len(f)} meshes (one per solution), "
                                                                f"got {len(h)}")
    if order is not None:
        validate.number(order, "order", positive=True)
        if len(f) == 3:
            raise InputError("order", "applies to two solutions; three give the observed order")
    elif len(f) == 2:
        raise InputError("order", "two solutions need the method's formal order (order > 0), e.g. order=2")
    return f, h


def _gci_two(h: tuple, f: tuple, ratios: tuple, ea: tuple, order: float | None) -> GCI:
    """The GCI of two solutions: the assumed (formal) order, Fs = 3, convergence not checked."""
    if order is None or not order > 0.0:
        raise ValueError("two solutions need the assumed order of the method (order > 0)")
    rp = ratios[0] ** order
    u_fine = FS_TWO * abs(f[1] - f[0]) / (rp - 1.0)
    u_coarse = u_fine * rp
    ext = extrapolate(f[0], f[1], ratios[0], order)
    return GCI(sizes=h, values=f, ratios=ratios, order=float(order), order_assumed=True, extrapolated=ext,
               safety_factor=FS_TWO, converging=None, oscillatory=False, approx_error_pct=ea,
               extrapolated_error_pct=_pct(ext - f[0], ext), gci_fine_pct=_pct(u_fine, f[0]),
               gci_coarse_pct=_pct(u_coarse, f[1]), u_fine=u_fine, u_coarse=u_coarse, asymptotic_ratio=None,
               note=f"two solutions: assumed order {order:g}, Fs = {FS_TWO:g}; convergence not checked")


def _gci_three(h: tuple, f: tuple, ratios: tuple, ea: tuple) -> GCI:
    """The GCI of three solutions: the observed order and extrapolation where they converge monotonically
    (Fs = 1.25), else a conservative band of Fs = 3 times the largest change (Roache)."""
    changes = [abs(b - a) for a, b in zip(f, f[1:])]
    if changes[0] == 0.0 and changes[1] == 0.0:
        return GCI(sizes=h, values=f, ratios=ratios, order=None, order_assumed=False, extrapolated=f[0],
                   safety_factor=FS_THREE, converging=True, oscillatory=False, approx_error_pct=ea,
                   extrapolated_error_pct=0.0, gci_fine_pct=_pct(0.0, f[0]) if f[0] else None,
                   gci_coarse_pct=_pct(0.0, f[1]) if f[1] else None, u_fine=0.0, u_coarse=0.0,
                   asymptotic_ratio=None, note="identical on every level")
    p, s, shrinking = observed_order(h, f)
    if p is not None and s > 0 and shrinking:
        r21, r32 = ratios
        ext = extrapolate(f[0], f[1], r21, p)
        u_fine = FS_THREE * changes[0] / (r21**p - 1.0)
        u_coarse = FS_THREE * changes[1] / (r32**p - 1.0)
        g21, g32 = _pct(u_fine, f[0]), _pct(u_coarse, f[1])
        ratio = None if not g21 else g32 / (r21**p * g21)
        return GCI(sizes=h, values=f, ratios=ratios, order=p, order_assumed=False, extrapolated=ext,
                   safety_factor=FS_THREE, converging=True, oscillatory=False, approx_error_pct=ea,
                   extrapolated_error_pct=_pct(ext - f[0], ext), gci_fine_pct=g21, gci_coarse_pct=g32,
                   u_fine=u_fine, u_coarse=u_coarse, asymptotic_ratio=ratio,
                   note=f"monotonic convergence, observed order {p:.3g}, Fs = {FS_THREE:g}")
    why = ("oscillatory convergence (eps32 / eps21 < 0)" if s < 0 else
           "a zero change: the order is undefined" if min(changes) == 0.0 else
           "the changes do not shrink (divergence)")
    big = FS_TWO * max(changes)
    return GCI(sizes=h, values=f, ratios=ratios, order=p, order_assumed=False, extrapolated=f[0],
               safety_factor=FS_TWO, converging=False, oscillatory=s < 0, approx_error_pct=ea,
               extrapolated_error_pct=None, gci_fine_pct=_pct(big, f[0]), gci_coarse_pct=_pct(big, f[1]),
               u_fine=big, u_coarse=big, asymptotic_ratio=None,
               note=f"{why}: no extrapolation; conservative band Fs = {FS_TWO:g} x the largest change (Roache)")


def richardson(sizes, values, theoretical_order: float | None = None) -> Richardson:
    """Richardson extrapolation of a quantity on three meshes in a constant ratio, with the check that they are in
    the asymptotic range.

    Parameters
    ----------
    sizes, values : sequence of float
        Mesh sizes [m], coarse to fine, and the quantity on each.
    theoretical_order : float, optional
        The elements' order (bounds the plausible observed order).

    Returns
    -------
    Richardson
        The order, extrapolated value, each mesh's error [%], and whether the estimate is reliable.

    Notes
    -----
    Outside the asymptotic range (module docstring) f_inf is the finest value and every error is at least the
    largest change between meshes (``reliable`` False).

    References
    ----------
    Roache (1998); Celik et al. (2008).
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
    p_max = None if theoretical_order is None else MAX_ORDER_FACTOR * theoretical_order
    p, _, shrinking = observed_order(h[::-1], f[::-1])
    converging = d1 * d2 > 0 and shrinking
    if converging:
        f_inf = extrapolate(f[2], f[1], h[1] / h[2], p)
        err = tuple(float(abs(v - f_inf) / abs(f_inf) * 100) for v in f)
        plausible = p >= MIN_ORDER and (p_max is None or p <= p_max)
        note = _order_note(p, plausible, theoretical_order, p_max)
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


def _order_note(p: float, plausible: bool, theoretical_order: float | None, p_max: float | None) -> str:
    """What :func:`richardson` says of an observed order p of converging values."""
    if plausible:
        note = f"asymptotic: observed order {p:.2f}"
        if theoretical_order is not None and p < 0.75 * theoretical_order:
            note += (f" (element order {theoretical_order:g}, lowered by singularities: corners, the clamp edge, "
                     "a rounded tip)")
        return note
    return (f"observed order {p:.2f} outside [{MIN_ORDER:g}, {p_max:g}]: not in the asymptotic range"
            if p_max is not None else f"observed order {p:.2f} below {MIN_ORDER:g}: not in the asymptotic range")


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
    props = []

    def run(h):
        if progress:
            print(f"convergence {fidelity}: mesh {len(props) + 1}, size {h:.4g} m", file=sys.stderr, flush=True)
        props.append(model(reed, mesh_size=h))

    for h in sizes:
        run(h)
    res, notes = _refine_until_asymptotic(reed, fidelity, sizes, props, (run, quantities, max_extra))
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
    return {"fidelity": fidelity, "sizes": [float(h) for h in sizes], "dofs": [int(p.dofs) for p in props],
            "default_index": default_index, "quantities": out_q, "reliable": reliable, "notes": notes}


def _refine_until_asymptotic(reed, fidelity: str, sizes: list, props: list, how: tuple) -> tuple[dict, list]:
    """({quantity: Richardson of the finest three meshes}, notes): finer meshes (``run(h)`` appends to ``sizes``'
    results ``props``) while a quantity is outside the asymptotic range, at most ``max_extra`` and while the
    memory estimate allows; ``how`` = (run, quantities, max_extra)."""
    run, quantities, max_extra = how
    ratio = sizes[0] / sizes[1]
    p_th = ELEMENT_ORDER.get(fidelity)

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
    return res, notes


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


#: quantities of the reed-parameter table that get a GCI
REED_QUANTITIES = ("omega_n", "kappa", "gamma1", "gamma2", "gamma3")
#: standard numerical uncertainty of a GCI band: GCI / 1.15 (ASME V&V 20-2009, section 2-4: the GCI
#: with Fs = 1.25 read as a ~95 % interval); applied alike to the conservative Fs = 3 bands
GCI_STANDARD_FACTOR = 1.15


def gci_study(reed, fidelity: str, mesh_size: float | None = None, quick: bool = False,
              quantities=REED_QUANTITIES, progress: bool = False, model=None) -> dict:
    """GCI of omega_n, kappa, gamma1..3 of one FEA fidelity at the mesh a check uses (``mesh_size`` or the default h).

    Full: :func:`convergence_study` on (2h, h, h/2) and :func:`gci` of the three solutions;
    the value at h is the second solution, so its band is GCI32 (``gci_coarse``).
    ``quick``: two meshes (2h, h), Fs = 3 with the assumed order :data:`MIN_ORDER` (the
    lowest these singular problems show; a conservative choice), the value at h the finest.

    Returns ``{"fidelity", "sizes", "dofs", "quick", "quantities": {q: {"value", "U", "u",
    "gci"}}}``: ``U`` the band [quantity units], ``u`` = U / :data:`GCI_STANDARD_FACTOR`.
    """
    if model is None:
        from .fidelities import get

        model = get(fidelity, "fidelity").reed_properties
    h = float(mesh_size) if mesh_size is not None else default_mesh_size(reed, fidelity)
    if quick:
        sizes = (h, RATIO * h)
        props = []
        for x in sizes:
            if progress:
                print(f"gci {fidelity}: mesh {len(props) + 1}/2, size {x:.4g} m", file=sys.stderr, flush=True)
            props.append(model(reed, mesh_size=x))
        values = {q: [getattr(p, q) for p in props] for q in quantities}
        dofs = [int(p.dofs) for p in props]
        index, kw = 0, {"order": MIN_ORDER}
    else:
        study = convergence_study(reed, fidelity, sizes=default_sizes(h), quantities=quantities,
                                  progress=progress, model=model, max_extra=0)
        sizes = tuple(study["sizes"][::-1])
        values = {q: study["quantities"][q]["values"][::-1] for q in quantities}
        dofs = study["dofs"][::-1]
        index, kw = 1, {}
    out = {}
    for q in quantities:
        g = gci(values[q], sizes=sizes, **kw)
        band = g.band(index)
        out[q] = {"value": float(values[q][index]), "U": float(band), "u": float(band / GCI_STANDARD_FACTOR),
                  "gci": g.as_dict()}
    return {"fidelity": fidelity, "sizes": [float(x) for x in sizes], "dofs": dofs, "quick": bool(quick),
            "mesh_size": h, "quantities": out}
