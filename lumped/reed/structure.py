"""The reed valve beyond one mode: its structural matrices for the pump (modal basis or the whole FE reed).

A reed valve with ``dynamics = "modal"`` (its first N modes, :func:`lumped.reed.modal_basis.modal_basis`)
or ``"fe"`` (the whole finite-element reed, :func:`lumped.reed.modal_basis.fe_reed`) has N generalised
coordinates q [m] and obeys (SI units, forces in N)::

    M q'' + C q' + K (q - q0) = b [dP X(x) + F_c(x, x')] - Q_drag(q')        (modal reed)

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
  (Gamma_i = int_F phi_i dA; FE: the consistent nodal loads);
- x = e . q, the port's opening: the footprint's load-weighted lift, e = b c_1 / Gamma_1, scaled so
  that with one mode it is the tip deflection (eq 3.21's x: the tip is where X(x) and l_o were
  measured; c_1 = phi_1(tip) of the mode that scales the opening);
- the pressure dP X(x) (X of eq 3.83) and the seat and stop contacts F_c(x, x') (eq 2.20 per unit
  area, as eq 3.21's F_c) act on x and are spread like the load, over the footprint: the generalised
  force of each is b times its pressure. All the reed exchanges with the flow, its seat and its stop
  goes through the footprint's lift; the higher modes enter through their share of it (the bending
  that lifts the footprint, the torsion an off-axis port loads). valvelab's model. It is conservative
  (b is parallel to e, so each force is the gradient of a potential in x): a multiplier of the tip's
  lift on a load spread over the face is not, and with two modes it made the prototype reed flutter
  onto its stop (84 impacts a revolution, which the measured positions of Figures 5.19-5.21 do not
  show); a seat acting on the tip alone let the modes bend the seated reed 1 mm through it;
- q0: the rest shape, the static shape under the uniform pressure that puts the opening at the
  valve's rest opening x_0 (seat.preload; eq 3.21's gamma1 kappa (x - x_0));
- Q_drag: the quadratic drag of eq 3.21 per strip, 1/2 rho C_D |wbar'| wbar' on the width-mean
  deflection rate at the stations (with damping.drag on; its gamma2 projection at one mode).

With one mode (whole face, tip normalisation) this is eq 3.21 with its integrals taken over the
first mode shape instead of the static shape eq 3.21's kappa and gammas come from (about 1 % apart in
the static tip deflection; docs/reed_dynamics.md).

:func:`structure` assembles (M, C, K, b, e, q0, strips) for a valve; :func:`tail` packs A = M^-1 K,
B = M^-1 C, g = M^-1 b and the drag's strips for the compiled accelerations
(:func:`lumped.valves.reed.reed_accelerations`). A modal reed's are packed in the pump's coordinates
z = S q (:func:`coordinates`): the opening x = e . q first, then the modes but the one with the largest
weight in it. With the opening a state of its own, the fast path holds it, in contact with the seat or
stop, to the contact's tolerance (nanometres into a stiff seat: lumped.solver.steppers.tolerance_table), and the
other coordinates, whose positions the contact does not hold, to the free flight's
(lumped.solver.layout.valve_tolerances): 6 % fewer steps with three modes, the timing as close to the reference
stepper's (benchmarks/bench_reed_dynamics.py). The FE reed keeps its nodal DOFs (z = q): it runs on the
reference stepper, whose tolerances are the states' scales, and a change of coordinates that mixes its
DOFs would cost its eigenvalues 1e-8 of their precision.
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
    load: np.ndarray            # (n,): b [m^2]
    opening: np.ndarray         # (n,): e, x = e . q the port's opening [-]
    sealing: np.ndarray         # (n,): c, the mean lift of the footprint's outline (the tip for the whole face) [-]
    tip: np.ndarray             # (n,): the tip centre's deflection per unit q [-]
    rest: np.ndarray            # (n,): q0 [m]
    wbar: np.ndarray            # (K, n): width-mean deflection at the stations per unit q [-]
    areas: np.ndarray           # (K,): weight_k W_k, the strips' areas [m^2]
    frequencies: np.ndarray     # rad/s in vacuum (the basis's or the FE reed's)
    kinds: tuple

    @property
    def n(self) -> int:
        return len(self.load)


def damping_ratio(valve) -> float:
    """The damping ratio of eq 3.21's one mode, zeta = gamma1 c / (2 rho_c h_eff omega_n), omega_n = sqrt(gamma1
    kappa / (rho_c h_eff)) (eq 3.72), c = c_c + c_f.

    Parameters
    ----------
    valve : lumped.model.pump.ReedValve
        Its ``gamma1`` [-], ``stiffness`` kappa [Pa/m], ``damping`` c [Pa s/m], ``density`` rho_c [kg/m^3] and
        ``effective_thickness`` h_eff [m].

    Returns
    -------
    float
        zeta [-].

    References
    ----------
    Knutson (2016), eqs 3.21, 3.69, 3.72; Table 3.10.

    Examples
    --------
    The prototype reed: gamma1 1.640, c_c 77.50 Pa s/m and kappa 7.709 MPa/m (Table 3.10), rho_c 1410 kg/m^3 and
    h_eff 1.161 mm (Table 3.13), so omega_n = 2779 rad/s (Table 3.10: 2786) and zeta = gamma1 c / (2 rho_c h_eff
    omega_n):

    >>> from types import SimpleNamespace
    >>> v = SimpleNamespace(gamma1=1.640, stiffness=7.709e6, damping=77.50, density=1410.0,
    ...                     effective_thickness=1.161e-3)
    >>> print(f"{damping_ratio(v):.4f}")
    0.0140
    """
    m = valve.density * valve.effective_thickness
    omega_n = math.sqrt(valve.gamma1 * valve.stiffness / m)
    return valve.gamma1 * valve.damping / (2.0 * m * omega_n)


def _rest(stiffness, load, opening, x0: float) -> np.ndarray:
    """q0: the static shape under a uniform pressure P0 on the footprint with opening e . q0 = x0."""
    unit = np.linalg.solve(stiffness, load)
    return unit * (x0 / float(opening @ unit))


@functools.lru_cache(maxsize=64)
def structure(valve, rho_oil: float) -> Structure:
    """The structural matrices of a reed valve with ``dynamics`` "modal" or "fe" in oil: M q'' + C q' + K (q - q0) =
    b [dP X(x) + F_c] - Q_drag (module docstring).

    Parameters
    ----------
    valve : lumped.model.pump.ReedValve
        A reed valve with ``dynamics`` "modal" or "fe".
    rho_oil : float
        Oil density [kg/m^3].

    Returns
    -------
    Structure
        M [kg], C [N s/m], K [N/m], b [m^2], e, c, tip [-], q0 [m], the strips' width-mean deflections and areas
        [m^2], the vacuum frequencies [rad/s]. Cached: a model is packed for every simulation.

    References
    ----------
    Knutson (2016), eqs 3.17, 3.21; Sader (1998); Green & Sader (2002).
    """
    parts = _modal(valve, rho_oil) if valve.dynamics == "modal" else _fe(valve, rho_oil)
    mass, damping, stiffness, load, sealing, tip, wbar, areas, freqs, kinds, scale = parts
    opening = scale * load
    rest = _rest(stiffness, load, opening, valve.preload)
    return Structure(mass, damping, stiffness, load, opening, sealing, tip, rest, np.ascontiguousarray(wbar),
                     areas, freqs, kinds)


def _modal(valve, rho_oil: float) -> tuple:
    """The modal reed's (M, C, K, b, c, tip, wbar, areas, omega, names, c_1 / Gamma_1): diagonal modal mass and
    stiffness, the added mass of the strips, every mode damped at eq 3.21's ratio."""
    from lumped.reed.modal_basis import _opening_mode, modal_basis

    where = f"valves.{valve.position}"
    zeta, gamma_f = damping_ratio(valve), valve.hydrodynamic_function
    b = modal_basis(valve.reed, valve.fidelity or "analytic", valve.modes, valve.port, valve.mesh_size,
                    field=f"{where}.modes", fidelity_field=f"{where}.fidelity", port_field=f"{where}.port")
    m, k = np.asarray(b.modal_mass), np.asarray(b.modal_stiffness)
    mass = np.diag(m) + (b.added_mass(rho_oil, gamma_f, gamma_f) if gamma_f > 0 else 0.0)
    load, sealing = np.asarray(b.load), np.asarray(b.opening)
    i1 = _opening_mode(b.tip)
    return (mass, np.diag(2.0 * zeta * np.sqrt(k * m)), np.diag(k), load, sealing, np.asarray(b.tip),
            np.asarray(b.wbar).T, np.asarray(b.weights) * np.asarray(b.widths), np.asarray(b.omega), tuple(b.kinds),
            sealing[i1] / load[i1])


