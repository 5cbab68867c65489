"""The validity envelope of a pump result: the conditions the model's equations hold for, checked after a run.

A result outside them is still returned, but carries :class:`ResultWarning` records (``PumpResult.warnings``;
JSON ``warnings``: ``[{"code", "message"}]``) that name the condition and the value the run measured, e.g.
``{"code": "seat_penetration", "message": "delivery disc 1.68 mm into its seat, more than its 1.01 mm lift"}``.
What can be decided before running is refused by ``valvelab model check`` (:func:`check_model`).

Where the conditions come from:

- every valve kind declares its own in its module: :meth:`lumped.valves.kind.ValveParams.validity` returns an
  :class:`Envelope` (where the element rests, the pressure difference that lifts it off its seat, and
  :class:`Limit` records on what a run measures of it, :class:`ValveRun`); the base class gives the limits
  every kind shares (:func:`common_limits`), a kind adds its own, so a new kind touches nothing here;
- the conditions on any valve (it opens at all, it rests between its seat and its stop, its loss is not
  negative) and on the pump (a vapour cavity in the cylinder stays small, the delivery is not a small difference of
  large flows that the integrator's tolerance cannot resolve) are in this module.

Units: SI inside; the messages print mm, MPa and J.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np

#: a linear contact (eq 2.20) that gives way by more than this fraction of the valve's lift is outside it
CONTACT_FRACTION = 1.0
#: Cd(Re) is read as extrapolated where it comes within this fraction of its asymptote Cd_inf (see common_limits)
CD_PLATEAU = 0.95
#: the discrete vapour cavity model holds while the cavity is below this fraction of the cylinder volume
VAPOUR_LIMIT = 0.1
#: the integrator's relative tolerance times the flow amplification above which a delivery is unresolved: a
#: delivery that is a small difference of large flows carries the flows' relative error times their ratio to
#: it (the thesis pumps amplify by ~1.1-1.3; a small-bore pump at high speed by ~1000, tests/test_validity.py)
ACCURACY_LIMIT = 1e-2


@dataclass(frozen=True)
class ResultWarning:
    """One condition a result lies outside: ``code`` (a stable name) and ``message`` (the measured value)."""

    code: str
    message: str

    def to_dict(self) -> dict:
        """{"code", "message"} as the JSON holds it."""
        return {"code": self.code, "message": self.message}

    def __str__(self) -> str:
        return f"{self.code}: {self.message}"


#: how a message names a measured quantity of :class:`ValveRun` (value in its display unit)
QUANTITIES = {
    "seat_penetration": ("{v} into its seat", "mm"),
    "stop_penetration": ("{v} into its stop", "mm"),
    "peak_opening": ("opens {v}", "mm"),
    "deflection": ("deflects {v} from rest", "mm"),
    "max_reynolds": ("reaches an orifice Reynolds number of {v}", "-"),
}


@dataclass(frozen=True)
class Limit:
    """An upper limit on one measured quantity of a valve (``quantity``: a key of :data:`QUANTITIES`) [SI];
    ``code`` names the warning, ``reason`` completes its message ("more than " + reason)."""

    code: str
    quantity: str
    high: float
    reason: str

    def __post_init__(self):
        if self.quantity not in QUANTITIES:
            raise ValueError(f"Limit.quantity: expected one of {', '.join(QUANTITIES)}, got {self.quantity!r}")


@dataclass(frozen=True)
class Envelope:
    """What a valve kind declares of its validity: where its element rests with no pressure difference
    (``rest_opening`` [m], set by the valve key ``rest_key``), the pressure difference that lifts it off its
    seat (``cracking_pressure`` [Pa], 0 when it rests open), the :class:`Limit` records on a run and its lift
    ``stop_gap`` [m]. None: not declared (the condition is not checked)."""

    rest_opening: float | None = None
    rest_key: str | None = None
    cracking_pressure: float | None = None
    limits: tuple = ()
    stop_gap: float | None = None          # the lift x_stop [m] (lumped.valves.common.Common)


@dataclass(frozen=True)
class ValveRun:
    """What a run measured of one valve over its last revolution (SI units).

    ``opened``: it left its seat; ``peak_opening``, ``min_opening`` [m] (negative: pressed into its seat);
    ``seat_penetration``, ``stop_penetration`` [m] the deepest contact deflections; ``deflection`` [m] the
    largest distance from its rest opening (None without a declared rest); ``max_reynolds`` the largest
    orifice Reynolds number 4 rho |Q_o| / (mu p) (eq 2.46); ``max_dp`` the largest pressure difference in
    the opening direction [Pa]; ``forward_volume``, ``backward_volume`` [m^3] through it each way
    (orifice and displacement flow); ``energy_loss`` [J] (lumped.run.postprocess.losses).
    """

    position: str
    kind: str
    opened: bool
    peak_opening: float
    min_opening: float
    seat_penetration: float
    stop_penetration: float
    max_reynolds: float
    max_dp: float
    forward_volume: float
    backward_volume: float
    energy_loss: float
    deflection: float | None = None

    @property
    def name(self) -> str:
        """"delivery disc": how messages name the valve."""
        return f"{self.position} {self.kind}"


# --------------------------------------------------------------------------- formatting
def _mm(x: float) -> str:
    return f"{x * 1e3:.3g} mm" if abs(x) < 1e-3 else f"{x * 1e3:.2f} mm"


def _mpa(p: float) -> str:
    return f"{p / 1e6:.3g} MPa"


def _show(quantity: str, value: float) -> str:
    text, unit = QUANTITIES[quantity]
    return text.format(v=_mm(value) if unit == "mm" else f"{value:.3g}")


# --------------------------------------------------------------------------- limits every kind shares
@functools.lru_cache(maxsize=256)
def plateau_reynolds(cd_inf: float, a: float, b: float, c: float, fraction: float = CD_PLATEAU) -> float | None:
    """The Reynolds number [-] where Cd(Re) of eq 2.47 (Wu et al. 2002; eqs 2.48, 3.89) first reaches
    ``fraction`` of its asymptote Cd_inf, or None if it never does within Re = 1e8.

    The thesis fits the correlation to measured flows and warns that Cd_inf "should not be interpreted as an
    accurate estimate of the asymptotic value" (section 2.4.5): where Cd is within 5 % of Cd_inf the
    correlation is its asymptote, an extrapolation beyond the measured Reynolds numbers.
    """
    from lumped.fluid.orifice import discharge_coefficient

    s = np.geomspace(1e-2, 1e4, 4001)
    cd = discharge_coefficient(s, cd_inf, a, b, c)
    above = np.nonzero(cd >= fraction * cd_inf)[0]
    if not len(above):
        return None
    i = int(above[0])
    if i == 0:
        return float(s[0] ** 2)
    # linear interpolation in s between the last point below and the first above
    s0, s1, c0, c1 = s[i - 1], s[i], cd[i - 1], cd[i]
    st = s0 + (fraction * cd_inf - c0) * (s1 - s0) / (c1 - c0)
    return float(st * st)


def common_limits(common) -> tuple[Limit, ...]:
    """The limits every kind shares, from its :class:`lumped.valves.common.Common` quantities.

    - the seat and stop contacts (eq 2.20: linear, a compliant seat such as the thesis's O-ring) give way
      by at most the valve's lift x_stop: a seat that lets the element sink deeper than it ever opens is
      not a seat the linear contact describes (the thesis's O-ring gave 0.2-0.3 mm at 2.8-3.8 MPa against
      the 1.01 mm lift, section 5.4.5);
    - the orifice Reynolds number stays below where Cd(Re) is its fitted asymptote (:func:`plateau_reynolds`).
    """
    gap = common.stop_gap
    out = [Limit("seat_penetration", "seat_penetration", CONTACT_FRACTION * gap, f"its {_mm(gap)} lift"),
           Limit("stop_penetration", "stop_penetration", CONTACT_FRACTION * gap, f"its {_mm(gap)} lift")]
    re_top = plateau_reynolds(common.cd_inf, common.cd_a, common.cd_b, common.cd_c)
    if re_top is not None:
        out.append(Limit("discharge_range", "max_reynolds", re_top,
                         f"{re_top:.3g}, where Cd(Re) (eq 2.47) is within {100 * (1 - CD_PLATEAU):.0f} % of its "
                         f"asymptote {common.cd_inf:.3g}: beyond the flows it was fitted to (section 2.4.5)"))
    return tuple(out)


# --------------------------------------------------------------------------- checks on a run
def valve_warnings(valve, run: ValveRun, oil=None) -> list[ResultWarning]:
    """The warnings of one valve: its kind's :class:`Envelope` (:meth:`lumped.valves.kind.ValveParams.validity`)
    against what the run measured, and the conditions on any valve (it rests between its seat and its
    stop, it opens, its loss is not negative)."""
    env = valve.validity(oil)
    gap = env.stop_gap if env.stop_gap is not None else valve.common(oil).stop_gap
    if env.rest_opening is not None:
        run = replace(run, deflection=max(run.peak_opening - env.rest_opening, env.rest_opening - run.min_opening))
    out = []
    if env.rest_opening is not None and env.rest_opening > gap:
        out.append(ResultWarning("rest_beyond_stop", f"{run.name} rests {_mm(env.rest_opening)} open "
                                 f"({env.rest_key}), beyond its {_mm(gap)} stop: it sits pressed on its stop"))
    if not run.opened:
        crack = "" if env.cracking_pressure is None else f", below its {_mpa(env.cracking_pressure)} cracking pressure"
        out.append(ResultWarning("never_opens", f"{run.name} never opens: the pressure difference across it "
                                 f"reaches at most {_mpa(run.max_dp)}{crack}"))
    for lim in env.limits:
        value = getattr(run, lim.quantity)
        if value is not None and value > lim.high:
            out.append(ResultWarning(lim.code, f"{run.name} {_show(lim.quantity, value)}, more than {lim.reason}"))
    if run.energy_loss < 0.0:
        out.append(ResultWarning("negative_loss", f"{run.name} loses {run.energy_loss:.3g} J per revolution: "
                                 "throttling cannot give energy back (an integration error)"))
    return out


def pump_warnings(runs: dict, delivery: float, rtol: float, cavitation_angle: float,
                  max_vapour_fraction: float) -> list[ResultWarning]:
    """The pump's own conditions: a small vapour cavity in the cylinder, a delivery the tolerances resolve.

    - cavitation: the cylinder pressure held at the vapour pressure with the oil short of filling it is the
      discrete vapour cavity model (lumped.solver.rhs.cylinder_pressure; Wylie & Streeter 1993, section 8.5), which
      holds while the cavity stays below 10 % of the volume it forms in (Simpson & Bergant 1994, J. Hydraul.
      Eng. 120(3), 361-377); the thesis saw no cavitation (section 5.4.5);
    - accuracy: the delivery is what is left of the flows through the valves each way; when they are
      many times the delivery (a valve displacing more than the piston sweeps, a pump that barely
      delivers) its relative error is the integrator's rtol times that amplification. Not checked when a
      valve never opens (the delivery is then nothing by construction).
    """
    out = []
    if max_vapour_fraction > VAPOUR_LIMIT:
        out.append(ResultWarning("cavitation", f"the cylinder cavitates for {math.degrees(cavitation_angle):.1f} deg "
                                 f"of the revolution with vapour up to {100 * max_vapour_fraction:.3g} % of its volume, "
                                 f"more than the {100 * VAPOUR_LIMIT:.0f} % the discrete vapour cavity model holds for"))
    if all(r.opened for r in runs.values()):
        amp = max((r.forward_volume + r.backward_volume) / max(abs(r.forward_volume - r.backward_volume), 1e-300)
                  for r in runs.values())
        if amp * rtol > ACCURACY_LIMIT:
            worst = max(runs.values(), key=lambda r: r.forward_volume + r.backward_volume)
            out.append(ResultWarning("accuracy", f"the delivery {delivery * 1e6:.3g} cc/rev is what is left of "
                                     f"{worst.forward_volume * 1e6:.3g} cc through the {worst.position} valve and "
                                     f"{worst.backward_volume * 1e6:.3g} cc back ({amp:.3g}x): at rtol {rtol:g} "
                                     f"its error may reach {min(amp * rtol, 1.0) * 100:.2g} %; use a tighter rtol "
                                     "or method='reference'"))
    return out


def unresolved(outcome, rtol: float) -> ResultWarning:
    """The ``numerical_accuracy`` warning of a fast run whose reported revolution still moves when integrated
    tighter (lumped.run.accuracy.Outcome ``outcome``; ``rtol`` the run's): the estimated error, and what to do."""
    return ResultWarning("numerical_accuracy", f"the fast path's answer is not resolved: integrated at rtol "
                         f"{outcome.rtol * 10:.3g} and {outcome.rtol:.3g} the reported revolution differs in "
                         f"{outcome.difference.describe()} (limits 0.5 deg, 0.05 %, 1 %); the error may be that "
                         "large: use method='reference' (--method reference)")


# --------------------------------------------------------------------------- before running (model check)
def compression_pressure(model) -> float:
    """The highest cylinder pressure [Pa] the pump can reach: the oil a full cylinder holds at the tank
    pressure, rho(P_tank) (V_tdc + 2 A_p r), compressed into V_tdc (eqs 4.2, 4.11).

    An upper bound within the model: the inlet check valve admits oil only below the tank pressure, and
    back flow, leakage and the valves' displacement only take oil away.
    """
    pump, oil = model.pump, model.oil
    rho = oil.density_at(pump.tank_pressure) * pump.compression_ratio
    return float(oil.pressure_at(rho))


def check_model(model, load_pressure: float | None = None) -> None:
    """Refuse (:class:`geometry.errors.InputError`) what can be decided before running: a valve resting
    beyond its stop (any kind: its :class:`Envelope`), an inlet valve the tank pressure cannot open, and a
    pump that cannot deliver: its :func:`compression_pressure` not above the tank pressure plus the
    delivery valve's cracking pressure (no load at all), or not above the load (the model's
    ``[operating]`` one, or ``load_pressure`` [Pa]) plus it. ``model``: resolved (its effects applied,
    lumped.model.effect_library.resolve)."""
    from geometry.errors import InputError

    m = model
    kinds = dict(zip(("inlet", "delivery"), m.kinds))
    for pos in ("inlet", "delivery"):
        v = m.valve(pos)
        env = v.validity(m.oil)
        gap = env.stop_gap if env.stop_gap is not None else v.common(m.oil).stop_gap
        if env.rest_opening is not None and env.rest_opening > gap:
            raise InputError(f"valves.{pos}.{env.rest_key or 'stop.gap'}",
                             f"the {pos} {kinds[pos]} rests {_mm(env.rest_opening)} open, beyond its "
                             f"{_mm(gap)} stop (stop.gap): it would sit pressed on its stop and never close")
    inlet = m.inlet.validity(m.oil)
    room = m.pump.tank_pressure - m.oil.vapour_pressure      # the most the tank can push across the inlet
    if inlet.cracking_pressure is not None and inlet.cracking_pressure >= room:
        raise InputError(f"valves.inlet.{inlet.rest_key or 'spring.stiffness'}",
                         f"the inlet {kinds['inlet']} needs {_mpa(inlet.cracking_pressure)} to open, more than "
                         f"the tank pressure can give ({_mpa(room)} above the vapour pressure): the pump cannot fill")
    crack = m.delivery.validity(m.oil).cracking_pressure or 0.0
    top = compression_pressure(m)
    pt = m.pump.tank_pressure
    why = (f"compressing the oil a full cylinder holds at the tank pressure ({_mpa(pt)}) by the compression "
           f"ratio {m.pump.compression_ratio:.5g} reaches only {_mpa(top)}")
    if top <= pt + crack:
        raise InputError("pump.dead_volume", f"the pump cannot deliver against any load: {why}, not above the tank "
                                             f"pressure plus the delivery valve's {_mpa(crack)} cracking pressure")
    load = m.operating.load_pressure if load_pressure is None else load_pressure
    if load is not None and load < pt:       # absolute pressures: the pump would be fed from above its outlet
        raise InputError("operating.load_pressure", f"{_mpa(load)} is below the tank pressure {_mpa(pt)} "
                                                    "(absolute): a pump delivers into a load above its inlet")
    if load is not None and top <= load + crack:
        raise InputError("operating.load_pressure", f"the pump cannot deliver against {_mpa(load)}: {why}, not above "
                                                    f"the load plus the delivery valve's {_mpa(crack)} cracking "
                                                    f"pressure (it can pump against {_mpa(top - crack)} at most)")


# --------------------------------------------------------------------------- before running (implausible inputs)
#: a reed wider than this times its length is a plate, not the beam of eq 3.8 (the analytic and beam fidelities)
BEAM_WIDTH_TO_LENGTH = 1.0


def beam_warnings(reed, fidelity: str | None, where: str = "reed") -> list[tuple[str, str]]:
    """(key, message) when a reed wider than :data:`BEAM_WIDTH_TO_LENGTH` times its length is modelled as a
    beam (``fidelity`` analytic or beam: eq 3.8, plane sections across the width): a plate's anticlastic
    stiffening and its modes across the width are missing; the plate or solid fidelity models them."""
    if (fidelity or "analytic") not in ("analytic", "beam"):
        return []
    ratio = reed.max_width / reed.length
    if ratio <= BEAM_WIDTH_TO_LENGTH:
        return []
    return [(f"{where}.width_root", f"the reed is {ratio:.3g} times as wide as long ({reed.max_width * 1e3:.3g} mm by "
                                    f"{reed.length * 1e3:.3g} mm): beam theory (eq 3.8, fidelity "
                                    f"{fidelity or 'analytic'}) does not hold; use fidelity = \"plate\" or \"solid\"")]
