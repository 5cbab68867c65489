"""Classification of reed vibration modes: bending, torsion or in-plane.

A mode is *in-plane* when its through-thickness displacement u_z carries less energy
than u_x, u_y; otherwise it is *bending* when u_z is mainly symmetric about the centre
line (u_z(s, y) = u_z(s, -y)) and *torsion* when mainly antisymmetric. Mirror points are
sampled on the mid-surface of the reed outline, so the mesh need not be symmetric.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.reed import Reed


@dataclass
class ModalResult:
    """What every FE reed model computes (SI): frequencies [rad/s] with their kinds, kappa
    (uniform pressure / tip deflection) [Pa/m], centre-line shapes normalised to 1 at the tip."""

    omega: np.ndarray            # natural frequencies of the first modes [rad/s]
    kinds: list[str]             # their classification (bending, torsion, in-plane, ...)
    bending_index: int           # index of the first bending mode
    kappa: float                 # uniform pressure / tip deflection [Pa/m]
    s: np.ndarray                # centre-line stations [m]
    psi_static: np.ndarray       # static uniform-load shape, psi(L) = 1
    psi_mode: np.ndarray         # first bending mode shape, psi(L) = 1
    dofs: int
    mesh_size: float

    @property
    def omega_n(self) -> float:
        return float(self.omega[self.bending_index])


def probe_z(reed: Reed) -> float:
    """z [m] of the reference surface: the mid-surface, or the middle of the material below
    the deepest groove's floor when a groove reaches past it."""
    h = reed.thickness
    d = max((g.depth for g in reed.grooves), default=0.0)
    return h / 2 if d < h / 2 else (d + h) / 2


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
    z = probe_z(reed)
    pts = lambda p: np.vstack([p, np.full(p.shape[1], z)])  # noqa: E731
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
