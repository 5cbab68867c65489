"""The pump driver: one revolution loop for both steppers, its bookkeeping and the result.

:func:`simulate` checks the inputs, packs the model, and runs revolutions from top dead
centre with a stepper (:mod:`lumped.steppers`: the compiled Rodas4P "fast" path, the
default, or the scipy Radau "reference"), until cyclic steady state when asked. This is
the only revolution loop: delivery per revolution (eq 4.17 at atmospheric density),
the mass balance of the quadrature states, the cyclic-steady-state test, valve timing,
impacts and losses, the needle valve setting of the complete circuit, progress on
stderr, and the invariants a result must keep (:class:`InvariantError`) are all here.
"""

from __future__ import annotations

import math
import sys
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np

from geometry.declare import check_field, check_value, Spec
from geometry.errors import InputError, ModelFailure
from lumped import switching as sw
from lumped.effect_library import resolve
from lumped.layout import pack
from lumped.model import POSITIONS, Operating, PumpModel
from lumped.model_file import load_model
from lumped.pump import (
    G, M_CAV, N_MODE, N_STATES, OFF_DEL, OFF_IN, RATES_FIELDS, S_MCYL, S_MIN, S_MLEAK, S_MLOAD, S_MNV, S_MOUT, S_UDEL, S_UIN,
    S_XDEL, S_XIN,
)
from lumped.steppers import RadauStepper, RodasStepper, state_scales
from lumped.trace import Trace
from lumped.valve import FREE, SEAT, STOP, VALVE, kind_of

METHODS = ("fast", "reference", "Radau", "BDF", "LSODA")
#: default tolerances (rtol, atol in units of each state's scale): the fast path's from
#: benchmarks/pump_tolerance_study.py, the reference's from the convergence study (README.md)
DEFAULT_TOLERANCES = {"fast": (1e-3, 1e-5), "reference": (1e-6, 1e-6)}
#: a result's own invariants (checked unless simulate(..., check=False))
MASS_BALANCE_LIMIT = 1e-6
DELIVERY_LIMITS = (-0.01, 1.01)      # x the swept volume (times rho(P_tank)/rho_0: a supercharged inlet)
MAX_REVOLUTIONS = 100_000
ENERGY_SAMPLES = 1440                # per revolution, for the valve losses and the pressure extremes
#: a stop contact counts when the element arrives after being this fraction of its stop gap clear
CONTACT_EXCURSION = 1e-3
EXCURSION_SAMPLES = 33               # dense-output samples between leaving the stop and returning


class InvariantError(ModelFailure):
    """A result that breaks its own invariants (mass balance, delivery beyond the swept volume, NaN)."""


@dataclass(frozen=True)
class ValveResult:
    """One valve over the last revolution (SI units; angles in rad from TDC, None if it never opens)."""

    kind: str
    peak_opening: float            # [m]
    opening_angle: float | None    # crank angle where its main opening starts
    closing_angle: float | None    # ... and ends
    stop_contacts: int             # arrivals on the stop
    seat_impact_velocity: float    # largest speed arriving on the seat [m/s] (0: no impact)
    stop_impact_velocity: float    # largest speed arriving on the stop [m/s]
    energy_loss: float             # pressure-drop loss integral dP Q dt over the revolution [J]


