"""Reed vibration modes: the modal result every FE model returns, and how modes are named.

A mode is named by the nodal pattern of its out-of-plane displacement u_z(s, y) on the
reed's reference surface (:func:`describe_modes`). At each station s the field across
the width is expanded in Legendre polynomials of eta = 2 y / W(s): the P0 part is
bending, the P1 part torsion (twist), P2 and above plate modes with nodal lines along
the reed. With the share of each part in the mean square of u_z over the face:

- ``bending n``: P0 carries >= 80 %; n - 1 nodal lines across the reed (sign changes of
  the P0 part along s);
- ``torsion n``: P1 carries >= 80 %; n - 1 nodal lines across besides the centre line;
- ``bending-torsion a,b``: P0 and P1 together carry >= 80 % but neither alone (reeds that
  are not mirror-symmetric couple them); a - 1 and b - 1 nodal lines of each part;
- ``plate (m,n)``: otherwise; m nodal lines across the reed, n along it (the dominant
  Legendre degree), e.g. the anticlastic "plate (0,2)" of a wide plate;
- ``in-plane n``: the n-th mode whose in-plane displacement carries more energy than u_z.

Euler-Bernoulli models (analytic, beam) have bending modes only: ``bending n`` is the
n-th, which has n - 1 nodes (Sturm-Liouville). :func:`classify_by_symmetry` is the older,
coarser split used to pick the bending modes of a plate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.reed import Reed

#: Legendre degrees across the width used to name a mode (P0 bending, P1 torsion, P2.. plate)
N_LEGENDRE = 6
#: a family is named when its share of the out-of-plane mean square is at least this
PURE_SHARE = 0.8
#: sign changes along s count only between samples above this fraction of the peak
NODE_THRESHOLD = 0.05
#: sample points across the width stay this fraction inside the outline (meshes have chords)
INSIDE = 0.97


@dataclass
class ModalResult:
    """What every FE reed model computes (SI): frequencies [rad/s] with their kinds, kappa
    (uniform pressure / tip deflection) [Pa/m], centre-line shapes normalised to 1 at the tip."""

    omega: np.ndarray            # natural frequencies of the first modes [rad/s], ascending
    kinds: list[str]             # their family (bending, torsion, bending-torsion, plate, in-plane)
    bending_index: int           # index of the first bending mode
    kappa: float                 # uniform pressure / tip deflection [Pa/m]
    s: np.ndarray                # centre-line stations [m]
    psi_static: np.ndarray       # static uniform-load shape, psi(L) = 1
    psi_mode: np.ndarray         # first bending mode shape, psi(L) = 1
    dofs: int
    mesh_size: float
    labels: list[str]            # nodal-pattern names ("bending 1", "torsion 1", ...)

    @property
    def omega_n(self) -> float:
        return float(self.omega[self.bending_index])

    def first(self, n: int) -> tuple[list[float], list[str]]:
        """The first n frequencies [rad/s] and their labels (CONTRACT ``frequencies``, ``mode_kinds``)."""
        return [float(w) for w in self.omega[:n]], list(self.labels[:n])


@dataclass
class ModeShapes:
    """Mode shapes for plots: out-of-plane displacement on a grid of the face, each normalised to max |w| = 1.

    ``s`` [m] (ns,), ``y`` [m] (ns, ny) across the width at each station, ``w`` (n_modes, ns, ny);
    one-dimensional models give ny = 1 (y = 0).
    """

    s: np.ndarray
    y: np.ndarray
    w: np.ndarray
    omega: np.ndarray
    labels: list[str]
    fidelity: str


def piece_probe_z(reed: Reed) -> list[float]:
    """z [m] of the reference surface of each piece (:meth:`geometry.Reed.pieces`): its mid-surface
    h/2, or the middle of the material below the deepest groove floor on that piece when a
    groove reaches past h/2 (h the piece's smallest thickness on a thickness taper)."""
    out = []
    for p in reed.pieces():
        d = max((g.depth for g in reed.grooves if g.s_range()[0] < p.s1 and g.s_range()[1] > p.s0),
                default=0.0)
        h = p.h_min                  # a thickness taper: below its thinner end, inside the material everywhere
        out.append(h / 2 if d < h / 2 else (d + h) / 2)
    return out


def probe_z(reed: Reed, s=None):
    """z [m] of the reference surface at s [m] (vectorised; default: at the tip), see :func:`piece_probe_z`."""
    zs = np.array(piece_probe_z(reed))
    if s is None:
        return float(zs[-1])
    k = np.clip(reed._piece_index(s), 0, len(zs) - 1)
    return zs[k] if np.ndim(s) else float(zs[k])


def face_grid(reed: Reed, ns: int = 80, ny: int = 10):
    """Sample grid of the face for naming modes: stations s [m] (ns,), Gauss-Legendre eta and
    weights (ny,), widths W(s) [m] and the points (s, y) [m] as a (2, ns * ny) array (station-major)."""
    L = reed.length
    s = np.linspace(0.01, 0.995, ns) * L
    eta, wts = np.polynomial.legendre.leggauss(ny)
    W = np.asarray(reed.width(s), dtype=float)
    S = np.repeat(s, ny)
    Y = np.tile(eta, ns) * np.repeat(W, ny) / 2 * INSIDE
    return s, eta, wts, W, np.vstack([S, Y])


def pull_inside(mesh2d, pts: np.ndarray, mirror: bool = False) -> np.ndarray:
    """Points (s, y) [m] moved toward the centre line until they lie in the 2-D mesh ``mesh2d``.

    Meshes replace arcs by chords, so points near the true outline may fall just outside;
    each such point's y is scaled by 0.9 until inside (matplotlib's triangle finder).
    ``mirror``: the mesh holds y >= 0 only (half model); |y| is tested.
    """
    from matplotlib.tri import Triangulation

    t = mesh2d.t
    if t.shape[0] == 4:  # quadrilaterals: two triangles each
        t = np.hstack([t[[0, 1, 2]], t[[0, 2, 3]]])
    finder = Triangulation(mesh2d.p[0], mesh2d.p[1], t.T).get_trifinder()
    out = np.array(pts, dtype=float, copy=True)
    for _ in range(60):
        y = np.abs(out[1]) if mirror else out[1]
        bad = finder(out[0], y) < 0
        if not bad.any():
            break
        out[1, bad] *= 0.9
    return out


def _sign_changes(c: np.ndarray) -> int:
    """Sign changes of a sampled profile, counted only between samples above NODE_THRESHOLD of its peak."""
    c = np.asarray(c, dtype=float)
    peak = np.max(np.abs(c)) if c.size else 0.0
    if peak == 0.0:
        return 0
    n, last = 0, 0
    for v in c:
        if abs(v) < NODE_THRESHOLD * peak:
            continue
        sg = 1 if v > 0 else -1
        if last and sg != last:
            n += 1
        last = sg
    return n


def describe_mode(w: np.ndarray, s: np.ndarray, eta: np.ndarray, wts: np.ndarray, W: np.ndarray,
                  in_plane: bool = False) -> tuple[str, str]:
    """(family, label) of one mode from u_z sampled on :func:`face_grid` (w shaped (ns, ny)).

    See the module docstring for the names; ``in_plane`` marks a mode dominated by in-plane
    displacement (its label gets its running number in :func:`describe_modes`).
    """
    if in_plane:
        return "in-plane", "in-plane"
    w = np.asarray(w, dtype=float).reshape(len(s), len(eta))
    P = np.polynomial.legendre.legvander(eta, N_LEGENDRE - 1)        # (ny, K)
    c = (w * wts) @ P * ((2 * np.arange(N_LEGENDRE) + 1) / 2)         # (ns, K) Legendre coefficients
    ds = np.gradient(s)
    weight = W * ds                                                   # face-area weight per station
    total = np.sum((w**2 * wts).sum(axis=1) / 2 * weight)             # mean square over the face x area
    share = (c**2 * (2 / (2 * np.arange(N_LEGENDRE) + 1))).T @ weight / 2 / max(total, 1e-300)
    n0, n1 = _sign_changes(c[:, 0]) + 1, _sign_changes(c[:, 1]) + 1
    if share[0] >= PURE_SHARE:
        return "bending", f"bending {n0}"
    if share[1] >= PURE_SHARE:
        return "torsion", f"torsion {n1}"
    if share[0] + share[1] >= PURE_SHARE:
        return "bending-torsion", f"bending-torsion {n0},{n1}"
    k = int(np.argmax(share))
    return "plate", f"plate ({_sign_changes(c[:, k])},{k})"


def describe_modes(fields: list[np.ndarray], reed: Reed, in_plane=None, grid=None) -> tuple[list[str], list[str]]:
    """(families, labels) of modes given as u_z on :func:`face_grid` (see :func:`describe_mode`);
    in-plane modes are numbered in order."""
    s, eta, wts, W, _ = face_grid(reed) if grid is None else grid
    in_plane = [False] * len(fields) if in_plane is None else in_plane
    kinds, labels, n_in = [], [], 0
    for w, ip in zip(fields, in_plane):
        kind, label = describe_mode(w, s, eta, wts, W, ip)
        if kind == "in-plane":
            n_in += 1
            label = f"in-plane {n_in}"
        kinds.append(kind)
        labels.append(label)
    return kinds, labels


def bending_labels(n: int) -> list[str]:
    """Labels of the first n Euler-Bernoulli modes: bending 1..n (mode n has n - 1 nodes)."""
    return [f"bending {k + 1}" for k in range(n)]


def first_bending(kinds: list[str], labels: list[str]) -> int:
    """Index of the first bending mode: 'bending 1', else the first of the bending family, else 0."""
    for target in (lambda k, lab: lab == "bending 1", lambda k, lab: k == "bending",
                   lambda k, lab: k == "bending-torsion"):
        for i, (k, lab) in enumerate(zip(kinds, labels)):
            if target(k, lab):
                return i
    return 0


def mirror_points(reed: Reed, ns: int = 24, ny: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Points (s, y) [m] with y > 0 inside the outline and their mirror images (s, -y)."""
    s = np.linspace(0.05, 0.95, ns) * reed.length
    frac = np.linspace(0.15, 0.85, ny)
    S, F = np.meshgrid(s, frac, indexing="ij")
    Y = F * reed.width(S) / 2
    up = np.vstack([S.ravel(), Y.ravel()])
    return up, up * np.array([[1.0], [-1.0]])


def classify_by_symmetry(w_up: np.ndarray, w_down: np.ndarray) -> str:
    """'bending' if the out-of-plane field is mainly symmetric about y = 0, else 'torsion'."""
    sym = np.sum((w_up + w_down) ** 2)
    anti = np.sum((w_up - w_down) ** 2)
    return "bending" if sym >= anti else "torsion"


def classify_solid_modes(basis, modes: np.ndarray, reed: Reed, half: bool = False) -> list[str]:
    """Kind of each column of ``modes`` (vector Q2 DOFs, component-interleaved).

    On a half model (y >= 0) the symmetry is imposed by the plane condition, so only
    out-of-plane ('bending') and 'in-plane' are told apart here.
    """
    up, down = mirror_points(reed)
    pts = lambda p: np.vstack([p, probe_z(reed, p[0])])  # noqa: E731
    Pu = basis.probes(pts(up))
    Pd = None if half else basis.probes(pts(down))
    kinds = []
    for k in range(modes.shape[1]):
        u = modes[:, k].reshape(-1, 3)
        ux, uy, uz = (Pu @ u[:, i] for i in range(3))
        if np.sum(uz**2) < np.sum(ux**2 + uy**2):
            kinds.append("in-plane")
        else:
            kinds.append("bending" if half else classify_by_symmetry(uz, Pd @ u[:, 2]))
    return kinds


def fidelity_functions(fidelity: str, solve, module: str, *, n_min: int = 1, **solve_options) -> tuple:
    """The three functions every FE fidelity module offers (:mod:`fea.fidelities`), built from its ``solve``.

    Parameters
    ----------
    fidelity : str
        Its name (``beam``, ``plate``, ``solid``), carried by the ReedProperties.
    solve : callable
        ``solve(reed, mesh_size, n_modes=N, **solve_options)`` -> a result with ``omega_n`` [rad/s], ``kappa``
        [Pa/m], ``s`` [m], ``psi_static``, ``dofs`` and ``mesh_size`` [m].
    module : str
        The module they are offered by (their ``__module__``, for the API pages).
    n_min : int
        The fewest modes ``solve`` is asked for (the plate's naming of modes needs 4).
    **solve_options
        Passed to ``solve`` for the modes (the solid's ``torsion=True``).

    Returns
    -------
    tuple of callable
        ``reed_properties(reed, mesh_size=None) -> ReedProperties`` (omega_n, kappa, gamma1..3 of the static
        shape, h_eff: Table 3.4, eq 3.62), ``modes(reed, n, mesh_size=None)`` (at least n natural frequencies
        [rad/s], named) and ``properties_and_modes(reed, n, mesh_size=None)`` (both from one solution).
    """
    from lumped.reed.mode_function import ReedProperties

    def reed_properties(reed: Reed, mesh_size: float | None = None):
        r = solve(reed, mesh_size)
        return ReedProperties.from_solution(fidelity, reed, r)

    def modes(reed: Reed, n: int, mesh_size: float | None = None):
        return solve(reed, mesh_size, n_modes=max(int(n), n_min), **solve_options)

    def properties_and_modes(reed: Reed, n: int, mesh_size: float | None = None):
        r = modes(reed, n, mesh_size)
        return ReedProperties.from_solution(fidelity, reed, r), r

    reed_properties.__doc__ = (f"omega_n [rad/s], kappa [Pa/m], gamma1..3 (Table 3.4, static shape) and h_eff [m] "
                               f"(eq 3.62) of a reed by the {fidelity} FE model (a ReedProperties).")
    modes.__doc__ = (f"At least n (and {n_min} or more) natural frequencies [rad/s] of a reed by the {fidelity} FE "
                     "model, named by their nodal pattern (a result whose ``first(n)`` gives them).")
    properties_and_modes.__doc__ = f"(ReedProperties, modes) of a reed by the {fidelity} FE model, from one solution."
    for f in (reed_properties, modes, properties_and_modes):
        f.__module__, f.__qualname__ = module, f.__name__
    return reed_properties, modes, properties_and_modes