def _fe(valve, rho_oil: float) -> tuple:
    """The whole FE reed's (M, C, K, f, c, tip, wbar, areas, omega, names, c_1 / Gamma_1): its matrices, the
    strips' added mass (flexural and torsional), C = M Phi diag(2 zeta omega) Phi^T M in its mass-normalised
    modes."""
    from lumped.reed.modal_basis import _opening_mode, fe_reed

    where = f"valves.{valve.position}"
    zeta, gamma_f = damping_ratio(valve), valve.hydrodynamic_function
    # the exact E-B model (analytic) has no element mesh: its FE reed is the beam's
    fid = "beam" if (valve.fidelity or "analytic") == "analytic" else valve.fidelity
    fe = fe_reed(valve.reed, valve.port, fid, valve.mesh_size, fidelity_field=f"{where}.fidelity",
                 port_field=f"{where}.port")
    wbar, widths = np.asarray(fe.wbar), np.asarray(fe.widths)
    mass = np.array(fe.mass, dtype=float)
    if gamma_f > 0:
        w2, th = np.asarray(fe.weights) * widths ** 2, np.asarray(fe.theta)
        mass = mass + rho_oil * (math.pi / 4 * gamma_f * (wbar.T * w2) @ wbar
                                 + math.pi / 128 * gamma_f * (th.T * w2 * widths ** 2) @ th)
    omega, phi = fe.modes()
    mp = fe.mass @ phi
    load, sealing, tip = np.asarray(fe.load), np.asarray(fe.opening), np.asarray(fe.tip)
    shapes = phi[:, :6] / np.abs(phi[:, :6]).max(axis=0)
    i1 = _opening_mode(tip @ shapes)
    return (mass, mp @ np.diag(2.0 * zeta * omega) @ mp.T, np.array(fe.stiffness, dtype=float), load, sealing, tip,
            wbar, np.asarray(fe.weights) * widths, omega, ("fe",) * len(omega),
            (sealing @ phi[:, i1]) / (load @ phi[:, i1]))