@dataclass(frozen=True)
class PumpResult:
    """Outcome of :func:`simulate`; ``inlet`` and ``delivery`` are :class:`ValveResult`."""

    model: str
    valve: str                     # "disc", "reed" or "disc/reed" (inlet/delivery kinds)
    circuit: str
    speed_rpm: float
    load_pressure: float           # requested (mean) load pressure [Pa]
    air_content: float             # R used by eq 4.11
    delivery_per_rev: float        # [m^3/rev] at atmospheric density (eq 4.17), last revolution
    swept_volume: float            # 2 A_p r [m^3]
    deliveries: tuple              # delivery of every revolution [m^3]
    revolutions: int
    cyclic_steady: bool
    cycle_change: float            # relative change of delivery and TDC state between the last two revolutions
    cpu_seconds: float
    simulated_seconds: float
    mass_balance_error: float      # |dm_cyl - (m_in - m_out - m_leak)| / m_in over the last revolution
    inlet: ValveResult
    delivery: ValveResult
    mean_load_pressure: float      # [Pa]
    leakage_per_rev: float         # [m^3] at atmospheric density
    needle_area: float | None      # [m^2] (complete circuit)
    min_cylinder_pressure: float   # [Pa] over the last revolution
    max_cylinder_pressure: float   # [Pa]
    cavitation_angle: float        # crank angle [rad] the cylinder spent cavitating in the last revolution
    rhs_evaluations: int
    steps: int
    events: int
    method: str                    # "fast" or "reference" (or the scipy method)
    rtol: float
    atol: float
    trace: Trace | None = field(default=None, compare=False)

    @property
    def valves(self) -> dict:
        """{"inlet": ValveResult, "delivery": ValveResult}."""
        return {"inlet": self.inlet, "delivery": self.delivery}

    @property
    def volumetric_efficiency(self) -> float:
        """Delivery / swept volume (-)."""
        return self.delivery_per_rev / self.swept_volume

    @property
    def cpu_per_simulated_second(self) -> float:
        """CPU seconds per simulated second of pumping (thesis section 5.6: 23 s)."""
        return self.cpu_seconds / self.simulated_seconds

    def to_dict(self) -> dict:
        """The JSON object of ``valvelab pump --json`` (CONTRACT.md), angles in degrees, volumes in cc."""
        def deg(a):
            return None if a is None else round(math.degrees(a), 3)

        def per_valve(fn):
            return {pos: fn(v) for pos, v in self.valves.items()}

        return {
            "valve": self.valve, "model": self.model, "speed_rpm": self.speed_rpm,
            "load_pressure_pa": self.load_pressure, "delivery_cc_per_rev": self.delivery_per_rev * 1e6,
            "revolutions": self.revolutions, "cpu_seconds": self.cpu_seconds,
            "mass_balance_error": self.mass_balance_error, "air_content": self.air_content, "circuit": self.circuit,
            "cyclic_steady": self.cyclic_steady, "cycle_change": self.cycle_change,
            "deliveries_cc": [d * 1e6 for d in self.deliveries],
            "volumetric_efficiency": self.volumetric_efficiency,
            "cpu_seconds_per_simulated_second": self.cpu_per_simulated_second,
            "peak_opening_m": per_valve(lambda v: v.peak_opening),
            "opening_angle_deg": per_valve(lambda v: deg(v.opening_angle)),
            "closing_angle_deg": per_valve(lambda v: deg(v.closing_angle)),
            "stop_contacts": per_valve(lambda v: v.stop_contacts),
            "seat_impact_velocity_m_s": per_valve(lambda v: v.seat_impact_velocity),
            "stop_impact_velocity_m_s": per_valve(lambda v: v.stop_impact_velocity),
            "valve_loss_j_per_rev": per_valve(lambda v: v.energy_loss),
            "mean_load_pressure_pa": self.mean_load_pressure, "needle_area_m2": self.needle_area,
            "min_cylinder_pressure_pa": self.min_cylinder_pressure,
            "max_cylinder_pressure_pa": self.max_cylinder_pressure,
            "cavitation_deg": math.degrees(self.cavitation_angle),
            "leakage_cc_per_rev": self.leakage_per_rev * 1e6,
            "method": "fast" if self.method == "fast" else "reference", "rtol": self.rtol, "atol": self.atol,
        }

    def to_frame(self):
        """pandas DataFrame, one row per valve: the ValveResult fields plus the run's delivery and speed."""
        import pandas as pd

        rows = []
        for pos, v in self.valves.items():
            row = {"valve": pos, **{k: getattr(v, k) for k in v.__dataclass_fields__}}
            row.update(speed_rpm=self.speed_rpm, load_pressure_pa=self.load_pressure,
                       delivery_m3_per_rev=self.delivery_per_rev)
            rows.append(row)
        return pd.DataFrame(rows).set_index("valve")

    def plot(self, path=None):
        """Valve openings [mm] and pressures [MPa] against crank angle [deg] (needs ``trace=True``)."""
        import matplotlib

        if path is not None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        if self.trace is None:
            raise ValueError("the result holds no trace; simulate(..., trace=True)")
        fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
        self.trace.plot(a1, ("inlet_position", "delivery_position"))
        self.trace.plot(a2, ("cylinder_pressure", "load_pressure"))
        a1.set_ylabel("valve opening [mm]")
        a2.set_ylabel("pressure [MPa]")
        fig.suptitle(f"{self.model}: {self.speed_rpm:.0f} rpm, {self.load_pressure / 1e6:.2f} MPa, "
                     f"{self.delivery_per_rev * 1e6:.3f} cc/rev")
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=120)
            plt.close(fig)
        return fig


