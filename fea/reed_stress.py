"""Design check of a reed's stress (thesis section 3.1.1): at maximum opening and on its slotted seat.

Two static load cases on the 3-D solid reed (:mod:`fea.solid`, quadratic hexahedra):

1. **maximum opening**: the uniform pressure that bends the tip to the stop, p = kappa x_stop
   (eq 3.30; x_stop = 1.9 mm, thesis-reed's stop.gap). The thesis reports a maximum
   von Mises stress of 26.2 MPa for the prototype against 63 MPa yield for Delrin.
2. **reverse pressure on the seat**: the closed reed pressed onto its slotted seat by the
   reverse pressure difference on its downstream face; the seat carries the upstream
   face's lands (u_z = 0, frictionless, bilateral) except over the slots
   (``geometry/data/seat_stop.toml`` [reed_seat]); the pockets do not touch the seat.

von Mises stress is evaluated at the Gauss points. A clamped edge is a stress singularity
of 3-D elasticity, so the absolute maximum grows slowly with refinement there; the check
reports it, the maximum away from the clamp (s > ``clamp_exclusion``), where it converges,
and the beam-theory root stress M / Z as a cross-check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla
from skfem import Basis, ElementHex2, ElementVector, FacetBasis

from geometry.reed import Reed
from geometry.seat_stop import ReedSeat, load_reed_seat

from .mesh import is_symmetric, solid_mesh
from .resources import check_memory
from .solid import DEFAULT_LAYERS, INTORDER, assemble, default_mesh_size, estimate, fixed_dofs, pressure_load

#: Delrin 2700 NC010 yield stress [Pa] (thesis section 3.1.1)
YIELD_STRESS_DELRIN = 63.0e6


def reed_stop_opening() -> float:
    """The stop opening x_stop of the prototype reed valve (thesis-reed's valves, stop.gap).

    Returns
    -------
    float
        x_stop [m].

    References
    ----------
    Knutson (2016), Table 3.13.
    """
    from lumped.model.model_file import load_model

    return float(load_model("thesis-reed").delivery.stop_gap)


@dataclass(frozen=True)
class StressCheck:
    """Result of one load case; stresses in Pa, lengths in m."""

    case: str
    pressure: float
    tip_deflection: float
    max_von_mises: float
    max_von_mises_location: tuple[float, float, float]
    max_von_mises_away_from_clamp: float
    beam_root_stress: float | None
    yield_stress: float
    dofs: int
    mesh_size: float

    @property
    def safety_factor(self) -> float:
        return self.yield_stress / self.max_von_mises

    def as_dict(self) -> dict:
        d = dict(self.__dict__)
        d["max_von_mises_location"] = list(self.max_von_mises_location)
        d["safety_factor"] = self.safety_factor
        return d


def von_mises(grad_u: np.ndarray, lam: float, mu: float) -> np.ndarray:
    """von Mises stress of linear elasticity from displacement gradients: sigma = lambda tr(eps) I + 2 mu eps,
    sigma_vm = sqrt(3/2 s:s) with s the deviator.

    Parameters
    ----------
    grad_u : numpy.ndarray
        Displacement gradients (3, 3, ...) [-].
    lam, mu : float
        Lame constants [Pa].

    Returns
    -------
    numpy.ndarray
        sigma_vm [Pa].

    Examples
    --------
    >>> import numpy as np
    >>> g = np.zeros((3, 3)); g[0, 0] = 1e-3                    # uniaxial strain; E = 1 GPa, nu = 0.3
    >>> lam, mu = 1e9 * 0.3 / (1.3 * 0.4), 1e9 / 2.6
    >>> round(float(von_mises(g, lam, mu)) / 1e6, 3)              # 2 mu eps: the deviatoric part of sigma_x - sigma_y
    0.769
    """
    eps = 0.5 * (grad_u + np.swapaxes(grad_u, 0, 1))
    tr = eps[0, 0] + eps[1, 1] + eps[2, 2]
    s = 2 * mu * eps
    for i in range(3):
        s[i, i] += lam * tr
    dev = (s[0, 0] - s[1, 1]) ** 2 + (s[1, 1] - s[2, 2]) ** 2 + (s[2, 2] - s[0, 0]) ** 2
    shear = s[0, 1] ** 2 + s[1, 2] ** 2 + s[2, 0] ** 2
    return np.sqrt(0.5 * dev + 3.0 * shear)


def _setup(reed: Reed, mesh_size, symmetric_extra=True):
    h = default_mesh_size(reed) if mesh_size is None else float(mesh_size)
    half = is_symmetric(reed) and symmetric_extra
    sm = solid_mesh(reed, h, layers=DEFAULT_LAYERS, half=half)
    check_memory("stress model", *estimate(reed, sm))
    basis = Basis(sm.mesh, ElementHex2(), intorder=INTORDER)
    m = reed.material
    K, _ = assemble(basis, m.youngs_modulus, m.poisson_ratio, m.density)
    return h, half, sm, basis, K


def _solve(K, f, fixed):
    """Static solution with ``fixed`` DOFs held at zero (one sparse LU)."""
    free = np.setdiff1d(np.arange(K.shape[0]), fixed)
    u = np.zeros(K.shape[0])
    lu = spla.splu(K[free][:, free].tocsc(), permc_spec="MMD_AT_PLUS_A")
    u[free] = lu.solve(f[free])
    return u, len(free)


def _tip_deflection(basis, reed, u) -> float:
    from .modes import probe_z

    P = basis.probes(np.array([[reed.length * (1 - 1e-12)], [0.0], [probe_z(reed)]]))
    return float((P @ u[2::3])[0])


def _stress_summary(reed, basis, u, clamp_exclusion):
    vb = basis.with_element(ElementVector(ElementHex2()))
    g = vb.interpolate(u).grad  # (3, 3, nel, nq)
    m = reed.material
    lam = m.youngs_modulus * m.poisson_ratio / ((1 + m.poisson_ratio) * (1 - 2 * m.poisson_ratio))
    mu = m.youngs_modulus / (2 * (1 + m.poisson_ratio))
    vm = von_mises(g, lam, mu)
    x = np.asarray(basis.global_coordinates())  # (3, nel, nq)
    k = np.unravel_index(np.argmax(vm), vm.shape)
    away = x[0] > clamp_exclusion
    return float(vm[k]), tuple(float(x[i][k]) for i in range(3)), float(vm[away].max())


def beam_bending_stress(reed: Reed, pressure: float, s0: float = 0.0) -> float:
    """Bending stress of the Euler-Bernoulli beam at the extreme fibre of a section under the uniform pressure load
    q = p W(s), sigma = M(s0) c / I.

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    pressure : float
        p [Pa].
    s0 : float
        Section [m] from the clamp.

    Returns
    -------
    float
        sigma [Pa] (c from the section's neutral axis, geometry.Reed.neutral_axis).
    """
    s = np.linspace(s0, reed.length, 4001)
    M = pressure * np.trapezoid(reed.width(s) * (s - s0), s)
    A, I = reed.section(s0)
    # extreme fibre: the neutral axis shifts away from the grooved face
    h = float(reed.thickness_profile(s0))
    zc = reed.neutral_axis(s0)
    return float(M * max(zc, h - zc) / I)


def max_opening_stress(reed: Reed, x_stop: float | None = None, mesh_size=None,
                       clamp_exclusion: float | None = None,
                       yield_stress: float = YIELD_STRESS_DELRIN) -> StressCheck:
    """Largest von Mises stress in the 3-D reed with its tip at the stop, under the uniform pressure that holds it
    there (kappa x_stop).

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    x_stop : float, optional
        Tip deflection [m] (None: the thesis reed's stop).
    mesh_size : float, optional
        Element size [m]; None: the fidelity's default for this reed.
    clamp_exclusion : float, optional
        Distance [m] from the clamp excluded from the 'away' maximum (the clamp edge is singular; None: 2 h).
    yield_stress : float
        [Pa] (Delrin).

    Returns
    -------
    StressCheck
        The pressure [Pa], the maxima [Pa] and where, the beam's bending stress, the safety factor.

    References
    ----------
    Knutson (2016), section 3.1.1 (26.2 MPa, yield 63 MPa).
    """
    from .solid import last_static

    x_stop = reed_stop_opening() if x_stop is None else float(x_stop)
    h = default_mesh_size(reed) if mesh_size is None else float(mesh_size)
    last = last_static(reed, h, DEFAULT_LAYERS, is_symmetric(reed))
    if last is not None:     # the solid model just solved for kappa: the same 1 Pa solution, not solved again
        sm, basis, u1, dofs = last
    else:
        h, half, sm, basis, K = _setup(reed, mesh_size)
        f = pressure_load(sm, basis)
        u1, dofs = _solve(K, f, fixed_dofs(basis, half))
    w1 = _tip_deflection(basis, reed, u1)
    p = x_stop / w1  # Pa: linear, so the 1 Pa solution scales
    u = p * u1
    ce = 2 * reed.max_thickness if clamp_exclusion is None else clamp_exclusion
    mx, loc, away = _stress_summary(reed, basis, u, ce)
    return StressCheck("max_opening", p, x_stop, mx, loc, away, beam_bending_stress(reed, p),
                       yield_stress, dofs, h)


def seat_reverse_stress(reed: Reed, seat: ReedSeat | None = None, pressure: float | None = None,
                        mesh_size=None, clamp_exclusion: float | None = None,
                        yield_stress: float = YIELD_STRESS_DELRIN) -> StressCheck:
    """Largest von Mises stress in the closed reed pushed onto its slotted seat by a reverse pressure.

    Parameters
    ----------
    reed : geometry.Reed
        The reed (any profile the geometry describes).
    seat : geometry.seat_stop.ReedSeat, optional
        The seat (None: the thesis's).
    pressure : float, optional
        [Pa] (None: the seat's).
    mesh_size : float, optional
        Element size [m]; None: the fidelity's default for this reed.
    clamp_exclusion : float, optional
        As :func:`max_opening_stress`.
    yield_stress : float
        [Pa].

    Returns
    -------
    StressCheck
        As :func:`max_opening_stress`.
    """
    seat = seat or load_reed_seat()
    p = seat.reverse_pressure if pressure is None else float(pressure)
    half_ok = all(abs(c + c2) < 1e-12 for c, c2 in zip(seat.slot_centres(), seat.slot_centres()[::-1]))
    h, half, sm, basis, K = _setup(reed, mesh_size, symmetric_extra=half_ok)
    mesh = sm.mesh
    bf = mesh.boundary_facets()
    mid = mesh.p[:, mesh.facets[:, bf]].mean(axis=1)
    zmin = mesh.p[2, mesh.facets[:, bf]].min(axis=0)
    zmax = mesh.p[2, mesh.facets[:, bf]].max(axis=0)
    flat = zmax - zmin < 1e-12
    top = bf[flat & (np.abs(mid[2] - reed.thickness_profile(mid[0])) < 1e-12 * max(1.0, reed.max_thickness))]
    land = bf[flat & (np.abs(mid[2]) < 1e-12) & ~seat.in_slot(mid[0], mid[1])]
    fb = FacetBasis(mesh, basis.elem, facets=top, intorder=INTORDER)
    f = np.zeros(3 * basis.N)
    for a in range(len(fb.basis)):
        np.add.at(f, 3 * fb.element_dofs[a] + 2, -p * (np.asarray(fb.basis[a][0]) * fb.dx).sum(axis=1))
    support = basis.get_dofs(facets=land).all()
    fixed = np.unique(np.concatenate([fixed_dofs(basis, half), 3 * support + 2]))
    u, dofs = _solve(K, f, fixed)
    ce = 2 * reed.max_thickness if clamp_exclusion is None else clamp_exclusion
    mx, loc, away = _stress_summary(reed, basis, u, ce)
    return StressCheck("seat_reverse", p, _tip_deflection(basis, reed, u), mx, loc, away, None,
                       yield_stress, dofs, h)
