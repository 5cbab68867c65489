"""A reed's bending stress at a lift: Euler-Bernoulli in the loop, calibrated against the solid FEA.

**The design stress** is the solid FEA's maximum von Mises stress **away from the clamp**
(s > 2 h, :func:`fea.reed_stress.max_opening_stress`, ``max_von_mises_away_from_clamp``) with
the tip deflected to the stop; the clamped edge itself is a stress singularity of 3-D elasticity
whose value grows with mesh refinement (reported as ``stress_solid_at_clamp_mpa``, not
constrained). The tip deflection at maximum lift is ``x_stop - x_0`` (``stop.gap`` minus
``seat.preload``: a reed pressed onto its seat, x_0 < 0, is already bent when closed).

**In the optimisation loop** each design's stress is estimated in milliseconds as

    sigma_est = C * max_s M(s) c(s) / I(s)

the largest Euler-Bernoulli (nominal) bending stress along the reed under the uniform pressure
kappa_EB (x_stop - x_0) that puts its tip at that deflection (the clamp root for the thesis
reeds; grooves and steps enter I(s) and the fibre distance c(s);
:func:`fea.reed_stress.beam_bending_stress`), times a calibration factor C measured with the
solid FEA (:func:`studies.sweeps.design.study.calibrate`): by default the ratio solid / E-B of the
base model's reed (0.95 for the prototype: 31.7 MPa / 33.3 MPa at its default mesh), so the
estimate reproduces the solid FEA there.

What the estimate cannot see: the 3-D stress concentrations at a width step's re-entrant
corner and at the groove ends, which set the solid's maximum away from the clamp. On the 12
re-checked front designs of the reed example the ratio solid / estimate spans 0.78 to 1.75
(docs/optimization.md), so every
design of the final front is re-checked with the solid FEA itself, a design whose estimate is
more than ``recheck.stress_tolerance_pct`` below the solid is flagged, and the final constraint
check uses the solid value. ``stress.calibration = "conservative"`` takes the largest ratio over
the base, centre and range-end designs instead (safe in the loop, but it may exclude designs
the solid FEA would accept, the prototype included).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

#: E-B stress is evaluated at this many sections along the reed (plus both sides of each piece boundary)
N_SECTIONS = 48


def lift_deflection(valve, lift: float | None = None) -> float:
    """Tip deflection [m] from the reed's unloaded shape at tip opening ``lift`` (default: the stop)."""
    x = valve.stop_gap if lift is None else min(float(lift), valve.stop_gap)
    return x - valve.preload


def eb_kappa(valve) -> float:
    """kappa [Pa/m] of the Euler-Bernoulli (analytic) model of a reed valve's geometry."""
    if valve.fidelity == "analytic":
        return float(valve.stiffness)
    return _analytic_kappa(valve.reed)


@lru_cache(maxsize=256)
def _analytic_kappa(reed) -> float:
    from lumped.reed.fidelities import reed_properties

    return float(reed_properties(reed, "analytic").kappa)


def _sections(reed) -> np.ndarray:
    s = list(np.linspace(0.0, reed.length, N_SECTIONS, endpoint=False))
    for piece in reed.pieces():
        for b in (piece.s0, piece.s1):
            for x in (b * (1 - 1e-9), b * (1 + 1e-9)):
                if 0.0 <= x < reed.length:
                    s.append(x)
    return np.unique(np.asarray(s))


def eb_stress(reed, deflection: float, kappa: float) -> float:
    """The largest E-B bending stress [Pa] along the reed with the tip deflected by ``deflection`` under a
    uniform pressure p = kappa deflection."""
    from fea.reed_stress import beam_bending_stress

    p = kappa * deflection
    return float(max(beam_bending_stress(reed, p, float(s)) for s in _sections(reed)))


def reed_outputs(model, calibration: dict) -> dict:
    """Per reed valve: kappa, omega and (with a geometry and a calibration factor) the estimated stress at the
    stop; keys ``<pos>_kappa_pa_m``, ``<pos>_omega_rad_s``, ``<pos>_reed_stress_pa``, ``<pos>_reed_stress_eb_pa``
    (``<pos>_reed_stress_peak_pa`` is filled per operating point by the caller)."""
    out = {}
    for pos in ("inlet", "delivery"):
        v = model.valve(pos)
        keys = ("kappa_pa_m", "omega_rad_s", "reed_stress_pa", "reed_stress_peak_pa", "reed_stress_eb_pa")
        row = dict.fromkeys((f"{pos}_{k}" for k in keys))
        if type(v).__name__ == "ReedValve":
            row[f"{pos}_kappa_pa_m"] = float(v.stiffness)
            row[f"{pos}_omega_rad_s"] = float(v.natural_frequency())
        c = calibration.get(pos)
        if getattr(v, "reed", None) is not None and c:
            eb = eb_stress(v.reed, lift_deflection(v), eb_kappa(v))
            row[f"{pos}_reed_stress_eb_pa"] = eb
            row[f"{pos}_reed_stress_pa"] = c * eb
        out.update(row)
    return out


def solid_stress(reed, deflection: float, mesh_size=None) -> dict:
    """The solid FEA's stress with the tip at ``deflection``: ``away`` (the design stress), ``max`` (at the clamp
    edge, mesh dependent), ``pressure``, ``dofs``, ``mesh_size`` (SI)."""
    from fea.reed_stress import max_opening_stress

    sc = max_opening_stress(reed, x_stop=deflection, mesh_size=mesh_size)
    return {"away": sc.max_von_mises_away_from_clamp, "max": sc.max_von_mises, "pressure": sc.pressure,
            "dofs": sc.dofs, "mesh_size": sc.mesh_size}


def calibration_row(reed, deflection: float, mesh_size=None) -> dict:
    """One calibration reed: the E-B stress, the solid FEA's and their ratio (Pa)."""
    eb = eb_stress(reed, deflection, _analytic_kappa(reed))
    sol = solid_stress(reed, deflection, mesh_size)
    return {"eb_pa": eb, "solid_away_pa": sol["away"], "solid_max_pa": sol["max"], "ratio": sol["away"] / eb,
            "dofs": sol["dofs"], "mesh_size": sol["mesh_size"]}