# --------------------------------------------------------------------------- inputs
_SPEED = Operating.__dataclass_fields__["speed_rpm"].metadata["valvelab"]
_LOAD = Operating.__dataclass_fields__["load_pressure"].metadata["valvelab"]


def _int(name: str, v, lo: int, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
        raise InputError(name, f"expected an integer from {lo} to {hi}, got {v!r}")
    return int(v)


def _tol(name: str, v) -> float:
    return check_value(v, Spec(None, "-", "", bounds=(1e-14, 0.1), positive=True), name)


def _check(speed_rpm, load_pressure, revolutions, max_revolutions, circuit, method, trace_revolutions,
           trace_points, steady_tol, contact_atol):
    speed = check_value(speed_rpm, _SPEED, "speed_rpm")
    load = check_value(load_pressure, _LOAD, "load_pressure")
    revs = _int("revolutions", revolutions, 2, MAX_REVOLUTIONS)
    if max_revolutions is not None:
        _int("max_revolutions", max_revolutions, revs, MAX_REVOLUTIONS)
    if circuit not in (None, "simplified", "complete"):
        raise InputError("circuit", f"expected simplified or complete, got {circuit!r}")
    if method not in METHODS:
        raise InputError("method", f"expected one of {', '.join(METHODS)}, got {method!r}")
    _int("trace_revolutions", trace_revolutions, 1, revs)
    _int("trace_points", trace_points, 16, 1_000_000)
    _tol("steady_tol", steady_tol)
    if contact_atol is not None:
        check_value(contact_atol, Spec(None, "-", "", bounds=(1e-6, 1e6), positive=True), "contact_atol")
    return speed, load, revs


# --------------------------------------------------------------------------- the driver
def simulate(model="thesis-disc", speed_rpm: float | None = None, load_pressure: float | None = None, *,
             method: str = "fast", revolutions: int = 5, max_revolutions: int | None = None,
             circuit: str | None = None, rtol: float | None = None, atol: float | None = None,
             trace: bool = False, progress: bool = False, steady_tol: float = 1e-4, trace_revolutions: int = 1,
             trace_points: int = 2000, contact_atol: float | None = None, air_content: float | None = None,
             needle_area: float | None = None, check: bool = True, max_steps: int | None = None) -> PumpResult:
    """Simulate the pump of ``model`` at ``speed_rpm`` [rpm] and ``load_pressure`` [Pa, absolute].

    Parameters
    ----------
    model : str or PumpModel
        A shipped model (``thesis-disc``, ``thesis-reed``; ``disc``/``reed`` for short), a
        model file, or a :class:`~lumped.model.PumpModel`.
    speed_rpm, load_pressure : float
        Operating point [rpm], [Pa]; None: the model's ``[operating]`` values.
    method : str
        ``fast`` (compiled Rodas4P, default) or ``reference`` (scipy Radau; ``BDF``/``LSODA``
        also accepted).
    revolutions, max_revolutions : int
        Revolutions from TDC; with ``max_revolutions``, continue until cyclic steady state
        (relative change of delivery and TDC state below ``steady_tol``, or the
        integrator's rtol if larger) or that many.
    rtol, atol : float
        Integrator tolerances, atol in units of each state's scale (stop gap, 1 m/s, mass per
        revolution); None: DEFAULT_TOLERANCES of the method.
    trace, trace_revolutions, trace_points
        Keep the last revolutions sampled at ``trace_points`` per revolution (PumpResult.trace).
    contact_atol : float
        Fast path: velocity tolerance of a valve on its seat or stop, in units of atol x 1 m/s
        (default: each kind's own).
    air_content, circuit, needle_area
        Overrides of the model's oil.air_content, circuit kind and needle valve area.
    check : bool
        Raise :class:`InvariantError` if the result breaks its invariants (mass balance worse
        than 1e-6, delivery outside (-0.01, 1.01) swept volumes, NaN).
    max_steps : int
        Integrator steps allowed per revolution before giving up (RuntimeError); None: the
        stepper's default (fast 2,000,000, reference 500,000).

    Returns
    -------
    PumpResult

    References
    ----------
    Knutson (2016), chapter 4: eqs 4.1-4.17; section 5.6 (23 s per simulated second).

    Examples
    --------
    >>> r = simulate("thesis-disc", 593, 2.76e6)
    >>> print(f"{r.delivery_per_rev * 1e6:.2f} cc/rev")    # Table 5.4, baseline: the thesis's model 1.731
    1.73 cc/rev
    """
    m = load_model(model, field="model")
    if air_content is not None:
        check_field(m.oil, "air_content", air_content, "air_content")
        m = replace(m, oil=replace(m.oil, air_content=float(air_content)))
    speed_rpm = m.operating.speed_rpm if speed_rpm is None else speed_rpm
    load_pressure = m.operating.load_pressure if load_pressure is None else load_pressure
    if speed_rpm is None:
        raise InputError("speed_rpm", f"missing: the model {m.name!r} has no [operating] speed_rpm")
    if load_pressure is None:
        raise InputError("load_pressure", f"missing: the model {m.name!r} has no [operating] load_pressure")
    speed, load, revs = _check(speed_rpm, load_pressure, revolutions, max_revolutions, circuit, method,
                               trace_revolutions, trace_points, steady_tol, contact_atol)
    stepper_kind = "fast" if method == "fast" else "reference"
    r_def, a_def = DEFAULT_TOLERANCES[stepper_kind]
    rtol = r_def if rtol is None else _tol("rtol", rtol)
    atol = a_def if atol is None else _tol("atol", atol)
    if needle_area is not None:
        check_field(m.circuit, "needle_area", needle_area, "needle_area")
    if stepper_kind == "fast":
        ensure_compiled()                 # compiling (or loading numba's cache) is never counted
    cpu0 = _time.process_time()
    resolved = resolve(m)
    circ = circuit or resolved.circuit.kind
    complete = circ == "complete"
    p = pack(resolved, speed, load, circ, needle_area)
    tune = complete and p[G.needle_cda] <= 0.0
    if tune:
        p[G.needle_cda] = _needle_cda_estimate(resolved, p)
    n_dyn = 6 if complete else 5
    period = 2.0 * math.pi / p[G.omega]
    rho0 = resolved.oil.density
    m_rev = rho0 * resolved.pump.displacement
    scales = state_scales(p, m_rev)
    atol_v = atol * scales
    if max_steps is not None:
        _int("max_steps", max_steps, 10, 100_000_000)
    if stepper_kind == "fast":
        stepper = RodasStepper(p, rtol, atol_v, n_dyn, atol, contact_atol, record=True,
                               max_steps=max_steps or 2_000_000)
    else:
        stepper = RadauStepper(p, rtol, atol_v, n_dyn, scales, "Radau" if method == "reference" else method,
                               max_steps=max_steps or 500_000)
    physics = _physics(stepper_kind)

    y = _initial_state(resolved, p, complete, physics)
    mode = np.zeros(N_MODE)
    sw.initial_mode(0.0, y, p, mode)
    limit = max_revolutions or revs
    deliveries, tdc_states = [], [y.copy()]
    kept: list = []
    n_rhs = n_steps = n_events = 0
    tuned_at = None if tune else 0
    bar = _progress_bar(progress, limit, f"{m.name} {speed:.0f} rpm ({stepper_kind})")
    steady = False
    change = math.inf
    last = None
    k = 0
    while k < limit:
        t0, t1 = k * period, (k + 1) * period
        y_start = y.copy()
        span = stepper.advance(t0, t1, y, mode)
        y, mode = span.y_end.copy(), span.mode_end.copy()
        n_rhs += span.n_rhs
        n_steps += span.n_steps
        n_events += span.n_events
        d = {q: y[q] - y_start[q] for q in (S_MIN, S_MOUT, S_MLEAK, S_MCYL)}
        mass_err = abs(d[S_MCYL] - (d[S_MIN] - d[S_MOUT] - d[S_MLEAK])) / max(abs(d[S_MIN]), abs(d[S_MOUT]), 1e-300)
        deliveries.append(d[S_MOUT] / rho0)                      # eq 4.17 at atmospheric density
        pl_mean = _mean_load_pressure(span, p, complete, physics)
        if tune and tuned_at is None:
            # start-up procedure, like the experimenter's needle-valve setting (section 5.5.2):
            # match the needle flow to the delivery at the requested mean pressure and move
            # the load-side mass to it; the cylinder and its mass balance are not touched
            d_nv = y[S_MNV] - y_start[S_MNV]
            a_old = p[G.needle_cda]
            a_new = a_old * (d[S_MOUT] / d_nv) * math.sqrt((pl_mean - p[G.tank_pressure])
                                                           / (load - p[G.tank_pressure]))
            if abs(a_new / a_old - 1.0) < 2e-4 and abs(pl_mean / load - 1.0) < 2e-4:
                tuned_at = k + 1                                  # needle valve frozen from here on
            else:
                p[G.needle_cda] = a_new
                y[S_MLOAD] += physics.load_mass(load, p)[0] - physics.load_mass(pl_mean, p)[0]
        tdc_states.append(y.copy())
        if k >= 1:
            change = _cycle_change(deliveries, tdc_states, p, m_rev, complete)
            settled = tuned_at is not None and k + 1 - tuned_at >= 2
            steady = change < max(steady_tol, rtol) and (not complete or settled)
        last = dict(span=span, mass_err=mass_err, pl_mean=pl_mean, leak=d[S_MLEAK] / rho0, y_start=y_start)
        if trace:
            kept = (kept + [span])[-trace_revolutions:]
        k += 1
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"{deliveries[-1] * 1e6:.4f} cc/rev")
        if k >= revs and steady:
            break
    if bar is not None:
        bar.close()
    cpu = _time.process_time() - cpu0

    span = last["span"]
    omega = p[G.omega]
    timing = _valve_timing(span, period, last["y_start"], omega, p)
    impacts = _impacts(span)
    ts = span.t0 + period * np.arange(ENERGY_SAMPLES) / ENERGY_SAMPLES
    ys, modes = span.sample(ts)
    rt = physics.rates_table(ts, ys, modes, p)
    col = {n: i for i, n in enumerate(RATES_FIELDS)}
    losses = _losses(rt, col, p, period / ENERGY_SAMPLES)
    cav = float(np.mean(modes[:, M_CAV] > 0.5)) * 2.0 * math.pi
    valves = {}
    for v, pos in enumerate(POSITIONS):
        valves[pos] = ValveResult(
            kind=kind_of(resolved.valve(pos)).name, peak_opening=float(span.peaks[v]),
            opening_angle=timing[0][v], closing_angle=timing[1][v], stop_contacts=timing[2][v],
            seat_impact_velocity=impacts[v][0], stop_impact_velocity=impacts[v][1], energy_loss=losses[v])
    tr = _trace(kept, period, trace_points, p, speed, physics) if trace else None
    res = PumpResult(
        model=m.name, valve=resolved.label, circuit=circ, speed_rpm=speed, load_pressure=load,
        air_content=resolved.oil.air_content, delivery_per_rev=deliveries[-1],
        swept_volume=resolved.pump.displacement, deliveries=tuple(deliveries), revolutions=k,
        cyclic_steady=bool(steady), cycle_change=float(change), cpu_seconds=cpu, simulated_seconds=k * period,
        mass_balance_error=float(last["mass_err"]), inlet=valves["inlet"], delivery=valves["delivery"],
        mean_load_pressure=float(last["pl_mean"]), leakage_per_rev=float(last["leak"]),
        needle_area=(p[G.needle_cda] / resolved.circuit.needle_discharge) if complete else None,
        min_cylinder_pressure=float(rt[:, col["p_cyl"]].min()), max_cylinder_pressure=float(rt[:, col["p_cyl"]].max()),
        cavitation_angle=cav, rhs_evaluations=int(n_rhs), steps=int(n_steps), events=int(n_events),
        method="fast" if stepper_kind == "fast" else ("reference" if method == "reference" else method),
        rtol=rtol, atol=atol, trace=tr)
    if check:
        check_invariants(res, resolved)
    return res