def coordinates(opening: np.ndarray, dynamics: str = "modal") -> tuple[np.ndarray, np.ndarray]:
    """The pump's coordinates z = S q of a modal reed: z_0 = x = e . q, then every q_j but the pivot (the j of the
    largest |e_j|); the identity for the FE reed.

    Parameters
    ----------
    opening : array of float
        e, the opening's weights (x = e . q) [-].
    dynamics : str
        "modal" or "fe".

    Returns
    -------
    (S, T) : tuple of array of float
        S and T = S^-1, (n, n) [-]; q_pivot = (x - sum of the others' e_j q_j) / e_pivot.
    """
    n = len(opening)
    if dynamics != "modal":
        return np.eye(n), np.eye(n)
    pivot = int(np.argmax(np.abs(opening)))
    s = np.zeros((n, n))
    s[0] = opening
    for k, j in enumerate(j for j in range(n) if j != pivot):
        s[k + 1, j] = 1.0
    return s, np.linalg.inv(s)


def tail(valve, rho_oil: float) -> np.ndarray:
    """The packed data of lumped.valves.reed.reed_accelerations in the coordinates z = S q (:func:`coordinates`),
    row-major: [e T = (1, 0, ..) (n) | S g (n) | S q0 (n) | S A T (n^2) | S B T (n^2) | S D (n K) | wbar T (K n)].

    g = M^-1 b, A = M^-1 K, B = M^-1 C, D = M^-1 wbar^T diag(areas). The opening weights come first:
    lumped.solver.layout reads them there.

    Parameters
    ----------
    valve : lumped.model.pump.ReedValve
        A reed valve with ``dynamics`` "modal" or "fe".
    rho_oil : float
        Oil density [kg/m^3].

    Returns
    -------
    array of float
        The tail (SI: 1/s^2, 1/s, m^2/kg, m, -).
    """
    st = structure(valve, rho_oil)
    s, t = coordinates(st.opening, valve.dynamics)
    minv = np.linalg.inv(st.mass)
    parts = [st.opening @ t, s @ (minv @ st.load), s @ st.rest, (s @ minv @ st.stiffness @ t).ravel(),
             (s @ minv @ st.damping @ t).ravel(), (s @ minv @ (st.wbar.T * st.areas)).ravel(), (st.wbar @ t).ravel()]
    return np.concatenate([np.asarray(a, dtype=float) for a in parts])


def modal_shares(valve, rho_oil: float, z: np.ndarray) -> np.ndarray:
    """Each mode's share e_i q_i of the opening, from the pump's coordinates z (q = T z).

    Parameters
    ----------
    valve : lumped.model.pump.ReedValve
        A reed valve with ``dynamics`` "modal" or "fe".
    rho_oil : float
        Oil density [kg/m^3].
    z : array of float
        (samples, n): the reed's coordinates [m].

    Returns
    -------
    array of float
        (samples, n): e_i q_i [m]; each row sums to the opening x.
    """
    st = structure(valve, rho_oil)
    _, t = coordinates(st.opening, valve.dynamics)
    return (np.asarray(z) @ t.T) * st.opening


def n_stations(valve, rho_oil: float) -> int:
    """The number of strips the reed's drag acts on (the basis's or the FE reed's stations).

    Parameters
    ----------
    valve : lumped.model.pump.ReedValve
        A reed valve with ``dynamics`` "modal" or "fe".
    rho_oil : float
        Oil density [kg/m^3].

    Returns
    -------
    int
        K.
    """
    return structure(valve, rho_oil).wbar.shape[0]
