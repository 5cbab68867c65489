"""The pump driver: :func:`simulate`, the result it returns and the invariants a result keeps.

:func:`simulate` has the shape of scipy's ``solve_ivp``: it checks the inputs, builds the
problem (:class:`lumped.solver.problem.PumpProblem`: the resolved model, packed), makes the
stepper its ``method`` names (:data:`lumped.solver.steppers.METHODS`: the compiled Rosenbrock "fast"
path, the default, or the scipy "reference"), runs revolutions from top dead centre until
the stop rule is met (:mod:`lumped.run.revolutions`) and hands the last revolution to the
post-processors (:mod:`lumped.run.postprocess`: timing, impacts, losses, the trace). A result
that breaks its own invariants is an :class:`InvariantError`, not an output.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np

from geometry.declare import check_field, check_value
from geometry.errors import InputError, ModelFailure
from lumped.run import accuracy, postprocess as post
from lumped import validity
from lumped.solver import switching as sw
from lumped.solver.layout import CAVITATION_SLOT, N_MODE, POSITIONS, G
from lumped.model.pump_model import Operating, PumpModel
from lumped.model.model_file import load_model
from lumped.solver.problem import PumpProblem
from lumped.run.options import (  # noqa: F401 - SolverOptions, TraceOptions: simulate's options objects
    MAX_REVOLUTIONS, METHODS, Overrides, RunOptions, SolverOptions, TraceOptions,
)
from lumped.run.revolutions import StopRule, TdcState, run, tdc_state  # noqa: F401 - TdcState: simulate's type
from lumped.solver.steppers import DEFAULT_TOLERANCES, METHODS as STEPPERS  # noqa: F401 - the tolerances: API
from lumped.run.trace import Trace
from lumped.valves.kind import kind_of

#: a result's own invariants (checked unless simulate(..., check=False))
MASS_BALANCE_LIMIT = 1e-6
DELIVERY_LIMITS = (-0.01, 1.01)      # x the swept volume (times rho(P_tank)/rho_0: a supercharged inlet)


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
    energy_loss: float             # energy dissipated by throttling, integral of dP Q_o dt over the revolution [J]


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
                                   # (one revolution: of the TDC state and the cylinder mass over it, first_change)
    cpu_seconds: float
    simulated_seconds: float
    mass_balance_error: float      # |dm_cyl - (m_in - m_out - m_leak)| / the mass through the valves, last revolution
                                   # (at least 1 % of one swept volume's: postprocess.mass_balance)
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
    dynamics: dict = field(default_factory=dict)   # {position: {"kind": "modal", "modes": N} | {"kind": "fe", "dofs": n}}
    warnings: tuple = ()           # lumped.validity.ResultWarning: conditions of the model's equations the run left
    start: str = "cold"            # "cold": today's start (valves seated, cylinder at the load pressure); "warm": a TdcState
    steady_tol: float = math.nan   # the tolerance cycle_change was tested against (the stop rule's, floored at rtol;
                                   # one revolution: SINGLE_FRACTION of it)
    tdc_state: object = field(default=None, compare=False, repr=False)   # lumped.run.revolutions.TdcState: the next start
    # the fast path's accuracy check (lumped.run.accuracy): the tightening of the reported revolution (0: the run's
    # own), its rtol, whether resolved, the extra steps and the last difference found (angle [rad], delivery and
    # peak [-]); None: not checked (reference path, complete circuit, accuracy_check=False)
    accuracy: dict | None = field(default=None, compare=False)

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
            "cyclic_steady": self.cyclic_steady, "cycle_change": self.cycle_change, "steady_tol": self.steady_tol,
            "start": self.start,
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
            "dynamics": {pos: dict(d) for pos, d in self.dynamics.items()},
            "warnings": [w.to_dict() for w in self.warnings],
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

    def plot(self, path=None, force: bool = False):
        """Valve openings [mm] and pressures [MPa] against crank angle [deg] (needs ``trace=True``); with
        ``path`` the figure is saved there, an existing file only replaced with ``force=True``."""
        import matplotlib

        if self.trace is None:
            raise InputError("trace", "the result holds no trace: run simulate(..., trace=True) to plot it")
        if not isinstance(force, bool):
            raise InputError("force", f"expected True or False, got {force!r}")
        if path is not None:
            from pathlib import Path

            if not isinstance(path, (str, Path)) or not str(path):
                raise InputError("path", f"expected a file path, got {path!r}")
            if Path(path).suffix.lower() not in PLOT_SUFFIXES:
                raise InputError("path", f"{Path(path).name}: expected a file ending in {', '.join(PLOT_SUFFIXES)}")
            if Path(path).is_dir() or not Path(path).parent.is_dir():
                raise InputError("path", f"{path}: expected a file in an existing folder")
            if Path(path).exists() and not force:
                raise InputError("path", f"{path} already exists; pass force=True to replace it")
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(8.5, 5))
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
#: the figure files PumpResult.plot writes (as the command line's --plot)
PLOT_SUFFIXES = (".png", ".pdf", ".svg")
_SPEED = Operating.__dataclass_fields__["speed_rpm"].metadata["valvelab"]
_LOAD = Operating.__dataclass_fields__["load_pressure"].metadata["valvelab"]


def _model_for_run(model, speed_rpm, load_pressure, overrides: Overrides, solver: SolverOptions):
    """(model, speed [rpm], load [Pa]): the model loaded with the run's overrides, the operating point checked
    (the model's ``[operating]`` where None); InputError naming a bad one, before anything is compiled."""
    m = load_model(model, field="model")
    if overrides.air_content is not None:
        check_field(m.oil, "air_content", overrides.air_content, "air_content")
        m = replace(m, oil=replace(m.oil, air_content=float(overrides.air_content)))
    speed_rpm = m.operating.speed_rpm if speed_rpm is None else speed_rpm
    load_pressure = m.operating.load_pressure if load_pressure is None else load_pressure
    if speed_rpm is None:
        raise InputError("speed_rpm", f"missing: the model {m.name!r} has no [operating] speed_rpm")
    if load_pressure is None:
        raise InputError("load_pressure", f"missing: the model {m.name!r} has no [operating] load_pressure")
    speed = check_value(speed_rpm, _SPEED, "speed_rpm")
    load = check_value(load_pressure, _LOAD, "load_pressure")
    if load < m.pump.tank_pressure:      # absolute pressures: the pump would be fed from above its outlet
        raise InputError("load_pressure", f"{load:g} Pa is below the tank pressure {m.pump.tank_pressure:g} Pa "
                                          "(absolute): a pump delivers into a load above its inlet")
    if overrides.needle_area is not None:
        check_field(m.circuit, "needle_area", overrides.needle_area, "needle_area")
    for pos in POSITIONS:
        if solver.family == "fast" and getattr(m.valve(pos), "dynamics", None) == "fe":
            raise InputError(f"valves.{pos}.dynamics", "the whole FE reed runs on the reference stepper only: "
                             "give method='reference' (--method reference), or dynamics = \"modal\" for the fast one")
    return m, speed, load


# --------------------------------------------------------------------------- the driver
def simulate(model="thesis-disc", speed_rpm: float | None = None, load_pressure: float | None = None, *,
             method: str = "fast", trace: bool | TraceOptions = False, stop: StopRule | None = None,
             **options) -> PumpResult:
    """Simulate the pump of ``model`` at ``speed_rpm`` [rpm] and ``load_pressure`` [Pa, absolute].

    Parameters
    ----------
    model : str or PumpModel
        A shipped model (``thesis-disc``, ``thesis-reed``; ``disc``/``reed`` for short), a model file, or a
        :class:`~lumped.model.pump_model.PumpModel`.
    speed_rpm, load_pressure : float
        Operating point [rpm], [Pa]; None: the model's ``[operating]`` values.
    method : str
        ``fast`` (compiled Rodas4P; Rodas5P with a flow force at rtol <= 1e-4; default) or ``reference``
        (scipy Radau; ``BDF``/``LSODA`` also accepted).
    trace : bool or TraceOptions
        Keep the last revolutions sampled (PumpResult.trace).
    stop : StopRule
        When to stop, instead of ``revolutions``, ``max_revolutions``, ``steady_tol``
        (``StopRule.steady(tol)``: until cyclic steady state, as the studies do).
    **options
        The keywords of :class:`~lumped.run.options.RunOptions` (CONTRACT.md): ``revolutions`` (5),
        ``max_revolutions``, ``steady_tol`` (1e-4); ``rtol``, ``atol`` (atol in units of each state's scale),
        ``contact_atol``, ``max_steps`` or ``solver=SolverOptions(...)``; ``trace_revolutions`` (1),
        ``trace_points`` (2000); ``initial_state`` (a ``PumpResult.tdc_state``: a warm start); ``air_content``,
        ``circuit``, ``needle_area`` (overrides of the model's); ``progress``; ``check`` (True: raise
        :class:`InvariantError` for a result breaking its invariants).

    Returns
    -------
    PumpResult

    Raises
    ------
    geometry.errors.InputError
        A bad argument, named, before anything is compiled or integrated.

    References
    ----------
    Knutson (2016), chapter 4: eqs 4.1-4.17; section 5.6 (23 s per simulated second).

    Examples
    --------
    >>> r = simulate("thesis-disc", 593, 2.76e6)
    >>> print(f"{r.delivery_per_rev * 1e6:.2f} cc/rev")    # Table 5.4, baseline: the thesis's model 1.731
    1.73 cc/rev
    """
    opts = RunOptions.from_keywords(method, trace, stop, options)
    m, speed, load = _model_for_run(model, speed_rpm, load_pressure, opts.overrides, opts.solver)
    return _run(m, speed, load, opts)


def _run(m: PumpModel, speed: float, load: float, opts: RunOptions) -> PumpResult:
    """Integrate a checked run (:func:`simulate`) and post-process its last revolution."""
    rtol, atol = opts.solver.tolerances()
    kind = opts.solver.family
    if kind == "fast":
        ensure_compiled()                 # compiling (or loading numba's cache) is never counted
    cpu0 = _time.process_time()
    problem = PumpProblem.build(m, speed, load, opts.overrides.circuit, opts.overrides.needle_area)
    stepper = STEPPERS[opts.solver.method](problem, rtol, atol, contact_atol=opts.solver.contact_atol, record=True,
                                           max_steps=opts.solver.max_steps)
    physics = _physics(kind + ("1" if kind == "fast" and problem.layout.one_dof else ""))
    warm, y, mode = _start(problem, stepper, physics, opts.initial_state)
    done = run(problem, stepper, y, mode, opts.stop, physics, rtol=rtol,
               keep=opts.trace.revolutions if opts.trace else 0, progress=opts.progress,
               label=f"{m.name} {speed:.0f} rpm ({kind})", warm=warm)
    tdc = tdc_state(problem, done, physics.load_mass, stepper)
    checked = None
    if kind == "fast" and opts.solver.accuracy_check and not problem.complete:
        # the reported revolution again, tighter (lumped.run.accuracy); a tuned needle valve changes between
        # revolutions: the complete circuit is not re-integrated
        # the run's own method and order (a tighter rtol would pick Rodas5P for a flow force: another kernel to
        # compile), so the tighter levels differ from the run by their tolerances only
        checked = accuracy.check(problem, done, STEPPERS[opts.solver.method], physics, rtol, atol,
                                 {"contact_atol": opts.solver.contact_atol, "max_steps": opts.solver.max_steps,
                                  "order": stepper.order})
        done.n_steps += checked.extra_steps
    cpu = _time.process_time() - cpu0      # the integration and its check; the post-processing is not counted
    rt_modes = post.rates(done.last.span, problem, physics)
    info = _RunInfo(opts.solver.method, rtol, atol, cpu, opts.trace.points if opts.trace else 0,
                    "warm" if warm else "cold", done.tol if done.tol else opts.stop.tolerance(rtol), tdc, checked)
    res = _result(m, problem, done, physics, info, rt_modes)
    if opts.check:
        check_invariants(res, problem.model)
    return res


def _start(problem: PumpProblem, stepper, physics, initial_state) -> tuple[bool, np.ndarray, np.ndarray]:
    """(warm, state, mode) a run starts from: ``initial_state`` where it fits the problem (its step-size memory
    handed to the stepper), else today's start (valves seated, the cylinder full at the load pressure)."""
    warm = initial_state is not None and initial_state.fits(problem)
    if warm:
        y, mode = initial_state.start(problem, physics.load_mass)
        if problem.tune_needle and initial_state.needle_cda:
            problem.p[G.needle_cda] = initial_state.needle_cda   # the tuning starts from the solved design's
        if hasattr(stepper, "restore"):
            stepper.restore(initial_state.memory)
        return True, y, mode
    y = problem.initial_state(physics.load_mass)
    mode = np.zeros(N_MODE)
    sw.initial_mode(0.0, y, problem.p, mode)
    return False, y, mode


@dataclass(frozen=True)
class _RunInfo:
    """How a finished run was made, for its :class:`PumpResult`: the method, tolerances, CPU seconds, trace
    samples per revolution (0: none), the start ("cold"/"warm"), the steady-state tolerance tested, the
    :class:`~lumped.run.revolutions.TdcState` it ended with."""

    method: str
    rtol: float
    atol: float
    cpu: float
    trace_points: int
    start: str
    steady_tol: float
    tdc: object
    accuracy: object = None           # lumped.run.accuracy.Outcome (None: not checked)


def _result(m: PumpModel, problem: PumpProblem, done, physics, info: _RunInfo, rt_modes) -> "PumpResult":
    """The :class:`PumpResult` of a finished run: the last revolution post-processed (``rt_modes``: its rates
    table and modes, lumped.run.postprocess.rates)."""
    last = done.last
    span = last.span
    resolved = problem.model
    rt, modes = rt_modes
    losses = post.losses(rt, problem, problem.period / post.ENERGY_SAMPLES)
    cav = float(np.mean(modes[:, CAVITATION_SLOT] > 0.5)) * 2.0 * math.pi
    valves = _valve_results(problem, span, last, losses)
    runs = post.valve_runs(span, problem, rt, losses, [kind_of(resolved.valve(pos)).name for pos in POSITIONS])
    vapour = float(np.max(rt[:, post.COL["vapour_volume"]] / rt[:, post.COL["volume"]]))
    warns = [w for pos in POSITIONS for w in validity.valve_warnings(resolved.valve(pos), runs[pos], resolved.oil)]
    warns += validity.pump_warnings(runs, last.delivery, info.rtol, cav, vapour)
    if info.accuracy is not None and not info.accuracy.resolved:
        warns.append(validity.unresolved(info.accuracy, info.rtol))
    tr = post.trace(done.kept, problem, info.trace_points, physics) if info.trace_points else None
    p_cyl = rt[:, post.COL["p_cyl"]]
    method = info.method
    return PumpResult(
        model=m.name, valve=resolved.label, circuit=problem.circuit, speed_rpm=problem.speed_rpm,
        load_pressure=problem.load_pressure, air_content=resolved.oil.air_content, delivery_per_rev=last.delivery,
        swept_volume=resolved.pump.displacement, deliveries=done.deliveries, revolutions=len(done.revolutions),
        cyclic_steady=bool(done.steady), cycle_change=float(done.change), cpu_seconds=info.cpu,
        simulated_seconds=len(done.revolutions) * problem.period, mass_balance_error=post.mass_balance(problem, last),
        inlet=valves["inlet"], delivery=valves["delivery"], mean_load_pressure=float(last.mean_load_pressure),
        leakage_per_rev=float(last.leakage),
        needle_area=(problem.p[G.needle_cda] / resolved.circuit.needle_discharge) if problem.complete else None,
        min_cylinder_pressure=float(p_cyl.min()), max_cylinder_pressure=float(p_cyl.max()),
        cavitation_angle=cav, rhs_evaluations=int(done.n_rhs), steps=int(done.n_steps), events=int(done.n_events),
        method="fast" if method == "fast" else ("reference" if method == "reference" else method),
        rtol=info.rtol, atol=info.atol, trace=tr, dynamics=_dynamics(resolved), warnings=tuple(warns),
        start=info.start, steady_tol=info.steady_tol, tdc_state=info.tdc,
        accuracy=None if info.accuracy is None else {
            "level": info.accuracy.level, "rtol": info.accuracy.rtol, "resolved": info.accuracy.resolved,
            "extra_steps": info.accuracy.extra_steps,
            "difference": {k: float(v) for k, v in dataclasses.asdict(info.accuracy.difference).items()}})


def _valve_results(problem: PumpProblem, span, last, losses) -> dict:
    """{position: :class:`ValveResult`} of the last revolution: timing, peak, stop contacts, impacts, losses."""
    openings, closings, stops = post.valve_timing(span, problem, last.y_start)
    impacts = post.impacts(span, problem)
    out = {}
    for v, pos in enumerate(POSITIONS):
        out[pos] = ValveResult(
            kind=kind_of(problem.model.valve(pos)).name, peak_opening=float(span.peaks[v]),
            opening_angle=openings[v], closing_angle=closings[v], stop_contacts=stops[v],
            seat_impact_velocity=impacts[v][0], stop_impact_velocity=impacts[v][1], energy_loss=losses[v])
    return out


def _dynamics(model) -> dict:
    """The valves moved beyond one DOF: {position: {"kind": "modal", "modes": N} or {"kind": "fe", "dofs": n}}."""
    out = {}
    for pos in POSITIONS:
        v = model.valve(pos)
        dyn = getattr(v, "dynamics", None)
        if dyn == "modal":
            out[pos] = {"kind": "modal", "modes": int(v.modes)}
        elif dyn == "fe":
            out[pos] = {"kind": "fe", "dofs": int(v.dofs())}
    return out


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
    """The pump functions the driver calls between spans: compiled (fast; "fast1" the one-DOF flavour,
    lumped.solver.compiled.physics) or Python (reference)."""

    def __init__(self, kind: str):
        if kind.startswith("fast"):
            from lumped.solver import compiled
            one = kind == "fast1"
            self.rates_table = compiled.cached("lumped.solver.rhs", "rates_table", one)
            self.load_pressure = compiled.cached("lumped.solver.rhs", "load_pressure", one)
            self.load_mass = compiled.cached("lumped.solver.rhs", "load_mass", one)
            self.oil_density = compiled.cached("lumped.solver.rhs", "oil_density", one)
        else:
            from lumped.solver import rhs
            self.rates_table = rhs.rates_table
            self.load_pressure = rhs.load_pressure
            self.load_mass = rhs.load_mass
            self.oil_density = rhs.oil_density


_PHYSICS: dict = {}
_COMPILE = {"seconds": None}


def ensure_compiled() -> float:
    """Compile (or load from numba's disk cache) the fast path once per process; the wall seconds it took."""
    if _COMPILE["seconds"] is None:
        t0 = _time.perf_counter()
        model = load_model("thesis-disc")
        ph = _physics("fast1")
        for circ in ("simplified", "complete"):
            problem = PumpProblem.build(model, 600.0, 2.8e6, circ, needle_area=1e-7)
            st = STEPPERS["fast"](problem, 1e-3, 1e-5)
            y = problem.initial_state(ph.load_mass)
            mode = np.zeros(N_MODE)
            sw.initial_mode(0.0, y, problem.p, mode)
            span = st.advance(0.0, 1e-5, y, mode)
            ts = np.array([0.0, 5e-6])
            ys, modes = span.sample(ts)
            ph.rates_table(ts, ys, modes, problem.p)
            ph.load_pressure(float(y[problem.layout.index("m_load")]) or 1e-3, problem.p)
            ph.load_mass(2e6, problem.p)
        _COMPILE["seconds"] = _time.perf_counter() - t0
    return _COMPILE["seconds"]


def _physics(kind: str) -> _Physics:
    if kind not in _PHYSICS:
        _PHYSICS[kind] = _Physics(kind)
    return _PHYSICS[kind]