def check_invariants(res: PumpResult, model: PumpModel) -> None:
    """Raise :class:`InvariantError` if ``res`` breaks the mass balance (1e-6), the delivery range or is NaN."""
    for name in ("delivery_per_rev", "mass_balance_error", "cycle_change", "mean_load_pressure",
                 "min_cylinder_pressure", "max_cylinder_pressure"):
        v = getattr(res, name)
        if isinstance(v, float) and math.isnan(v):
            raise InvariantError(f"{name} is NaN: the integration left the model's domain")
    for v in res.valves.values():
        for name in ("peak_opening", "seat_impact_velocity", "stop_impact_velocity", "energy_loss"):
            if not math.isfinite(getattr(v, name)):
                raise InvariantError(f"{name} is not finite: the integration left the model's domain")
    if res.mass_balance_error > MASS_BALANCE_LIMIT:
        raise InvariantError(f"mass balance error {res.mass_balance_error:.2e} per revolution exceeds "
                             f"{MASS_BALANCE_LIMIT:g}: the integration is not to be trusted (tighten rtol/atol)")
    oil = model.oil
    supercharge = oil.density_at(model.pump.tank_pressure) / oil.density
    lo, hi = DELIVERY_LIMITS
    d = res.delivery_per_rev / res.swept_volume
    if not lo <= d <= hi * supercharge:
        raise InvariantError(f"delivery {res.delivery_per_rev * 1e6:.4g} cc/rev is {d:.3g} swept volumes "
                             f"({res.swept_volume * 1e6:.4g} cc): outside ({lo}, {hi * supercharge:.4g})")


