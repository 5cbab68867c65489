"""Mode-function parameters (thesis Table 3.4) and the reed properties every fidelity returns.

Analytic (Euler-Bernoulli) and FEA models of a reed all return
:class:`ReedProperties`, so the pump model and the multi-fidelity check take
whichever fidelity the user chose without knowing how it was computed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def mode_integrals(quad, psi, W, width_ref: float) -> tuple[float, float, float]:
    """The mode-function parameters gamma1, gamma2, gamma3 of Table 3.4 from a shape and the width sampled at a
    quadrature's nodes.

    Parameters
    ----------
    quad : lumped.reed.quadrature.ProfileQuadrature
        The quadrature whose nodes psi and W are sampled at.
    psi : numpy.ndarray
        The mode function psi(s) [-] at the nodes (psi(L) = 1).
    W : numpy.ndarray
        The width W(s) [m] at the nodes.
    width_ref : float
        W_2 [m], the tip width.

    Returns
    -------
    tuple of float
        (gamma1, gamma2, gamma3) [-]: gamma1 = int psi W / int psi^2 W, gamma2 = int psi^3 W / int psi^2 W, gamma3 =
        int psi^2 W^2 / (W_2 int psi^2 W).

    References
    ----------
    Knutson (2016), Table 3.4, eqs 3.18-3.21.
    """
    m2 = quad.integral(psi**2 * W)
    return (float(quad.integral(psi * W) / m2), float(quad.integral(psi**3 * W) / m2),
            float(quad.integral(psi**2 * W**2) / (width_ref * m2)))


def mode_parameters(reed, s, psi) -> tuple[float, float, float]:
    """The mode-function parameters gamma1, gamma2, gamma3 of Table 3.4 for a shape sampled on a reed (e.g. at FEA
    nodes).

    Parameters
    ----------
    reed : geometry.Reed
        The reed (its exact width W(s) and breakpoints).
    s : array_like
        Positions [m], increasing, covering [0, L].
    psi : array_like
        The shape there [-] (normalised at the tip here).

    Returns
    -------
    tuple of float
        (gamma1, gamma2, gamma3) [-] (:func:`mode_integrals`).

    Notes
    -----
    psi is interpolated by a cubic spline through the samples and integrated piece by piece between the reed's
    breakpoints with its exact width W(s): a rule across the width step or the rounded tip would cost ~1e-4 in
    the gammas.

    References
    ----------
    Knutson (2016), Table 3.4.
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
    """The effective thickness of a reed's one-mode model, h_eff = gamma1 kappa / (rho_c omega_n^2) (eq 3.62): the
    thickness a uniform plate of the same frequency and stiffness would have.

    Parameters
    ----------
    gamma1 : float
        Table 3.4's gamma1 [-].
    kappa : float
        Stiffness [Pa/m].
    density : float
        rho_c [kg/m^3].
    omega_n : float
        First frequency in vacuum [rad/s].

    Returns
    -------
    float
        h_eff [m].

    References
    ----------
    Knutson (2016), eq 3.62, Table 3.13.

    Examples
    --------
    The prototype reed (Table 3.10's kappa and omega_n; Table 3.13 lists 1.161 mm with the FEA's):

    >>> round(effective_thickness(1.640, 7.709e6, 1410.0, 2786.0) * 1e3, 2)
    1.16
    """
    return gamma1 * kappa / (density * omega_n**2)


def gamma1_alternative(density: float, h_eff: float, omega_n: float, kappa: float) -> float:
    """gamma1 from frequency and stiffness alone, gamma1 = rho_c h_eff omega_n^2 / kappa (eq 3.48).

    Parameters
    ----------
    density : float
        rho_c [kg/m^3].
    h_eff : float
        Effective thickness [m].
    omega_n : float
        First frequency [rad/s].
    kappa : float
        Stiffness [Pa/m].

    Returns
    -------
    float
        gamma1 [-].

    References
    ----------
    Knutson (2016), eq 3.48, Table 3.9.

    Examples
    --------
    >>> round(gamma1_alternative(1410.0, effective_thickness(1.534, 7.345e6, 1410.0, 2427.0), 2427.0, 7.345e6), 3)
    1.534
    """
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
