"""Kirchhoff plate reed with Argyris triangles (scikit-fem ``ElementTriArgyris``).

The reed face (s, y) as a thin plate of rigidity D = E h^3 / 12 (1 - nu^2), clamped on
s = 0: w = 0 and dw/dn = 0. Each element carries its section's thickness h(s) (thickness
steps of multi-section reeds are mesh lines where w_xx may jump:
:func:`release_step_curvature`), less the groove depth where a groove is cut
(the mid-surface offset of a one-sided pocket or step is neglected: the plate is the
reed's "thickness per element" model). Mass rho h per unit area; the uniform pressure
p = 1 Pa gives kappa = p / w(L, 0) (eq 3.30). Argyris elements are C1-conforming
quintics, so frequencies converge from above.

Default element size: 2 mm on the 1 in thesis reeds, scaled with the reed's in-plane size
(:func:`fea.mesh.scaled_mesh_size`). Measured discretisation error of that default (not
"about 0.2 %" as documented before): stepped #2 0.56 % in omega_n and 0.90 % in kappa
(0.50 % and 0.77 % against a 0.25 mm mesh), stepped #1 0.16 / 0.32 %, prototype 0.39 /
0.70 %, uniform < 0.001 % (the re-entrant step corners and the clamped-free corners are
singular, so convergence is of order ~1.1-1.7 in h; docs/fea.md); 6e-6 on six modes of the
square cantilever plate (FV16 geometry) against an independent Ritz solution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla
from skfem import Basis, BilinearForm, ElementTriArgyris, LinearForm, asm, condense, solve as fem_solve
from skfem.helpers import dd, ddot, eye, trace

from geometry.reed import Reed

from .mesh import FaceMesh, face_mesh, scaled_mesh_size
from .modes import ModalResult, ModeShapes, describe_modes, face_grid, fidelity_functions, first_bending, pull_inside
from .resources import check_memory, plate_bytes

#: default element size [m] away from the clamp for the 1 in thesis reeds, scaled for others
DEFAULT_MESH_SIZE = 2.0e-3
INTORDER = 10
N_SHAPE = 401


def default_mesh_size(reed: Reed) -> float:
    """The plate's default element size: DEFAULT_MESH_SIZE scaled with the reed (fea.mesh.scaled_mesh_size).

    Parameters
    ----------
    reed : geometry.Reed
        The reed.

    Returns
    -------
    float
        [m].
    """
    return scaled_mesh_size(reed, DEFAULT_MESH_SIZE)


@dataclass
class PlateResult(ModalResult):
    """The plate's modal result plus its basis, mesh and full mode vectors (for shapes and VTU)."""

    basis: Basis = None          # on the mesh in units of ``scale`` (probe points / scale)
    face: FaceMesh = None
    modes: np.ndarray = None
    scale: float = 1.0           # length unit of the basis mesh [m]
    system: "PlateSystem" = None  # the assembled matrices (modal masses, the whole FE reed)


@BilinearForm
def _stiffness(u, v, w):
    # bending moments per unit curvature: D [(1 - nu) k + nu tr(k) I] with D = E h^3 / 12 (1 - nu^2)
    nu = w.nu
    D = w.E * w.h**3 / (12.0 * (1.0 - nu**2))
    k = dd(u)
    return D * ddot((1.0 - nu) * k + nu * eye(trace(k), 2), dd(v))


@BilinearForm
def _mass(u, v, w):
    return w.rho * w.h * u * v


@LinearForm
def _load(v, w):
    return 1.0 * v


def _clip_to_rectangle(poly: np.ndarray, lo, hi) -> np.ndarray:
    """The part of a convex polygon (k, 2) inside the box lo <= p <= hi (Sutherland-Hodgman)."""
    for axis in (0, 1):
        for bound, sign in ((lo[axis], 1.0), (hi[axis], -1.0)):
            if len(poly) == 0:
                return poly
            d = sign * (poly[:, axis] - bound)          # >= 0 inside this half-plane
            out = []
            for i in range(len(poly)):
                p, q, dp, dq = poly[i], poly[(i + 1) % len(poly)], d[i], d[(i + 1) % len(poly)]
                if dp >= 0:
                    out.append(p)
                if (dp >= 0) != (dq >= 0):
                    out.append(p + dp / (dp - dq) * (q - p))
            poly = np.array(out).reshape(-1, 2)
    return poly


