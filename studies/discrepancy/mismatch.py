"""Mismatched-model data: synthetic runs from model forms the candidate library does not contain.

A dataset made by the very model the workflow fits (the inverse crime) tests the search, not the
decision: real data come from a pump no model reproduces. Each :class:`Variant` here changes the
*form* of the physics the data are made with, beyond any value of the library's parameters, and is
applied on top of the hidden effects (``studies.discrepancy.confusion``, cases with ``form``):

- ``film_tension``: the squeeze film holds a tension of 2-15 kPa before it cavitates (Roemer et al. 2015
  measured oils holding tension below the vapour pressure); the library's film cavitates at the vapour
  pressure, so the inlet disc lets go of its seat 0.6-5 deg later in the data than in any fitted model at
  the thesis's conditions (3 deg at 10 kPa, 12 deg at 30 kPa; at 100 kPa, an atmosphere, it never opens);
- ``film_gap``: the residual film at seat contact is 0.3-0.6 um or 2-3 um thick, not the library's 1 um;
  the film's force grows as 1/h^3, so its release and the hover height differ;
- ``jet_weak``: the steady force at 60-90 % of eq 2.36 (its momentum term rho q^2 / A_port too, which no jet
  angle scales) and the transient at 50-80 % of eq 2.37 (its momentum term q u too, which no oil-column length
  scales): a jet law the library's (eqs 2.36 and 2.37 with one jet angle and one oil column) takes only
  approximately. (Without its transient term at all, the thesis disc's flow force leaves a gap within the
  noise: held-out 0.9 units; stronger, at 1.5-3 times eq 2.37, it acts as an added mass of the oil column
  beyond the plausible length and is named as one);
- ``seat_underdamped``: a compliant seat damped at 10-40 % of critical; the library's seat is critically
  damped (eq 2.23), so the valve rings on it in the data;
- ``air_isothermal``: the entrained air compressed isothermally (polytropic exponent 1.0, eq 4.9); the
  model's air is adiabatic (1.4);
- ``leak_length``: the piston's sealing length 8-14 mm, not the model pump's 20 mm: a leak of the same
  clearance conducts 1.4-2.5 times more (eq 4.5); the fitted clearance is then an effective one (compare
  the conductance);
- ``cd_error``: the discharge coefficient off by 1-2 % (a nuisance the workflow fits, here on top of an
  effect);
- ``sensor``: rig vibration (2-5 um at 37-180 Hz) and a drift (3-8 um over the record) on the position
  readings and a 0.5-1 % gain error of the pressure transducer.

Every variant draws its values log-uniformly from its ranges by the dataset's seed and records them in
truth.toml (``model_form``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from lumped.model.effect_library import resolve
from lumped.model.pump_model import POSITIONS

from studies.discrepancy.pump_sim import PumpSimulator


def _valves(model, **changes):
    """``model`` with the same field changes on both valves (those that have the fields)."""
    out = {}
    for pos in POSITIONS:
        v = model.valve(pos)
        have = {k: x for k, x in changes.items() if k in type(v).__dataclass_fields__}
        if have:
            out[pos] = replace(v, **have)
    return replace(model, **out)


def _film_tension(m, v):
    return _valves(m, squeeze_tensile_strength=v["sigma_t"])


def _film_gap(m, v):
    return _valves(m, squeeze_min_gap=v["h_r"])


def _jet_weak(m, v):
    return replace(m, **{p: replace(m.valve(p), flow_force_steady=v["steady"], flow_force_transient=v["transient"])
                         for p in POSITIONS if getattr(m.valve(p), "flow_force_steady", 0.0) > 0.0})


def _seat_underdamped(m, v):
    out = {}
    for p in POSITIONS:
        valve = m.valve(p)
        k = getattr(valve, "seat_stiffness", None)
        if k is None or k >= 1e9 or not hasattr(valve, "contact_mass"):
            continue                                 # a rigid seat rings at MHz: leave it
        crit = 2.0 * math.sqrt(k * valve.contact_mass)
        out[p] = replace(valve, seat_damping=v["zeta"] * crit)
    return replace(m, **out)


def _air_isothermal(m, v):
    return replace(m, oil=replace(m.oil, polytropic_exponent=1.0))


def _leak_length(m, v):
    return replace(m, pump=replace(m.pump, seal_length=v["L"]))


def _cd_error(m, v):
    s = v["scale"]
    return replace(m, **{p: replace(m.valve(p), cd_inf=m.valve(p).cd_inf * s, cd_a=m.valve(p).cd_a * s)
                         for p in POSITIONS})


@dataclass(frozen=True)
class Variant:
    """A model form the library lacks: ``apply(resolved model, values) -> model``; ``ranges`` {name: (lo, hi)}
    drawn log-uniformly (a negative pair: either sign of the magnitude); ``noise``: extra Noise fields
    (studies.discrepancy.synth.Noise) drawn the same way; ``kinds`` the valve kinds it has a meaning for."""

    name: str
    what: str
    apply: Callable | None = None
    ranges: dict = None
    noise: dict = None
    kinds: tuple = ("disc", "reed", "ball")


VARIANTS = {v.name: v for v in (
    Variant("film_tension", "the squeeze film cavitates at the vapour pressure minus a tensile strength of 2-15 kPa",
            _film_tension, {"sigma_t": (2e3, 1.5e4)}, kinds=("disc",)),
    Variant("film_gap", "the squeeze film's residual thickness at seat contact 0.3-0.6 um (the library's 1 um)",
            _film_gap, {"h_r": (3e-7, 6e-7)}, kinds=("disc",)),
    Variant("jet_weak", "the steady flow force at 60-90 % of eq 2.36, the transient at 50-80 % of eq 2.37",
            _jet_weak, {"steady": (0.6, 0.9), "transient": (0.5, 0.8)}, kinds=("disc",)),
    Variant("seat_underdamped", "a compliant seat damped at 10-40 % of critical (the library's: critical, eq 2.23)",
            _seat_underdamped, {"zeta": (0.1, 0.4)}, kinds=("disc", "ball")),
    Variant("air_isothermal", "the entrained air compressed isothermally (polytropic exponent 1.0, the model's 1.4)",
            _air_isothermal, {}),
    Variant("leak_length", "the piston's sealing length 8-14 mm (the model pump's 20 mm): 1.4-2.5 times the "
            "conductance of the same clearance", _leak_length, {"L": (8e-3, 14e-3)}),
    Variant("cd_error", "the discharge coefficient 1-2 % off", _cd_error, {"scale": (-1.01, -1.02)}),
    Variant("sensor", "rig vibration (2-5 um, 37-180 Hz) and drift (3-8 um) on the positions, a 0.5-1 % gain error "
            "of the pressure transducer", None, {}, {"vibration_m": (2e-6, 5e-6), "vibration_hz": (37.0, 180.0),
                                                    "drift_m": (3e-6, 8e-6), "pressure_gain_error": (-0.005, -0.01)}),
)}


def draw(ranges: dict | None, rng: np.random.Generator) -> dict:
    """Values drawn log-uniformly from ``ranges``; a pair of negative numbers -a, -b gives +-[a, b] (a random
    sign; for ``scale`` a factor 1 +- (x - 1))."""
    out = {}
    for k, (lo, hi) in (ranges or {}).items():
        if lo < 0 and hi < 0:
            mag = math.exp(rng.uniform(math.log(-lo), math.log(-hi)))
            sign = rng.choice((-1.0, 1.0))
            out[k] = 1.0 + sign * (mag - 1.0) if k == "scale" else sign * mag
        else:
            out[k] = float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
    return out


@dataclass(frozen=True)
class MismatchSimulator(PumpSimulator):
    """A PumpSimulator whose model carries a model-form variant on top of the applied effects (synthesis only)."""

    variant: str = ""
    values: tuple = ()

    def model_for(self, cond, effects: tuple):
        m = super().model_for(cond, effects)
        v = VARIANTS[self.variant]
        if v.apply is None:
            return m
        return replace(v.apply(resolve(m), dict(self.values)), effects=())

    def truth_form(self) -> dict:
        """What truth.toml records of the variant."""
        return {"variant": self.variant, "what": VARIANTS[self.variant].what, **dict(self.values)}


def mismatched(simulator: PumpSimulator, variant: str, rng: np.random.Generator) -> tuple[PumpSimulator, dict]:
    """(a simulator making data with ``variant``'s model form, the extra Noise fields it draws)."""
    v = VARIANTS[variant]
    vals = draw(v.ranges, rng)
    noise = draw(v.noise, rng)
    sim = MismatchSimulator(simulator.model, simulator.rtol, variant, tuple(sorted(vals.items())))
    return sim, noise
