"""The reed valve beyond one mode: its structural matrices for the pump (modal basis or the whole FE reed).

A reed valve with ``dynamics = "modal"`` (its first N modes, :func:`lumped.reed_modes.modal_basis`)
or ``"fe"`` (the whole finite-element reed, :func:`lumped.reed_modes.fe_reed`) has N generalised
coordinates q [m] and obeys (SI units, forces in N)::

    M q'' + C q' + K (q - q0) = b [dP X(x) + F_c(x, x')] - f_drag(q')        (modal reed)

- M: the modal (diagonal) or FE mass matrix, plus the strip-theory added mass of the oil
  (rho pi/4 Gamma_f int wbar_i wbar_j W^2 ds + rho pi/128 Gamma_f int theta_i theta_j W^4 ds, eq 3.17
  extended per strip, Sader 1998 and Green & Sader 2002; valvelab takes the torsional
  hydrodynamic function equal to the flexural one) when the added_mass effect is on;
- K: modal stiffness diag(m_i omega_i^2) or the FE stiffness matrix;
- C: every mode damped at the damping ratio of eq 3.21's one mode, zeta = gamma1 c / (2 rho_c
  h_eff omega_n) with c = c_c + c_f (the thesis identified c_c from the plucked reed's first mode,
  Table 3.10, and c_f at its frequency, eq 3.80; it has no data for higher modes, so the ratio is
  held: valvelab's assumption). Modal: C = diag(2 zeta sqrt(k_i m_i)); FE: C = M Phi diag(2 zeta
  omega_i) Phi^T M in the FE reed's own mass-normalised modes Phi, so that the FE reed and the modal
  reed with every mode are the same damped system;
- b: the load of a unit pressure over the port footprint projected on each coordinate
  (Gamma_i = int_F phi_i dA; FE: the consistent nodal loads); the pressure is eq 3.21's dP X(x),
  X of eq 3.83 evaluated at the opening x;
- x = c . q: the opening, the mean lift over the footprint's outline scaled to the first mode's tip
  (lumped.reed_modes), on which the contact state switches (lumped.switching, as for every kind);
- the seat: while seated the reed lies on its seat lands, which hold its whole face: a Winkler
  foundation of the seat stiffness and damping per unit area (eq 2.20's k_seat, c_seat, Pa/m and
  Pa s/m), K_f = k_seat F, C_f = c_seat F with F_ij = int phi_i phi_j dA over the face (width-mean
  deflection and twist at the stations). A seat acting on x alone lets the modes wrap through it
  (with three modes the seated inlet reed bent 1 mm through its seat while its tip stayed at 0);
  valvelab's model;
- the stop: a limiter the reed's tip runs into, acting where x is measured: F_c(x, x') A_c c with
  eq 2.20's stop branch, so the contact does the work F_c A_c dx (conservative); A_c = Gamma_1 / c_1
  of the mode that scales the opening makes one mode eq 3.21's gamma1 F_c; valvelab's assumption;
- q0: the rest shape, the static shape under the uniform pressure that puts the opening at the
  valve's rest opening x_0 (seat.preload; eq 3.21's gamma1 kappa (x - x_0));
- f_drag: the quadratic drag of eq 3.21 per strip, 1/2 rho C_D |wdot| wdot on the width-mean
  deflection rate at the stations (with damping.drag on; its gamma2 projection at one mode).

With one mode (whole face, tip normalisation) this is eq 3.21 with its integrals taken over the
first mode shape instead of the static shape eq 3.21's kappa and gammas come from (about 1 % apart in
the static tip deflection; docs/reed_dynamics.md).

:func:`structure` assembles (M, C, K, b, c, q0, drag stations) for a valve; :func:`tail` packs
A = M^-1 K, B = M^-1 C, g = M^-1 b and the drag matrices for the compiled accelerations
(:func:`lumped.reed_valve.reed_accelerations`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

#: reed dynamics by name (model-file key ``dynamics``) and their codes in the packed block
DYNAMICS = ("one-mode", "modal", "fe")
ONE_MODE, MODAL, FE = range(3)


@dataclass(frozen=True, eq=False)
class Structure:
    """The structural matrices of a modal or FE reed valve (SI: kg, N s/m, N/m, m^2, -, m)."""

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    load: np.ndarray
    opening: np.ndarray
    rest: np.ndarray
    contact: np.ndarray         # (n,): A_c c, the generalised stop force of a unit F_c [m^2]
    foundation: np.ndarray      # (n, n): F = int phi_i phi_j dA over the face [m^2], the seat per unit k_seat
    drag_rows: np.ndarray       # (n, K): wbar_i(s_k) weight_k W_k, the drag's projection
    drag_rates: np.ndarray      # (K, n): wbar_i(s_k), the stations' rates from q'
    frequencies: np.ndarray     # rad/s in vacuum (the basis's or the FE reed's lowest n)
    kinds: tuple

    @property
    def n(self) -> int:
        return len(self.load)


def damping_ratio(valve) -> float:
    """zeta = gamma1 c / (2 rho_c h_eff omega_n) of eq 3.21's one mode (c = c_c + c_f) [-]."""
    m = valve.density * valve.effective_thickness
    omega_n = math.sqrt(valve.gamma1 * valve.stiffness / m)
    return valve.gamma1 * valve.damping / (2.0 * m * omega_n)