# --------------------------------------------------------------------------- helpers
class _Physics:
    """The pump functions the driver calls between spans: compiled (fast) or Python (reference)."""

    def __init__(self, kind: str):
        if kind == "fast":
            from lumped import compiled
            self.rates_table = compiled.cached("lumped.pump", "rates_table")
            self.load_pressure = compiled.cached("lumped.pump", "load_pressure")
            self.load_mass = compiled.cached("lumped.pump", "load_mass")
            self.oil_density = compiled.cached("lumped.pump", "oil_density")
        else:
            from lumped import pump
            self.rates_table = pump.rates_table
            self.load_pressure = pump.load_pressure
            self.load_mass = pump.load_mass
            self.oil_density = pump.oil_density


_PHYSICS: dict = {}
_COMPILE = {"seconds": None}


def ensure_compiled() -> float:
    """Compile (or load from numba's disk cache) the fast path once per process; the wall seconds it took."""
    if _COMPILE["seconds"] is None:
        t0 = _time.perf_counter()
        model = load_model("thesis-disc")
        for circ in ("simplified", "complete"):
            p = pack(model, 600.0, 2.8e6, circ, needle_area=1e-7)
            n_dyn = 6 if circ == "complete" else 5
            scales = state_scales(p, model.oil.density * model.pump.displacement)
            st = RodasStepper(p, 1e-3, 1e-5 * scales, n_dyn, 1e-5)
            y = _initial_state(model, p, circ == "complete", _physics("fast"))
            mode = np.zeros(N_MODE)
            sw.initial_mode(0.0, y, p, mode)
            span = st.advance(0.0, 1e-5, y, mode)
            ts = np.array([0.0, 5e-6])
            ys, modes = span.sample(ts)
            ph = _physics("fast")
            ph.rates_table(ts, ys, modes, p)
            ph.load_pressure(float(y[S_MLOAD]) or 1e-3, p)
            ph.load_mass(2e6, p)
        _COMPILE["seconds"] = _time.perf_counter() - t0
    return _COMPILE["seconds"]