def rectangle_rule(mesh, lo, hi, intorder: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Points and weights integrating over the box lo..hi intersected with a triangle mesh.

    Each triangle is clipped to the box and its part fanned into triangles, each with a Gauss rule of order
    ``intorder`` (exact for the Argyris quintics times a constant), so int_box N_j dA is exact on a mesh the box's
    edges cut anywhere.

    Parameters
    ----------
    mesh : skfem.MeshTri
    lo, hi : array_like of float
        The box's corners (mesh units).
    intorder : int
        Gauss order per triangle.

    Returns
    -------
    (points, weights) : tuple of array of float
        (2, n) and (n,), in mesh units.
    """
    from skfem.quadrature import get_quadrature
    from skfem.refdom import RefTri

    X, Wq = get_quadrature(RefTri, intorder)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    tri = mesh.p[:, mesh.t]                                      # (2, 3, nel)
    cand = np.nonzero((tri[0].max(0) > lo[0]) & (tri[0].min(0) < hi[0])
                      & (tri[1].max(0) > lo[1]) & (tri[1].min(0) < hi[1]))[0]
    pts, wts = [], []
    for e in cand:
        poly = _clip_to_rectangle(tri[:, :, e].T.copy(), lo, hi)
        for k in range(1, len(poly) - 1):
            a, b, c = poly[0], poly[k], poly[k + 1]
            J = abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
            if J <= 1e-14 * (hi - lo).prod():
                continue
            pts.append(a[:, None] + np.outer(b - a, X[0]) + np.outer(c - a, X[1]))
            wts.append(Wq * J)
    return np.hstack(pts), np.concatenate(wts)


def release_step_curvature(basis: Basis, reed: Reed, ell: float) -> int:
    """Give the elements beyond each thickness step their own w_xx DOF at the vertices on the step line.

    Argyris elements share w and all its first and second derivatives at vertices (C2 there), but across a line s =
    s_k where the rigidity D jumps only w, w_x, w_y, w_xy and w_yy are continuous: the bending moment D w_xx is, so
    w_xx jumps. Shared, it would stiffen the plate (+0.3 % in kappa at 2 mm on a reed with two steps, converging
    slowly); released, the plate with nu = 0 equals the beam. Groove edges are left as they are: the plate's groove
    model is an approximation anyway (docs/fea.md).

    Parameters
    ----------
    basis : skfem.Basis
        The Argyris basis; its element DOFs are modified in place.
    reed : geometry.Reed
        The reed.
    ell : float
        The length unit of the basis mesh [m].

    Returns
    -------
    int
        The number of DOFs added.
    """
    ps = reed.pieces()
    steps = [p.s1 / ell for p, q in zip(ps[:-1], ps[1:]) if p.h_end != q.h]
    if not steps:
        return 0
    mesh, dofs = basis.mesh, basis.dofs
    ed = dofs.element_dofs            # (21, nel), modified in place (the basis reads it)
    cen = mesh.p[0, mesh.t].mean(axis=0)
    n_new = int(dofs.N)
    added = 0
    for sk in steps:
        tol = 1e-9 * max(1.0, sk)
        on_line = np.nonzero(np.abs(mesh.p[0] - sk) < tol)[0]
        right = cen > sk
        for v in on_line:
            touches = np.any(mesh.t == v, axis=0)
            if not (np.any(touches & right) and np.any(touches & ~right)):
                continue                             # on the outline's step edge: one side only
            new = None
            for i in range(3):                       # local vertex i: DOFs 6 i .. 6 i + 5, u_xx at 6 i + 3
                els = np.nonzero((mesh.t[i] == v) & right)[0]
                if els.size:
                    if new is None:
                        new, n_new = n_new, n_new + 1
                        added += 1
                    ed[6 * i + 3, els] = new
    dofs.N = n_new
    return added


def estimate(fm: FaceMesh) -> tuple[int, float]:
    """The plate's DOFs and peak memory on the face mesh: 6 per vertex + 1 per edge (Argyris).

    Parameters
    ----------
    fm : fea.mesh.FaceMesh

    Returns
    -------
    (dofs, bytes) : tuple of (int, float)
    """
    m = fm.mesh
    dofs = 6 * m.p.shape[1] + m.facets.shape[1]
    return dofs, plate_bytes(dofs)


@dataclass
class PlateSystem:
    """The assembled Argyris plate of a reed, on the mesh in units of ``ell`` [m].

    True stiffness K / ell^2 [N/m], mass M ell^2 [kg], uniform-pressure load f ell^2 [m^2];
    the DOFs are w [m] and its derivatives times powers of ell (all in metres). ``free``:
    the DOFs left after the clamp (w and every derivative but w_xx zero on s = 0).
    """

    basis: Basis
    face: FaceMesh
    ell: float
    K: object
    M: object
    f: np.ndarray
    free: np.ndarray
    clamped: np.ndarray
    mesh_size: float

    def probe(self, s, y) -> np.ndarray:
        """Dense (len(s), len(free)) matrix giving w [m] at face points (s, y) [m] from the free DOFs
        (points just outside the meshed outline are moved onto it, fea.modes.pull_inside)."""
        pts = pull_inside(self.face.mesh, np.vstack([np.asarray(s, float), np.asarray(y, float)]))
        return self.basis.probes(pts / self.ell).tocsc()[:, self.free].toarray()

    def footprint_load(self, port) -> np.ndarray:
        """f_j = int_F N_j dA [m^2] on the free DOFs: a unit pressure on the port's footprint F
        (the whole meshed face without a port), exact (:func:`rectangle_rule` on the mesh)."""
        if port is None:
            return self.f[self.free] * self.ell**2
        lo = np.array([port.s_start, port.y_center - port.width / 2]) / self.ell
        hi = np.array([port.s_end, port.y_center + port.width / 2]) / self.ell
        pts, wts = rectangle_rule(self.basis.mesh, lo, hi)
        return self.basis.probes(pts).tocsc()[:, self.free].T @ wts * self.ell**2

    def dense(self) -> tuple[np.ndarray, np.ndarray]:
        """(M [kg], K [N/m]) on the free DOFs, dense, in true units."""
        M = self.M[self.free][:, self.free].toarray() * self.ell**2
        K = self.K[self.free][:, self.free].toarray() / self.ell**2
        return M, K


def assemble(reed: Reed, mesh_size: float | None = None) -> PlateSystem:
    """Stiffness, mass and uniform-pressure load of the clamped Kirchhoff plate (Argyris triangles).

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    mesh_size : float, optional
        Element size [m]; None: the fidelity's default for this reed.

    Returns
    -------
    system
        K [N/m], M [kg] and the load of a unit pressure (SI), with its probes and free DOFs.

    Notes
    -----
    Before assembling, the DOFs and memory are estimated and an InputError naming
    --mesh-size raised if they exceed what the machine has (fea.resources).

    References
    ----------
    Knutson (2016), eq 3.8, section 3.2; scikit-fem.
    """
    size = default_mesh_size(reed) if mesh_size is None else float(mesh_size)
    fm = face_mesh(reed, size, quad=False)
    check_memory("plate model", *estimate(fm))
    # Argyris DOFs are w and its first and second derivatives: in metres their scales differ
    # by (element size)^2 and the LU loses every digit on fine meshes (stepped #2 at 0.18 mm
    # was 0.5 % off). Assemble on the mesh in units of the element size ell instead:
    # K = K'/ell^2, M = M' ell^2, f = f' ell^2, so omega^2 = lambda'/ell^4, w = ell^4 K'^-1 f'.
    ell = size
    basis = Basis(type(fm.mesh)(fm.mesh.p / ell, fm.mesh.t), ElementTriArgyris(), intorder=INTORDER)
    release_step_curvature(basis, reed, ell)
    hel = fm.material_thickness[:, None] * np.ones((1, basis.X.shape[1]))
    mat = reed.material
    K = asm(_stiffness, basis, E=mat.youngs_modulus, nu=mat.poisson_ratio, h=hel)
    M = asm(_mass, basis, rho=mat.density, h=hel)
    f = asm(_load, basis)
    # clamp: w and all its derivatives along the edge vanish; only w_xx stays free
    tol = 1e-12 * max(1.0, reed.length / ell)
    clamp = basis.get_dofs(lambda x: x[0] < tol)
    D = np.concatenate([clamp.nodal[n] for n in ("u", "u_x", "u_y", "u_xy", "u_yy")] + [clamp.facet["u_n"]])
    free = np.setdiff1d(np.arange(K.shape[0]), D)
    return PlateSystem(basis=basis, face=fm, ell=ell, K=K, M=M, f=f, free=free, clamped=D, mesh_size=size)


def _eigen(sys: PlateSystem, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Lowest omega^2 [rad^2/s^2] and free-DOF mode vectors by shift-invert ARPACK."""
    Kc, Mc, _, I = condense(sys.K, sys.M, D=sys.clamped)
    k = min(int(n_modes), len(I) - 2)
    vals, vecs = spla.eigsh(Kc.tocsc(), k=k, M=Mc.tocsc(), sigma=0.0, which="LM",
                            v0=np.ones(Kc.shape[0]))  # a fixed start: reproducible results
    order = np.argsort(vals)
    return vals[order] / sys.ell**4, vecs[:, order]


def solve(reed: Reed, mesh_size: float | None = None, n_modes: int = 4) -> PlateResult:
    """The modes, the uniform-load stiffness kappa = p / w(L) and the centre-line shapes of the clamped Kirchhoff
    plate (Argyris triangles).

    D = E h^3 / (12 (1 - nu^2)) and rho h per element from the face mesh (its thickness and groove depth). The
    DOFs and memory are estimated first: an InputError naming --mesh-size where they exceed what the machine has
    (fea.resources).

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    mesh_size : float, optional
        Element size [m]; None: the fidelity's default for this reed.
    n_modes : int
        Modes wanted.

    Returns
    -------
    result
        omega [rad/s] of the modes (named), kappa [Pa/m], the static and first-mode shapes psi(s) (psi(L) = 1), DOFs
        and mesh size.

    References
    ----------
    Knutson (2016), eqs 3.8, 3.30, section 3.5.
    """
    sys = assemble(reed, mesh_size)
    basis, fm, ell, K, I = sys.basis, sys.face, sys.ell, sys.K, sys.free
    u = fem_solve(*condense(K, sys.f, D=sys.clamped)) * ell**4
    vals, vecs = _eigen(sys, n_modes)
    k = len(vals)
    modes = np.zeros((K.shape[0], k))
    modes[I] = vecs
    grid = face_grid(reed)
    P = basis.probes(pull_inside(fm.mesh, grid[4]) / ell)
    fields = [(P @ modes[:, j]).reshape(len(grid[0]), len(grid[1])) for j in range(k)]
    kinds, labels = describe_modes(fields, reed, grid=grid)
    bending = first_bending(kinds, labels)
    s = np.linspace(0.0, reed.length, N_SHAPE)
    Pc = basis.probes(np.vstack([np.clip(s, 1e-12 * reed.length, reed.length * (1 - 1e-12)), 0 * s]) / ell)
    w = Pc @ u
    phi = Pc @ modes[:, bending]
    return PlateResult(
        omega=np.sqrt(vals), kinds=kinds, bending_index=bending, kappa=1.0 / w[-1], s=s,
        psi_static=w / w[-1], psi_mode=phi / phi[-1], dofs=len(I), mesh_size=sys.mesh_size, labels=labels,
        basis=basis, face=fm, modes=modes, scale=ell, system=sys,
    )


#: the fidelity's functions (fea.fidelities): properties, at least 4 modes (the naming of plate modes needs them), both
reed_properties, modes, properties_and_modes = fidelity_functions("plate", solve, __name__, n_min=4)


def mode_shapes(result: PlateResult, reed: Reed, n: int | None = None, ns: int = 60, ny: int = 21) -> ModeShapes:
    """w of the first n modes on an (s, y) grid of the face, each max |w| = 1 (for plots).

    Parameters
    ----------
    result : PlateResult
    reed : geometry.Reed
        The reed.
    n : int, optional
        Modes; None: all solved.
    ns, ny : int
        Grid points along and across.

    Returns
    -------
    fea.modes.ModeShapes
    """
    n = result.modes.shape[1] if n is None else min(n, result.modes.shape[1])
    s = np.linspace(1e-4, 1 - 1e-4, ns) * reed.length
    eta = np.linspace(-1.0, 1.0, ny) * 0.999
    Y = eta[None, :] * np.asarray(reed.width(s))[:, None] / 2
    S = np.repeat(s[:, None], ny, axis=1)
    P = result.basis.probes(pull_inside(result.face.mesh, np.vstack([S.ravel(), Y.ravel()])) / result.scale)
    w = np.empty((n, ns, ny))
    for k in range(n):
        wk = (P @ result.modes[:, k]).reshape(ns, ny)
        w[k] = wk / (np.max(np.abs(wk)) or 1.0)
    return ModeShapes(s=s, y=Y, w=w, omega=result.omega[:n], labels=result.labels[:n], fidelity="plate")


def write_modes_vtu(result: PlateResult, path) -> None:
    """Write the face mesh with each mode's deflection w (max |w| = 1) as point data (VTU).

    Parameters
    ----------
    result : PlateResult
    path : str or Path

    Returns
    -------
    None
    """
    from .mesh import write_vtu

    nodal = result.basis.nodal_dofs[0]  # the value DOF 'u' of each vertex
    data = {}
    for k in range(result.modes.shape[1]):
        v = result.modes[nodal, k]
        data[f"mode{k + 1}_{result.labels[k].replace(' ', '_')}_{result.omega[k]:.0f}rad_s"] = v / np.abs(v).max()
    write_vtu(path, result.face.mesh, data)


# -- the modal reed and the whole FE reed (lumped.reed.modal_basis) ---------------------------------
#: default element size of the whole FE plate reed on the 1 in thesis reeds (scaled for others):
#: coarse, so the dense reed stays a few hundred DOFs (docs/reed_dynamics.md)
FE_MESH_SIZE = 5.0e-3


def default_fe_mesh_size(reed: Reed) -> float:
    """The whole FE plate reed's default element size: FE_MESH_SIZE scaled with the reed.

    Parameters
    ----------
    reed : geometry.Reed
        The reed.

    Returns
    -------
    float
        [m].
    """
    return scaled_mesh_size(reed, FE_MESH_SIZE)


def modal_basis(reed: Reed, port=None, mesh_size: float | None = None, n_modes: int = 6):
    """The ``plate`` fidelity's modal basis for the modal reed valve: the first modes of the clamped Kirchhoff plate
    (Argyris triangles) with their modal masses, loads, openings and station values.

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    port : geometry.reed_port.ReedPort, optional
        The port's footprint on the face (None: the whole face, eq 3.21's load).
    mesh_size : float, optional
        Element size [m]; None: the fidelity's default for this reed.
    n_modes : int
        Modes wanted.

    Returns
    -------
    lumped.reed.modal_basis.ModalBasis
        (SI units; lumped.reed.modal_basis).

    References
    ----------
    docs/reed_dynamics.md; Knutson (2016), eq 3.21.
    """
    from lumped.reed.modal_basis import Modes, Sampling, build_basis

    r = solve(reed, mesh_size, n_modes=n_modes)
    sys = r.system
    vecs = r.modes[sys.free]
    raw = np.einsum("ij,ij->j", vecs, sys.M[sys.free][:, sys.free] @ vecs) * sys.ell**2
    modes = Modes(r.omega, r.labels, raw, lambda s, y: sys.probe(s, y) @ vecs,
                  raw_load=sys.footprint_load(port) @ vecs, mesh_size=sys.mesh_size, dofs=r.dofs)
    return build_basis(reed, port, "plate", modes, Sampling(plane=True))


def fe_reed(reed: Reed, port=None, mesh_size: float | None = None):
    """The whole plate FE reed for the reference stepper: dense M, K on the free DOFs, the load of a unit pressure
    on the footprint, the opening, tip and station rows.

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    port : geometry.reed_port.ReedPort, optional
        The port's footprint on the face (None: the whole face, eq 3.21's load).
    mesh_size : float, optional
        Element size [m]; None: default_fe_mesh_size.

    Returns
    -------
    lumped.reed.modal_basis.FEReed
        (SI units).

    References
    ----------
    docs/reed_dynamics.md.
    """
    from lumped.reed.modal_basis import FESystem, Sampling, fe_reed_from

    sys = assemble(reed, default_fe_mesh_size(reed) if mesh_size is None else mesh_size)
    M, K = sys.dense()
    system = FESystem(M, K, sys.probe, load=sys.footprint_load(port), mesh_size=sys.mesh_size,
                      dof_units=f"Argyris DOFs: w [m], ell (w_x, w_y), ell^2 (w_xx, w_xy, w_yy), ell w_n "
                                f"[m], ell = {sys.ell:.6g} m")
    return fe_reed_from(reed, port, "plate", system, Sampling(plane=True))
