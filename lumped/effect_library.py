"""The candidate effects of CONTRACT.md for valvelab's pump model (``lumped.params``).

One :func:`register` call per effect: its parameters (bounds searched in log space,
the physical prior and where it comes from, the plausible range) and how it switches
the effect on in a :class:`lumped.params.PumpModel` via ``dataclasses.replace``. To
add an effect, add an entry here (and, if the model lacks the physics, a switch in
``lumped/params.py``); the discrepancy workflow and ``valvelab synth`` pick it up.

Effects that the pump model implements as pure switches (flow forces: eqs 2.36 and
2.37 have no free coefficient in ``DiscValve``) are zero-parameter candidates: the
workflow scores them as they are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cache

from lumped.effects import BOTH_VALVES, PER_VALVE, PUMP, Effect, Library, Parameter
from lumped.params import DiscValve, PumpModel, _data, critical_damping, room_viscosity, thesis_air_content

LIBRARY = Library()
register = LIBRARY.register


def _valves(target: str) -> tuple[str, ...]:
    return ("inlet", "delivery") if target == "both" else (target,)


def _on_valves(model: PumpModel, target: str, **changes) -> PumpModel:
    """``model`` with the same field changes on the target valve(s)."""
    return replace(model, **{pos: replace(getattr(model, pos), **changes) for pos in _valves(target)})


@cache
def _disc_reference() -> DiscValve:
    from lumped.params import load_disc_valve
    return load_disc_valve("inlet")


@cache
def _reed_modal() -> tuple[float, float]:
    """(gamma1, rho_c h_eff [kg/m^2]) of the prototype reed (Table 3.13)."""
    st = _data("reed_valve")["structure"]
    return st["gamma1"], st["density"] * st["effective_thickness"]


def contact_mass() -> float:
    """The mass the thesis used for critical contact damping, eq 2.23 [kg] (Table 2.1 total)."""
    return _data("disc_valve")["mass"]["contact_reference"]


# --------------------------------------------------------------------------- seat_compliance
def _seat_damping(values: dict, valve_type: str) -> dict:
    """Critical seat damping (eq 2.23) for the fitted seat stiffness."""
    k = values["k_seat"]
    if valve_type == "reed":
        g1, modal = _reed_modal()
        return {"c_seat": critical_damping(g1 * k, modal) / g1}      # Pa s/m, as lumped.params
    return {"c_seat": critical_damping(k, contact_mass())}          # N s/m (2 sqrt(k m), 3.9 g)


def _apply_seat(model: PumpModel, values: dict, target: str) -> PumpModel:
    c = _seat_damping(values, model.valve)["c_seat"]
    return _on_valves(model, target, seat_compliance=True, compliant_seat_stiffness=values["k_seat"],
                      compliant_seat_damping=c)


register(Effect(
    name="seat_compliance",
    summary="compliant seat (e.g. an O-ring under an unseated valve housing): linear k_seat, critical c_seat",
    parameters=(Parameter(
        "k_seat", "N/m", prior=1.5e6, bounds=(1.0e5, 1.0e10), plausible=(1.0e5, 1.0e9),
        source="O-ring under the unseated delivery housing, measured in the pump (section 2.4.3.2); "
               "a steel seat is 3.02e9 N/m (FEA), anything near it is no compliance"),),
    variants={"reed": (Parameter(
        "k_seat", "Pa/m", prior=8.49e9, bounds=(1.0e8, 1.0e13), plausible=(1.0e8, 5.0e11),
        source="the disc's O-ring (1.5e6 N/m) over the disc face, lumped/data/reed_valve.toml; "
               "the Delrin seat lands are E/h = 2.1e12 Pa/m"),)},
    apply=_apply_seat, targets=PER_VALVE, derived=_seat_damping,
))


# --------------------------------------------------------------------------- squeeze_film
@dataclass(frozen=True)
class _SqueezeDisc(DiscValve):
    """A disc valve whose stiction coefficient C2 is given rather than computed from eq 2.15."""

    c2_value: float = 0.0

    def c2(self, viscosity: float) -> float:  # noqa: D102 - the packed C2 of eq 2.13
        return self.c2_value


def _c2_prior() -> float:
    """C2 of eq 2.15 [N m^2 s] for the disc geometry and the oil at room temperature."""
    return _disc_reference().c2(room_viscosity())


def _apply_squeeze(model: PumpModel, values: dict, target: str) -> PumpModel:
    out = model
    for pos in _valves(target):
        v = getattr(out, pos)
        fields_ = {f: getattr(v, f) for f in v.__dataclass_fields__ if f != "c2_value"}
        fields_["squeeze_film"] = True
        out = replace(out, **{pos: _SqueezeDisc(**fields_, c2_value=values["C2"])})
    return out


_C2 = _c2_prior()
register(Effect(
    name="squeeze_film",
    summary="Reynolds-equation stiction C2 u / x^3 with the cavitation limiter (eqs 2.13-2.18)",
    parameters=(Parameter(
        "C2", "N m^2 s", prior=_C2, bounds=(_C2 / 100.0, _C2 * 100.0), plausible=(_C2 / 4.0, _C2 * 4.0),
        source="eq 2.15 with the disc geometry of Table 2.3 and mu at 22 C (Appendix A); a factor 4 "
               "either way covers the bevel angle (sin^4) and the film geometry"),),
    apply=_apply_squeeze, valve_types=("disc",), targets=BOTH_VALVES,
))


# --------------------------------------------------------------------------- flow_force
register(Effect(
    name="flow_force",
    summary="steady and transient flow forces (eqs 2.36, 2.37); a switch: the model has no free coefficient",
    parameters=(),
    apply=lambda m, v, t: _on_valves(m, t, flow_force=True), valve_types=("disc",), targets=BOTH_VALVES,
))


# --------------------------------------------------------------------------- added_mass
def _disc_added_mass_prior() -> float:
    """m_f = (8/3) rho R_o^3 [kg]: a thin disc broadside in unbounded fluid (Lamb; eq 2.3 m_f)."""
    d = _disc_reference()
    rho = _data("oil")["compressibility"]["density_atm"]
    return d.added_mass_coefficient * rho * d.outer_radius**3


def _apply_added_mass(model: PumpModel, values: dict, target: str) -> PumpModel:
    if model.valve == "reed":
        return _on_valves(model, target, added_mass=True, hydrodynamic_function=values["Gamma_f"])
    v = model.inlet
    coef = values["m_f"] / (model.oil.density_atm * v.outer_radius**3)
    return _on_valves(model, target, added_mass=True, added_mass_coefficient=coef)


_MF = _disc_added_mass_prior()
register(Effect(
    name="added_mass",
    summary="added fluid mass on the moving element (eq 2.3 m_f; eq 3.17 for the reed)",
    parameters=(Parameter(
        "m_f", "kg", prior=_MF, bounds=(_MF / 100.0, _MF * 100.0), plausible=(_MF / 4.0, _MF * 10.0),
        source="(8/3) rho R_o^3, a disc in unbounded fluid (Lamb); confinement in the housing raises it"),),
    variants={"reed": (Parameter(
        "Gamma_f", "-", prior=0.885, bounds=(0.01, 100.0), plausible=(0.2, 10.0),
        source="hydrodynamic function of eq 3.13 at kappa_n = 0.9677 (section 3.8.2.2); a wall nearby "
               "raises it"),)},
    apply=_apply_added_mass, targets=BOTH_VALVES,
))


# --------------------------------------------------------------------------- fluid_damping
register(Effect(
    name="fluid_damping",
    summary="viscous fluid damping on the reed (c_f, section 3.8.3)",
    parameters=(Parameter(
        "c_f", "Pa s/m", prior=1650.0, bounds=(10.0, 1.0e5), plausible=(165.0, 16500.0),
        source="eq 3.80 from the Naik et al. (2003) correlation at R_k = 2250; approximate by the "
               "thesis's own account, a wall nearby raises it"),),
    apply=lambda m, v, t: _on_valves(m, t, fluid_damping=True, fluid_damping_coefficient=v["c_f"]),
    valve_types=("reed",), targets=BOTH_VALVES,
))


# --------------------------------------------------------------------------- piston_leakage
def _leak_conductance(values: dict, valve_type: str) -> dict:
    """Laminar annulus conductance pi d c^3 / (12 mu L) [m^3/(s Pa)] of the fitted clearance (eq 4.5)."""
    pump = _data("pump")
    d, L = pump["pump"]["piston_diameter"], pump["leakage"]["seal_length"]
    return {"conductance": math.pi * d * values["clearance"] ** 3 / (12.0 * room_viscosity() * L)}


register(Effect(
    name="piston_leakage",
    summary="laminar leakage between piston and cylinder, proportional to the pressure difference (eq 4.5)",
    parameters=(Parameter(
        "clearance", "m", prior=_data("pump")["leakage"]["radial_clearance"], bounds=(1.0e-6, 2.0e-4),
        plausible=(1.0e-6, 5.0e-5),
        source="radial clearance of a lapped piston (lumped/data/pump.toml); a few to tens of micrometres"),),
    apply=lambda m, v, t: replace(m, pump=replace(m.pump, piston_leakage=True, leakage_clearance=v["clearance"])),
    targets=PUMP, derived=_leak_conductance,
))


# --------------------------------------------------------------------------- entrained_air
def _air_stated(runs) -> str | None:
    if any(getattr(r, "air_content", None) is not None for r in runs):
        return "run.toml states the air content"
    return None


register(Effect(
    name="entrained_air",
    summary="air content R in the oil (eq 4.11) where the baseline assumes none",
    parameters=(Parameter(
        "R", "-", prior=thesis_air_content("disc"), bounds=(1.0e-4, 0.2), plausible=(1.0e-4, 0.1),
        source="R used by the thesis's model: 0.013 (disc rig, Table 5.4), 0.008 (reed rig, Table 5.6)"),),
    variants={"reed": (Parameter(
        "R", "-", prior=thesis_air_content("reed"), bounds=(1.0e-4, 0.2), plausible=(1.0e-4, 0.1),
        source="R used by the thesis's model for the reed rig (Table 5.6)"),)},
    apply=lambda m, v, t: replace(m, oil=replace(m.oil, entrained_air=True, air_content=v["R"])),
    targets=PUMP, applicable=_air_stated,
))


# --------------------------------------------------------------------------- model errors (not searched)
def _apply_cd_scale(model: PumpModel, values: dict, target: str) -> PumpModel:
    # Cd(Re) of eq 2.47 is linear in (Cd_inf, A): scaling both scales Cd at every Re
    s = values["scale"]
    return replace(model, **{pos: replace(getattr(model, pos), cd_inf=getattr(model, pos).cd_inf * s,
                                          cd_a=getattr(model, pos).cd_a * s) for pos in _valves(target)})


register(Effect(
    name="discharge_scale",
    summary="discharge coefficient off by a factor (a baseline error the workflow does not search)",
    parameters=(Parameter("scale", "-", prior=1.0, bounds=(0.5, 2.0), plausible=(0.8, 1.25),
                          source="Cd correlations eqs 2.48, 3.89", log=False),),
    apply=_apply_cd_scale, targets=BOTH_VALVES, candidate=False,
))