def _physics(kind: str) -> _Physics:
    if kind not in _PHYSICS:
        _PHYSICS[kind] = _Physics(kind)
    return _PHYSICS[kind]


def _initial_state(model: PumpModel, p, complete: bool, physics) -> np.ndarray:
    """At TDC: cylinder full at load pressure, both valves at rest on their seats."""
    y = np.zeros(N_STATES)
    pl = p[G.load_pressure]
    y[S_MCYL] = model.oil.density_at(pl) * model.pump.dead_volume
    if complete:
        y[S_MLOAD] = physics.load_mass(pl, p)[0]
    return y


def _needle_cda_estimate(model: PumpModel, p) -> float:
    """First guess of Cd A of the needle valve: pass 85 % of the ideal delivery at the load pressure."""
    pl, pt = p[G.load_pressure], p[G.tank_pressure]
    oil = model.oil
    ideal = model.pump.displacement - (oil.density_at(pl) / oil.density_at(pt) - 1.0) * model.pump.dead_volume
    mdot = 0.85 * ideal * oil.density * p[G.omega] / (2 * math.pi)
    return mdot / math.sqrt(2.0 * oil.density_at(pl) * (pl - pt))


def _mean_load_pressure(span, p, complete: bool, physics) -> float:
    if not complete:
        return float(p[G.load_pressure])
    ts = np.linspace(span.t0, span.t1, 121)
    ys, _ = span.sample(ts)
    vals = [physics.load_pressure(float(yy[S_MLOAD]), p)[0] for yy in ys]
    return float(np.trapezoid(vals, ts) / (span.t1 - span.t0))


