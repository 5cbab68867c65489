"""Mode-function parameters (thesis Table 3.4) and the reed properties every fidelity returns.

Analytic (Euler-Bernoulli) and FEA models of a reed all return
:class:`ReedProperties`, so the pump model and the multi-fidelity check take
whichever fidelity the user chose without knowing how it was computed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def mode_integrals(quad, psi, W, width_ref: float) -> tuple[float, float, float]:
    """gamma1, gamma2, gamma3 of Table 3.4 (dimensionless) from psi and W [m] at the nodes of ``quad``.

    gamma1 = int psi W / int psi^2 W, gamma2 = int psi^3 W / int psi^2 W,
    gamma3 = int psi^2 W^2 / (W_2 int psi^2 W); ``width_ref`` is W_2 [m];
    ``quad`` a :class:`lumped.reed.quadrature.ProfileQuadrature`.
    """
    m2 = quad.integral(psi**2 * W)
    return (float(quad.integral(psi * W) / m2), float(quad.integral(psi**3 * W) / m2),
            float(quad.integral(psi**2 * W**2) / (width_ref * m2)))


def mode_parameters(reed, s, psi) -> tuple[float, float, float]:
    """gamma1, gamma2, gamma3 of Table 3.4 for a shape psi(s) sampled on ``reed`` (e.g. FEA nodes).

    psi is interpolated by a cubic spline through the samples (``s`` [m] increasing,
    covering [0, L]) and integrated piece by piece between the reed's breakpoints
    with its exact width W(s): a rule across the width step or the rounded tip would
    cost ~1e-4 in the gammas. psi is normalised at the tip here.
    """
    from scipy.interpolate import CubicSpline

    from .quadrature import ProfileQuadrature, profile_breaks

    s = np.asarray(s, dtype=float)
    psi = np.asarray(psi, dtype=float)
    keep = np.append(np.diff(s) > 0, True)  # drop repeated abscissae (e.g. both sides of a step)
    spline = CubicSpline(s[keep], psi[keep])
    quad = ProfileQuadrature(profile_breaks(reed))
    p = spline(quad.s) / spline(reed.length)
    return mode_integrals(quad, p, reed.width(quad.s), reed.width_tip)


def effective_thickness(gamma1: float, kappa: float, density: float, omega_n: float) -> float:
    """h_eff = gamma1 kappa / (rho_c omega_n^2) [m] (eq 3.62)."""
    return gamma1 * kappa / (density * omega_n**2)


def gamma1_alternative(density: float, h_eff: float, omega_n: float, kappa: float) -> float:
    """gamma1 = rho_c h_eff omega_n^2 / kappa (eq 3.48), from frequency and stiffness alone."""
    return density * h_eff * omega_n**2 / kappa


@dataclass(frozen=True)
class ReedProperties:
    """What any reed model (analytic, beam, plate, solid) gives the lumped reed valve.

    omega_n: first bending natural frequency in vacuum [rad/s];
    kappa: uniform pressure / tip deflection [Pa/m] (eq 3.30);
    gamma1..3: Table 3.4 parameters from the static uniform-load deflection shape;
    h_eff: effective thickness [m] (eq 3.62); s, psi: that shape on the centre line
    (psi(L) = 1); dofs, mesh_size: None for the analytic model.
    """

    fidelity: str
    omega_n: float
    kappa: float
    gamma1: float
    gamma2: float
    gamma3: float
    h_eff: float
    s: np.ndarray
    psi: np.ndarray
    dofs: int | None = None
    mesh_size: float | None = None

    @classmethod
    def from_shape(cls, fidelity: str, reed, omega_n: float, kappa: float, s, psi,
                   dofs: int | None = None, mesh_size: float | None = None) -> "ReedProperties":
        """Properties of a model that gives omega_n [rad/s], kappa [Pa/m] and the static shape psi(s).

        gamma1..3 by :func:`mode_parameters` (piecewise on ``reed``), h_eff by eq 3.62.
        """
        g1, g2, g3 = mode_parameters(reed, s, psi)
        return cls(fidelity=fidelity, omega_n=float(omega_n), kappa=float(kappa), gamma1=g1, gamma2=g2,
                   gamma3=g3, h_eff=effective_thickness(g1, kappa, reed.material.density, omega_n),
                   s=np.asarray(s), psi=np.asarray(psi), dofs=dofs, mesh_size=mesh_size)

    @classmethod
    def from_solution(cls, fidelity: str, reed, r) -> "ReedProperties":
        """Properties of an FE solution ``r`` (``omega_n``, ``kappa``, ``s``, ``psi_static``, ``dofs``, ``mesh_size``)."""
        return cls.from_shape(fidelity, reed, r.omega_n, r.kappa, r.s, r.psi_static, dofs=r.dofs,
                              mesh_size=r.mesh_size)

    def as_contract(self, geometry: str) -> dict:
        """The JSON object of ``valvelab reed --json`` (CONTRACT.md)."""
        return {
            "geometry": geometry,
            "fidelity": self.fidelity,
            "omega_n": float(self.omega_n),
            "kappa": float(self.kappa),
            "gamma1": float(self.gamma1),
            "gamma2": float(self.gamma2),
            "gamma3": float(self.gamma3),
            "h_eff": float(self.h_eff),
            "dofs": None if self.dofs is None else int(self.dofs),
            "mesh_size": None if self.mesh_size is None else float(self.mesh_size),
        }