def _rest(stiffness, load, opening, x0: float) -> np.ndarray:
    """q0: the static shape under a uniform pressure P0 on the footprint with opening c . q0 = x0."""
    unit = np.linalg.solve(stiffness, load)
    return unit * (x0 / float(opening @ unit))


@functools.lru_cache(maxsize=64)
def structure(valve, rho_oil: float) -> Structure:
    """The matrices of a reed valve with ``dynamics`` "modal" or "fe" in oil of density rho_oil [kg/m^3]
    (cached: a model is packed for every simulation)."""
    from lumped.reed_modes import _opening_mode, fe_reed, modal_basis

    where = f"valves.{valve.position}"
    port = valve.port
    zeta = damping_ratio(valve)
    gamma_f = valve.hydrodynamic_function
    if valve.dynamics == "modal":
        b = modal_basis(valve.reed, valve.fidelity or "analytic", valve.modes, port, valve.mesh_size,
                        field=f"{where}.modes", fidelity_field=f"{where}.fidelity", port_field=f"{where}.port")
        m, k = np.asarray(b.modal_mass), np.asarray(b.modal_stiffness)
        mass = np.diag(m) + (b.added_mass(rho_oil, gamma_f, gamma_f) if gamma_f > 0 else 0.0)
        stiffness = np.diag(k)
        damping = np.diag(2.0 * zeta * np.sqrt(k * m))
        load, opening = np.asarray(b.load), np.asarray(b.opening)
        wbar, w = np.asarray(b.wbar), np.asarray(b.weights) * np.asarray(b.widths)
        freqs, kinds = np.asarray(b.omega), tuple(b.kinds)
        i1 = _opening_mode(b.tip)
        contact = load[i1] / opening[i1] * opening
        foundation = _foundation(wbar, np.asarray(b.theta), np.asarray(b.weights), np.asarray(b.widths))
    else:
        fe = fe_reed(valve.reed, port, valve.fidelity or "beam", valve.mesh_size,
                     fidelity_field=f"{where}.fidelity", port_field=f"{where}.port")
        wbar, w = np.asarray(fe.wbar).T, np.asarray(fe.weights) * np.asarray(fe.widths)
        mass = np.array(fe.mass, dtype=float)
        if gamma_f > 0:
            w2 = np.asarray(fe.weights) * np.asarray(fe.widths) ** 2
            th = np.asarray(fe.theta).T
            mass = mass + rho_oil * (math.pi / 4 * gamma_f * (wbar * w2) @ wbar.T
                                     + math.pi / 128 * gamma_f * (th * w2 * np.asarray(fe.widths) ** 2) @ th.T)
        stiffness = np.array(fe.stiffness, dtype=float)
        omega, phi = fe.modes()
        mp = fe.mass @ phi
        damping = mp @ np.diag(2.0 * zeta * omega) @ mp.T
        load, opening = np.asarray(fe.load), np.asarray(fe.opening)
        freqs, kinds = omega, ("fe",) * len(omega)
        tips = fe.tip @ phi[:, :6]
        scale = np.abs(phi[:, :6]).max(axis=0)
        i1 = _opening_mode(tips / scale)
        contact = (load @ phi[:, i1]) / (opening @ phi[:, i1]) * opening
        foundation = _foundation(wbar, np.asarray(fe.theta).T, np.asarray(fe.weights), np.asarray(fe.widths))
    rest = _rest(stiffness, load, opening, valve.preload)
    return Structure(mass, damping, stiffness, load, opening, rest, contact, foundation, wbar * w, wbar.T, freqs,
                     kinds)


def _foundation(wbar, theta, weights, widths) -> np.ndarray:
    """F_ij = int phi_i phi_j dA [m^2] over the face, the shapes linear across the width at each station:
    sum_k weight_k (W_k wbar_ik wbar_jk + W_k^3 / 12 theta_ik theta_jk)."""
    return (wbar * weights * widths) @ wbar.T + (theta * weights * widths**3 / 12.0) @ theta.T


def tail(valve, rho_oil: float) -> np.ndarray:
    """The packed data of :func:`lumped.reed_valve.reed_accelerations`: [c (n) | g = M^-1 b (n) |
    h = M^-1 A_c c (n) | q0 (n) | A = M^-1 K (n^2) | B = M^-1 C (n^2) | M^-1 F (n^2) | D = M^-1 drag rows
    (n K) | drag rates (K n)], row-major. The opening weights c come first: lumped.layout reads them there."""
    s = structure(valve, rho_oil)
    minv = np.linalg.inv(s.mass)
    parts = [s.opening, minv @ s.load, minv @ s.contact, s.rest, (minv @ s.stiffness).ravel(),
             (minv @ s.damping).ravel(), (minv @ s.foundation).ravel(), (minv @ s.drag_rows).ravel(),
             np.ascontiguousarray(s.drag_rates).ravel()]
    return np.concatenate([np.asarray(a, dtype=float) for a in parts])


def n_stations(valve, rho_oil: float) -> int:
    """Stations of the drag's strips (the basis's or the FE reed's)."""
    return structure(valve, rho_oil).drag_rates.shape[0]