def _cycle_change(deliveries, states, p, m_rev: float, complete: bool) -> float:
    """Largest relative change between the last two revolutions: delivery and state at TDC."""

    d1, d0 = deliveries[-1], deliveries[-2]
    a, b = states[-1], states[-2]
    ch = [abs(d1 - d0) / max(abs(d1), 1e-300),
          abs(a[S_MCYL] - b[S_MCYL]) / m_rev,
          abs(a[S_XIN] - b[S_XIN]) / p[OFF_IN + VALVE.stop_gap],
          abs(a[S_XDEL] - b[S_XDEL]) / p[OFF_DEL + VALVE.stop_gap]]
    if complete:
        ch.append(abs(a[S_MLOAD] - b[S_MLOAD]) / m_rev)
    return float(max(ch))


def _stop_arrivals(span, v: int, xi: int, gap: float) -> int:
    """Arrivals of valve v on its stop in the span that follow a real excursion (see CONTACT_EXCURSION).

    A contact is counted when the element arrives on the stop after having been at least
    CONTACT_EXCURSION x the stop gap clear of it since it last left it; a departure and
    return of a few nanometres while pressed on a compliant stop is the step-size control
    crossing x_stop, not a rebound anyone could measure, and counting it would make the
    count depend on the tolerance (the two steppers then disagree).
    """
    n, left_at = 0, None
    for t, slot, old, new in span.events:
        if slot != 2 * v:
            continue
        if old == STOP and new != STOP:
            left_at = t
        elif new == STOP:
            if left_at is None or t <= left_at:
                n += 1
            else:
                ts = np.linspace(left_at, t, EXCURSION_SAMPLES)
                ys, _ = span.sample(ts)
                if gap - float(np.min(ys[:, xi])) >= CONTACT_EXCURSION * gap:
                    n += 1
            left_at = None
    return n


