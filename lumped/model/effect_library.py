"""The candidate effects of CONTRACT.md for valvelab's pump model, and how a model resolves them.

Each effect is one ``LIBRARY.register`` call: its parameters (each bound to the declared
component field it sets, with search bounds, a prior from ``lumped/data/effect_priors.toml``
or computed for the model at hand, and a plausible range), the valve kinds it applies
to, and its targets. Switching an effect on sets those fields on the target
component(s) (:func:`set_fields`); a model file's ``[effects.NAME.TARGET]`` table and the
discrepancy workflow's candidates go through the same entries. To add an effect: one
entry here, plus (if the model lacks the physics) a declared field and its use in the
valve kind's module (docs/extending.md).

:func:`resolve` turns a :class:`~lumped.model.pump_model.PumpModel` into the model the physics
sees (its effects applied); :func:`baseline` is the discrepancy workflow's starting
point, the same model with every candidate effect off.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import cache

from geometry.data_files import package_toml
from lumped.model.effects import BOTH_VALVES, PER_VALVE, PUMP, Effect, Library, Parameter

#: an effect fitted on both valves, then tried on each alone (Effect.placement)
ONE_OR_BOTH = BOTH_VALVES + PER_VALVE
from lumped.model.pump_model import POSITIONS, PumpModel

LIBRARY = Library()
register = LIBRARY.register


@cache
def priors() -> dict:
    """lumped/data/effect_priors.toml."""
    return package_toml("lumped", "effect_priors.toml")


def _targets(target: str) -> tuple[str, ...]:
    return POSITIONS if target == "both" else (target,)


def set_fields(model: PumpModel, target: str, **changes) -> PumpModel:
    """``model`` with the same field changes on the target: a valve, both valves, or the pump/oil
    (``pump.<field>``/``oil.<field>`` names for pump-wide effects)."""
    if target == "pump":
        out = model
        for name, v in changes.items():
            comp, field = name.split(".")
            out = replace(out, **{comp: replace(getattr(out, comp), **{field: v})})
        return out
    out = {}
    for pos in _targets(target):
        v = getattr(model, pos)
        missing = [k for k in changes if k not in type(v).__dataclass_fields__]
        if target == "both" and missing:
            continue            # "both" on a mixed pump: only the valves of the kind the effect acts on
        if missing:
            from geometry.errors import InputError

            raise InputError(f"valves.{pos}", f"an effect sets {missing[0]!r}, which the {pos} valve's kind "
                             f"({type(v).__name__}) does not declare")
        out[pos] = replace(v, **changes)
    return replace(model, **out)


#: kind name -> the reference model of that kind (the shipped thesis model), for priors asked
#: for a bare valve type; set by lumped.model.model_file, which loads the shipped models (this
#: module sits below it)
REFERENCE: dict = {"model": None}


def _thesis(kind: str):
    if REFERENCE["model"] is None:
        raise RuntimeError("no reference model: import lumped.model.model_file (lumped does on import)")
    return REFERENCE["model"](kind)


def _valve_of(model, target: str, kind: str):
    """The target valve of ``model`` (for "both": the first of ``kind``, the inlet's first), or the thesis valve of
    that kind (no model, or none of its valves is of that kind: a prior is then the thesis's)."""
    from lumped.valves.kind import kind_of

    m = model if model is not None else _thesis(kind)
    positions = ("inlet", "delivery") if target in ("both", "pump") else (target,)
    for pos in positions:
        if kind_of(m.valve(pos)).name == kind:
            return m.valve(pos), m
    if model is None:
        return m.valve(positions[0]), m
    return _valve_of(None, target, kind)


# --------------------------------------------------------------------------- seat_compliance
def _seat_damping(values: dict, context, target: str) -> dict:
    """Critical seat damping (eq 2.23) for the fitted seat stiffness (the target valve's contact mass)."""
    kind = context if isinstance(context, str) else (context.kind_at(target) if context is not None else "disc")
    v, _ = _valve_of(None if isinstance(context, str) else context, target, kind)
    return {"c_seat": replace(v, seat_stiffness=values["k_seat"], seat_damping=None).seat_damping_value}


def _apply_seat(model: PumpModel, values: dict, target: str) -> PumpModel:
    # seat_damping None: the valve derives the critical damping for the new stiffness (eq 2.23)
    return set_fields(model, target, seat_stiffness=values["k_seat"], seat_damping=None)


register(Effect(
    name="seat_compliance",
    summary="compliant seat (e.g. an O-ring under an unseated valve housing): linear k_seat, critical c_seat",
    parameters=(Parameter(
        "k_seat", "N/m", prior=priors()["seat_compliance"]["disc"]["k_seat"], bounds=(1.0e5, 1.0e10),
        plausible=(1.0e5, 1.0e9), field="seat_stiffness", strong="low",    # a stiff seat is no compliance
        source="O-ring under the unseated delivery housing, measured in the pump (section 2.4.3.2); "
               "a steel seat is 3.02e9 N/m (FEA), anything near it is no compliance"),),
    variants={"reed": (Parameter(
        "k_seat", "Pa/m", prior=priors()["seat_compliance"]["reed"]["k_seat"], bounds=(1.0e8, 1.0e13),
        plausible=(1.0e8, 5.0e11), field="seat_stiffness", strong="low",   # a stiff seat is no compliance
        source="the disc's O-ring (1.5e6 N/m) over the disc face (lumped/data/effect_priors.toml); "
               "the Delrin seat lands are E/h = 2.1e12 Pa/m"),)},
    apply=_apply_seat, targets=PER_VALVE, derived=_seat_damping,
    derived_units={"c_seat": {None: "N s/m", "reed": "Pa s/m"}},     # the reed's contact is per unit area
))


# --------------------------------------------------------------------------- squeeze_film
def _c2_prior(model, target: str) -> float:
    """C2 of eq 2.15 [N m^2 s] for the target disc's geometry and the model's oil viscosity."""
    v, m = _valve_of(model, target, "disc")
    return v.c2(m.oil.viscosity)


register(Effect(
    name="squeeze_film",
    summary="Reynolds-equation squeeze film C2 u / x^3 (eqs 2.13-2.15) whose pressure cavitates at the vapour "
            "pressure minus the oil's tensile strength (eqs 2.16-2.17 on the film pressure, docs/stiction.md)",
    parameters=(Parameter(
        "C2", "N m^2 s", prior=float("nan"), bounds=(1.0 / 100.0, 100.0), plausible=(1.0 / 10.0, 10.0),
        field="squeeze_c2", prior_from=_c2_prior, relative=True, strong="high",   # the film force goes with C2
        source="eq 2.15 with the disc geometry and the oil viscosity; a factor 10 either way covers the bevel "
               "angle (sin^4), a film that is not uniform (seat flatness) and the oil's temperature"),),
    apply=lambda m, v, t: set_fields(m, t, squeeze_c2=v["C2"]), valve_types=("disc",), targets=ONE_OR_BOTH,
    tight_tolerance=True, placement=True,
))


# --------------------------------------------------------------------------- flow_force
def _jet_prior(model, target: str) -> float:
    """theta_jet [rad]: the model's, else the seat bevel angle (eq 2.30, the thesis's assumption)."""
    v, _ = _valve_of(model, target, "disc")
    return v.jet_angle_value


def _transient_prior(model, target: str) -> float:
    """L_t [m]: the model's, else the port length L of eq 2.31 (Table 2.3)."""
    v, _ = _valve_of(model, target, "disc")
    return v.transient_length_value


_FF = priors()["flow_force"]
register(Effect(
    name="flow_force",
    summary="steady and transient flow forces (eqs 2.36, 2.37) with a fitted jet angle and oil-column length",
    parameters=(
        Parameter("theta_jet", "rad", prior=math.radians(54.0), prior_from=_jet_prior, log=False,
                  bounds=tuple(math.radians(a) for a in _FF["jet_angle_search_deg"]),
                  plausible=tuple(math.radians(a) for a in _FF["jet_angle_plausible_deg"]), field="jet_angle",
                  strong="low",           # the steady force goes with cos(theta_jet): none at 90 deg (eq 2.36)
                  source="jet leaving along the seat bevel (eq 2.30, Knutson 2016); measured and CFD jet angles "
                         "of poppet and disc valves (lumped/data/effect_priors.toml)"),
        Parameter("L_t", "m", prior=float("nan"), prior_from=_transient_prior, relative=True,
                  bounds=tuple(_FF["transient_length_search"]), plausible=tuple(_FF["transient_length_plausible"]),
                  field="transient_length", strong="high",   # the transient force goes with L_t (eq 2.37)
                  source="the port length L of eq 2.31 (Table 2.3); transient flow forces of CFD differ from the "
                         "control-volume estimate by several times (lumped/data/effect_priors.toml)"),
    ),
    apply=lambda m, v, t: set_fields(m, t, flow_force_steady=1.0, flow_force_transient=1.0,
                                     jet_angle=v["theta_jet"], transient_length=v["L_t"]),
    valve_types=("disc",), targets=ONE_OR_BOTH, placement=True,
))


# --------------------------------------------------------------------------- added_mass
def _disc_added_mass_prior(model, target: str) -> float:
    """m_f = coefficient rho R_o^3 [kg]: a thin disc broadside in unbounded fluid (Lamb; eq 2.3 m_f)."""
    v, m = _valve_of(model, target, "disc")
    return priors()["added_mass"]["disc"]["coefficient"] * m.oil.density * v.outer_radius**3


def _ball_added_mass_prior(model, target: str) -> float:
    """m_f = rho pi d_b^3 / 12 [kg]: half the fluid a sphere displaces (Lamb 1932, section 92; eq 2.3 m_f)."""
    v, m = _valve_of(model, target, "ball")
    return m.oil.density * math.pi * v.ball_diameter**3 / 12.0


register(Effect(
    name="added_mass",
    summary="added fluid mass on the moving element (eq 2.3 m_f; eq 3.17 for the reed)",
    parameters=(Parameter(
        "m_f", "kg", prior=float("nan"), bounds=(1.0 / 100.0, 100.0), plausible=(1.0 / 4.0, 10.0),
        field="added_mass", prior_from=_disc_added_mass_prior, relative=True, strong="high",
        source="(8/3) rho R_o^3, a disc in unbounded fluid (Lamb); confinement in the housing raises it"),),
    variants={"reed": (Parameter(
        "Gamma_f", "-", prior=priors()["added_mass"]["reed"]["Gamma_f"], bounds=(0.01, 100.0), plausible=(0.2, 10.0),
        field="hydrodynamic_function", strong="high",
        source="hydrodynamic function of eq 3.13 at kappa_n = 0.9677 (section 3.8.2.2); a wall nearby "
               "raises it"),),
              "ball": (Parameter(
        "m_f", "kg", prior=float("nan"), bounds=(1.0 / 100.0, 100.0), plausible=(1.0 / 4.0, 10.0),
        field="added_mass", prior_from=_ball_added_mass_prior, relative=True, strong="high",
        source="half the displaced fluid, a sphere in unbounded fluid (Lamb 1932); the seat and housing "
               "nearby raise it"),)},
    apply=lambda m, v, t: set_fields(m, t, **({"added_mass": v["m_f"]} if "m_f" in v
                                              else {"hydrodynamic_function": v["Gamma_f"]})),
    valve_types=("disc", "reed", "ball"), targets=BOTH_VALVES, tight_tolerance=True,
))


# --------------------------------------------------------------------------- fluid_damping
register(Effect(
    name="fluid_damping",
    summary="viscous fluid damping on the reed (c_f, section 3.8.3)",
    parameters=(Parameter(
        "c_f", "Pa s/m", prior=priors()["fluid_damping"]["c_f"], bounds=(10.0, 1.0e5), plausible=(165.0, 16500.0),
        field="fluid_damping_coefficient", strong="high",
        source="eq 3.80 from the Naik et al. (2003) correlation at R_k = 2250; approximate by the "
               "thesis's own account, a wall nearby raises it"),),
    apply=lambda m, v, t: set_fields(m, t, fluid_damping_coefficient=v["c_f"]),
    valve_types=("reed",), targets=BOTH_VALVES,
))


# --------------------------------------------------------------------------- quadratic_drag
register(Effect(
    name="quadratic_drag",
    summary="the reed's quadratic fluid drag, the gamma2 rho |x'| x' C_D / 2 term of eq 3.21 (the thesis's model "
            "leaves it off and uses the linear c_f, Table 3.13)",
    parameters=(Parameter(
        "C_D", "-", prior=priors()["quadratic_drag"]["C_D"], bounds=(0.01, 100.0), plausible=(0.1, 10.0),
        field="drag_coefficient", strong="high",
        source="drag coefficient of a plate moving broadside, ~1 unconfined (section 3.8.2.2); confinement between "
               "the seat and the manifold raises it"),),
    apply=lambda m, v, t: set_fields(m, t, drag=True, drag_coefficient=v["C_D"]),
    valve_types=("reed",), targets=BOTH_VALVES,
))


# --------------------------------------------------------------------------- piston_leakage
def _leak_conductance(values: dict, context, target: str = "pump") -> dict:
    """Laminar annulus conductance pi d c^3 / (12 mu L) [m^3/(s Pa)] of the fitted clearance (eq 4.5)."""
    m = context if (context is not None and not isinstance(context, str)) else _thesis(context or "disc")
    pump = replace(m.pump, leakage_clearance=values["clearance"])
    return {"conductance": pump.leakage_coefficient(m.oil.viscosity)}


register(Effect(
    name="piston_leakage",
    summary="laminar leakage between piston and cylinder, proportional to the pressure difference (eq 4.5)",
    parameters=(Parameter(
        "clearance", "m", prior=priors()["piston_leakage"]["clearance"], bounds=(1.0e-6, 2.0e-4),
        plausible=(1.0e-6, 5.0e-5), field="leakage_clearance", strong="high",   # the leak goes with c^3 (eq 4.5)
        source="radial clearance of a lapped piston (lumped/data/effect_priors.toml); a few to tens of "
               "micrometres"),),
    apply=lambda m, v, t: set_fields(m, "pump", **{"pump.leakage_clearance": v["clearance"]}),
    targets=PUMP, derived=_leak_conductance, derived_units={"conductance": "m^3/(s Pa)"},
))


# --------------------------------------------------------------------------- entrained_air
def _air_stated(runs) -> str | None:
    if any(getattr(r, "air_content", None) is not None for r in runs):
        return "run.toml states the air content"
    return None


def _air_prior(model, target: str) -> float:
    """The model's own air content (oil.air_content) where it states one, else a typical 1 %."""
    if model is not None and model.oil.air_content > 0:
        return model.oil.air_content
    return priors()["entrained_air"]["R"]


def _air_prior_for(kind: str):
    def prior(model, target):
        return _air_prior(model if model is not None else _thesis(kind), target)
    return prior


_R = dict(bounds=(1.0e-4, 0.2), plausible=(1.0e-4, 0.1), field="air_content", strong="high")
register(Effect(
    name="entrained_air",
    summary="air content R in the oil (eq 4.11) where the baseline assumes none",
    parameters=(Parameter("R", "-", prior=0.01, prior_from=_air_prior_for("disc"), **_R,
                          source="the model's stated air content (thesis disc rig: 0.013, Table 5.4)"),),
    variants={"reed": (Parameter("R", "-", prior=0.01, prior_from=_air_prior_for("reed"), **_R,
                                 source="the model's stated air content (thesis reed rig: 0.008, Table 5.6)"),)},
    apply=lambda m, v, t: set_fields(m, "pump", **{"oil.air_content": v["R"]}),
    targets=PUMP, applicable=_air_stated,
))


# --------------------------------------------------------------------------- model errors (not searched)
def _apply_cd_scale(model: PumpModel, values: dict, target: str) -> PumpModel:
    # Cd(Re) of eqs 2.47, 3.89 is linear in (Cd_inf, A): scaling both scales Cd at every Re
    s = values["scale"]
    return replace(model, **{pos: replace(getattr(model, pos), cd_inf=getattr(model, pos).cd_inf * s,
                                          cd_a=getattr(model, pos).cd_a * s) for pos in _targets(target)})


register(Effect(
    name="discharge_scale",
    summary="discharge coefficient off by a factor (a baseline error the workflow does not search)",
    parameters=(Parameter("scale", "-", prior=1.0, bounds=(0.5, 2.0), plausible=(0.8, 1.25),
                          source="Cd correlations eqs 2.48, 3.89", log=False),),
    apply=_apply_cd_scale, targets=BOTH_VALVES, candidate=False,
))


# --------------------------------------------------------------------------- resolution
def resolve(model: PumpModel, library: Library = LIBRARY) -> PumpModel:
    """The model the physics sees: ``model`` with its effects applied (and none left pending)."""
    if not model.effects:
        return model
    return library.apply(replace(model, effects=()), model.effects)


def baseline(model: PumpModel, library: Library = LIBRARY) -> PumpModel:
    """The discrepancy workflow's baseline: ``model`` with every candidate effect off.

    Its effects are dropped and the fields that candidate effects own fall back to
    their "off" value (entrained air: an air-free oil).
    """
    out = replace(model, effects=())
    return set_fields(out, "pump", **{"oil.air_content": 0.0})


def effect_fields(effect: str) -> list[tuple[str, str]]:
    """(component class name, field) pairs an effect sets (from the parameter declarations)."""
    e = LIBRARY[effect]
    out = []
    for params in (e.parameters, *e.variants.values()):
        out += [(effect, p.field) for p in params if p.field]
    return out


def check_values(effect: Effect, values: dict, context, target: str, where: str) -> dict:
    """Effect parameter values from a model file, each checked against its declared field."""
    from geometry.declare import check_field
    from geometry.errors import InputError

    params = {p.name: p for p in effect.parameters_for(context, target)}
    out = {}
    for k, v in values.items():
        if k not in params:
            expected = ", ".join(params) or "none (a switch)"
            raise InputError(f"{where}.{k}", f"unknown parameter of {effect.name}; expected {expected}")
        p = params[k]
        if p.field:
            comp = _component_for(context, target, p.field)
            if p.field not in type(comp).__dataclass_fields__:
                raise InputError(f"{where}.{k}", f"effect {effect.name!r} sets {p.field!r}, which "
                                 f"{type(comp).__name__} does not declare")
            v = check_field(comp, p.field, v, f"{where}.{k}")
        elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"{where}.{k}", f"expected a finite number in {p.unit}, got {v!r}")
        out[k] = float(v)
    for name, p in params.items():
        out.setdefault(name, p.prior)
    return out


def _component_for(model, target: str, field: str):
    """The component (valve, pump or oil object) that declares ``field`` for this target."""
    if target in POSITIONS:
        return model.valve(target)
    for comp in (model.pump, model.oil, model.inlet, model.delivery):
        if field in type(comp).__dataclass_fields__:
            return comp
    from geometry.errors import InputError

    raise InputError(f"effects.{target}", f"no component of the model declares the field {field!r} an effect sets "
                     f"(valves: {type(model.inlet).__name__}, {type(model.delivery).__name__})")