def _valve_timing(span, period, y_start, omega, p):
    """Crank angles of the main opening and closing of each valve and its stop contacts in a revolution."""
    events, t0 = span.events, span.t0
    opening, closing, stops = [], [], []
    for v, (xi, off) in enumerate(((S_XIN, OFF_IN), (S_XDEL, OFF_DEL))):
        ev = [(t, new) for (t, slot, old, new) in events if slot == 2 * v]
        stops.append(_stop_arrivals(span, v, xi, float(p[off + VALVE.stop_gap])))
        # open intervals [start, end) of x > 0 within the periodic revolution
        was_open = y_start[xi] > 0.0
        intervals, start = [], (t0 if was_open else None)
        for t, new in ev:
            if new == FREE and start is None:
                start = t
            elif new == SEAT and start is not None:
                intervals.append((start, t))
                start = None
        if start is not None:
            intervals.append((start, t0 + period))
        # never open, or never reseated (held off its seat, e.g. by a squeeze film): no timing
        # to report; 0 deg would be a silent wrong number
        if not intervals or intervals == [(t0, t0 + period)]:
            opening.append(None)
            closing.append(None)
            continue
        # join an interval running into the end with one starting the revolution (periodicity)
        if len(intervals) > 1 and intervals[0][0] == t0 and intervals[-1][1] == t0 + period:
            first = intervals.pop(0)
            a, b = intervals.pop()
            intervals.append((a, b + (first[1] - first[0])))
        a, b = max(intervals, key=lambda iv: iv[1] - iv[0])
        opening.append(float(((a - t0) * omega) % (2 * math.pi)))
        closing.append(float(((b - t0) * omega) % (2 * math.pi)))
    return tuple(opening), tuple(closing), tuple(stops)


def _impacts(span) -> list[tuple[float, float]]:
    """Largest speeds [m/s] at which each valve arrives on its seat and on its stop in the span."""
    out = []
    for v, ui in enumerate((S_UIN, S_UDEL)):
        seat = stop = 0.0
        for (t, slot, old, new), y in zip(span.events, span.event_states):
            if slot != 2 * v or old != FREE:
                continue
            if new == SEAT:
                seat = max(seat, abs(float(y[ui])))
            elif new == STOP:
                stop = max(stop, abs(float(y[ui])))
        out.append((seat, stop))
    return out


def _losses(rt, col, p, dt: float) -> tuple[float, float]:
    """Pressure-drop energy of each valve over the revolution, sum of dP Q dt [J] (Q = mdot / rho_orifice)."""
    pc, pl = rt[:, col["p_cyl"]], rt[:, col["p_load"]]
    q_in = rt[:, col["mdot_in"]] / rt[:, col["rho_in"]]
    q_del = rt[:, col["mdot_del"]] / rt[:, col["rho_del"]]
    e_in = float(np.sum((p[G.tank_pressure] - pc) * q_in) * dt)
    e_del = float(np.sum((pc - pl) * q_del) * dt)
    return e_in, e_del


def _trace(spans, period, npts, p, speed, physics) -> Trace:
    """The kept revolutions sampled at npts points each from the dense output."""
    ts_all, ys_all, rows = [], [], []
    for span in spans:
        ts = span.t0 + period * np.arange(npts) / npts
        ys, modes = span.sample(ts)
        rows.append(physics.rates_table(ts, ys, modes, p))
        ts_all.append(ts)
        ys_all.append(ys)
    t = np.concatenate(ts_all)
    y = np.concatenate(ys_all)
    rt = np.concatenate(rows)
    col = {n: i for i, n in enumerate(RATES_FIELDS)}
    signals = {
        "inlet_position": y[:, S_XIN], "delivery_position": y[:, S_XDEL],
        "cylinder_pressure": rt[:, col["p_cyl"]], "load_pressure": rt[:, col["p_load"]],
        "inlet_mass_flow": rt[:, col["mdot_in"]], "delivery_mass_flow": rt[:, col["mdot_del"]],
        "inlet_velocity": y[:, S_UIN], "delivery_velocity": y[:, S_UDEL],
        "vapour_volume": rt[:, col["vapour_volume"]],
    }
    return Trace(t - spans[0].t0, speed, signals)


def _progress_bar(progress: bool, total: int, desc: str):
    if not progress:
        return None
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit="rev", file=sys.stderr, leave=False)
