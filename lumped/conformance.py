"""The conformance check of a valve kind: what every registered kind must do, checked by running it.

:func:`check_valve_kind` is to a valve kind what scikit-learn's ``check_estimator`` is to an
estimator: it packs pumps with the kind at each position (with itself and with another
registered kind), runs both steppers on a few operating points and compares them (delivery
within 0.02 %, valve angles within 0.1 deg), tests the analytic Jacobian of the right-hand
side against central differences at states spread over every contact state, round-trips
``model show --toml`` through ``model check``, draws random designs from the kind's
``design_ranges`` and switches on every effect that applies to it. The tests run it for every
registered kind; docs/extending.md tells a newcomer to run it on a new one.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace

import numpy as np

#: fast vs reference: the acceptance of every kind (relative delivery, valve angles)
DELIVERY_RTOL = 2e-4
ANGLE_TOL_DEG = 0.1
#: operating points (speed [rpm], load pressure [Pa]) the steppers are compared on
POINTS = ((600.0, 2.76e6), (450.0, 1.5e6), (900.0, 4.5e6), (750.0, 3.5e6), (520.0, 2.0e6), (850.0, 1.8e6))


@dataclass
class ConformanceReport:
    """Outcome of :func:`check_valve_kind`: ``passed``; ``failures`` (one line each); ``checks`` (what was
    checked, with the measured numbers)."""

    kind: str
    failures: list = field(default_factory=list)
    checks: list = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return not self.failures

    def __str__(self) -> str:
        head = f"valve kind {self.kind!r}: {'passed' if self.passed else 'FAILED'}"
        return "\n".join([head] + [f"  ok   {c}" for c in self.checks] + [f"  FAIL {f}" for f in self.failures])


# --------------------------------------------------------------------------- the Jacobian check
def random_states(problem, rng, n: int = 8):
    """(t, y, mode) at states spread over every valve's contact states and regimes (and, for an air-free
    oil, a cavitating cylinder): the points the Jacobian is checked at."""
    from lumped.solver import rhs
    from lumped.solver.layout import BLOCK_OFFSET, CAVITATING, CAVITATION_SLOT, G, N_MODE, set_opening
    from lumped.solver.switching import initial_mode
    from lumped.valves.kind import VALVE

    p, lay = problem.p, problem.layout
    for i in range(n):
        y = np.zeros(lay.n_states)
        t = rng.uniform(0.0, problem.period)
        vol = rhs.cylinder_volume_at(t, p)[0]
        y[lay.index("m_cyl")] = problem.model.oil.density_at(rng.uniform(0.05e6, 4e6)) * vol
        for v, o in enumerate(BLOCK_OFFSET):
            stop = p[o + VALVE.stop_gap]
            pos, rates = lay.positions(v), lay.rates(v)
            y[pos] = rng.uniform(-0.2, 0.2, size=pos.stop - pos.start) * stop
            level = (-rng.uniform(1e-9, 1e-6), rng.uniform(0.05, 0.9) * stop, stop * (1 + rng.uniform(1e-5, 1e-3)),
                     rng.uniform(1e-6, 3e-5))[(i + v) % 4]
            set_opening(y, p, o, level)
            y[rates] = rng.choice([-1, 1], size=rates.stop - rates.start) * rng.uniform(0.01, 0.5,
                                                                                       size=rates.stop - rates.start)
        if problem.complete:
            y[lay.index("m_load")] = rhs.load_mass(rng.uniform(1.5e6, 4e6), p)[0]
        mode = np.zeros(N_MODE)
        initial_mode(t, y, p, mode)
        if p[G.rho_vapour] > 0 and i == n - 1:           # a cylinder below the vapour density
            y[lay.index("m_cyl")] = 0.999 * p[G.rho_vapour] * vol
            mode[CAVITATION_SLOT] = CAVITATING
        yield t, y, mode


def central_differences(t, y, p, mode, n_dyn: int, scales, masses=()):
    """(f, df/dy, df/dt) of the Python right-hand side by central differences (the reference of the check);
    steps 1e-7 of each state's scale, 1e-9 for the oil masses ``masses`` (indices: the pressures are stiff
    in them; but for the cylinder's while it cavitates: its pressure is held, and a step of 1e-9 would
    leave round-off of the accelerations above the weak dependence through the density)."""
    from lumped.solver import rhs
    from lumped.solver.layout import CAVITATING, CAVITATION_SLOT, S_MCYL

    if int(mode[CAVITATION_SLOT]) == CAVITATING:
        masses = tuple(i for i in masses if i != S_MCYL)
    f0 = rhs.rhs(t, y, p, mode)
    n = len(y)
    jfd = np.zeros((n, n))
    for j in range(n_dyn):
        h = (1e-9 if j in masses else 1e-7) * max(abs(y[j]), scales[j])
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        jfd[:, j] = (rhs.rhs(t, yp, p, mode) - rhs.rhs(t, ym, p, mode)) / (2 * h)
    dt = 1e-9
    ft = (rhs.rhs(t + dt, y, p, mode) - rhs.rhs(t - dt, y, p, mode)) / (2 * dt)
    return f0, jfd, ft


@dataclass(frozen=True)
class JacobianComparison:
    """The analytic Jacobian against central differences over drawn states: the worst normalised errors of
    df/dy and df/dt (< 1: they agree) and where they are (row, column of df/dy; row of df/dt; state names)."""

    worst_j: float
    worst_t: float
    entry: tuple = (0, 0)
    t_row: int = 0
    names: tuple = ()
    contact: str = ""

    def where(self) -> str:
        """The worst entry of df/dy by state names, d(row)/d(column)."""
        r, c = self.entry
        return f"d({self.names[r]})/d({self.names[c]})" if self.names else f"({r}, {c})"


def compare_jacobian(problem, seed: int, jac_fn, n: int = 8) -> JacobianComparison:
    """The analytic Jacobian ``jac_fn`` (lumped.solver.jacobian.pump_jacobian or its compiled copy) against
    central differences of the Python right-hand side at ``n`` states drawn by :func:`random_states`.

    Each entry is measured against its own size (1e-3 of it) and the size of its row times the state's
    scale (1e-6 of it); a non-zero column of a quadrature (the running totals never feed back) is an
    infinite error.
    """
    p, lay = problem.p, problem.layout
    n_dyn, scales = lay.n_dyn, problem.scales
    masses = (lay.index("m_cyl"), lay.index("m_load"))
    atol = 1e-8 * scales
    best = JacobianComparison(0.0, 0.0, names=tuple(lay.names))
    rng = np.random.default_rng(seed)
    for t, y, mode in random_states(problem, rng, n):
        f0, jfd, ftfd = central_differences(t, y, p, mode, n_dyn, scales, masses)
        ja = np.zeros((len(y), len(y)))
        fa = np.zeros(len(y))
        jac_fn(t, y, p, mode, np.nan, ja, fa, np.zeros(len(y)), np.zeros(len(y)), atol, 1e-6, n_dyn)
        row = np.abs(jfd[:, :n_dyn] * scales[:n_dyn]).max(axis=1, keepdims=True) + 1e-300
        err = np.abs(ja[:, :n_dyn] - jfd[:, :n_dyn]) * scales[:n_dyn] / (1e-3 * np.abs(jfd[:, :n_dyn] * scales[:n_dyn])
                                                                           + 1e-6 * row)
        if np.any(ja[:, n_dyn:] != 0.0):                     # quadratures never feed back
            r, c = np.argwhere(ja[:, n_dyn:] != 0.0)[0]
            best = replace(best, worst_j=math.inf, entry=(int(r), int(c) + n_dyn), contact=_mode_text(mode))
        elif np.nan_to_num(err, nan=math.inf).max() > best.worst_j:
            e = np.nan_to_num(err, nan=math.inf)
            r, c = np.unravel_index(int(np.argmax(e)), e.shape)
            best = replace(best, worst_j=float(e.max()), entry=(int(r), int(c)), contact=_mode_text(mode))
        tscale = np.abs(ftfd) + 1e-5 * np.abs(f0) / 1e-3 + 1e-300
        et = np.nan_to_num(np.abs(fa - ftfd) / (1e-3 * tscale), nan=math.inf)
        if et.max() > best.worst_t:
            best = replace(best, worst_t=float(et.max()), t_row=int(np.argmax(et)))
    return best


def jacobian_errors(problem, seed: int, jac_fn, n: int = 8) -> tuple[float, float]:
    """Largest normalised |analytic - central| over ``n`` states drawn, for df/dy and df/dt (< 1: agree);
    :func:`compare_jacobian` says where."""
    c = compare_jacobian(problem, seed, jac_fn, n)
    return c.worst_j, c.worst_t


def _mode_text(mode) -> str:
    from lumped.solver.layout import CONTACT_SLOT, POSITIONS
    from lumped.valves.kind import CONTACT_NAMES

    return ", ".join(f"{pos} {CONTACT_NAMES[int(mode[s])]}" for pos, s in zip(POSITIONS, CONTACT_SLOT))


def likely_cause(c: JacobianComparison, kind) -> str:
    """Where a Jacobian mismatch most likely comes from, read from the entry's row and column."""
    if not c.names:
        return ""
    if not math.isfinite(c.worst_j) and c.entry[1] >= len(c.names) - 4:
        return "a running total (quadrature) feeds back into the dynamics: the right-hand side reads it"
    r, col = (c.names[c.entry[0]], c.names[c.entry[1]]) if c.worst_j >= 1.0 else (c.names[c.t_row], "t")
    if not (r.endswith(".u") or ".qdot" in r):          # not a valve's acceleration row
        return ("the mass flows: valve_flow's partials (the orifice area law A_o(x) and Cd(Re)) or a kind's "
                "Common quantities (area_per_opening, area_curvature, displacement areas)")
    if col in ("m_cyl", "m_load", "t"):
        return ("the acceleration reads the pressures or the flow (f.q_o, f.cd, f.ddp_dt) in a way the chain rule "
                "misses: set Common.flow_in_acceleration=True when it reads the flow, so the flow is recomputed "
                "at each perturbation")
    if kind is not None and kind.accelerations_jacobian is not None:
        return (f"the kind's accelerations_jacobian ({kind.accelerations_jacobian.__name__}) disagrees with its "
                "accelerations")
    return ("the acceleration reads the flow (f.q_o, f.cd) without Common.flow_in_acceleration=True, or is not "
            "smooth in the valve's own states inside a contact state and regime (a branch on x or u that the mode "
            "does not fix, e.g. a contact decided from x instead of `contact`)")


# --------------------------------------------------------------------------- the check
def _angles(res) -> list:
    return [res.inlet.opening_angle, res.inlet.closing_angle, res.delivery.opening_angle, res.delivery.closing_angle]


def _compare(report, label: str, model, speed: float, load: float, revolutions: int) -> None:
    from lumped.run.simulate import simulate

    r = simulate(model, speed, load, method="reference", revolutions=revolutions)
    f = simulate(model, speed, load, method="fast", revolutions=revolutions)
    dd = abs(f.delivery_per_rev / r.delivery_per_rev - 1.0)
    worst = 0.0
    for a, b in zip(_angles(f), _angles(r)):
        if (a is None) != (b is None):
            report.failures.append(f"{label}: a valve opens on one stepper and not on the other")
            return
        if a is not None:
            d = abs(a - b)
            worst = max(worst, math.degrees(min(d, 2 * math.pi - d)))
    what = f"{label} at {speed:.0f} rpm, {load / 1e6:.2f} MPa: fast vs reference delivery {dd * 100:.4f} %, " \
           f"angles {worst:.3f} deg"
    if dd > DELIVERY_RTOL or worst > ANGLE_TOL_DEG:
        report.failures.append(what + f" (limits {DELIVERY_RTOL * 100:g} %, {ANGLE_TOL_DEG:g} deg)")
    else:
        report.checks.append(what)


def _finite_positive(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0


def _contract(report, kind) -> None:
    """The static contract (lumped.valves.kind.check_kind: what register refuses) and the default model's valves:
    each of its kind, common() a checked Common, DERIVED given by packed_extra(), natural_frequency() positive."""
    from lumped.model.model_file import kind_default_model, load_model
    from lumped.valves.kind import Common, check_kind

    cls = kind.params
    check_kind(_unregistered(kind))
    model = load_model(kind_default_model(kind.name))
    for pos in ("inlet", "delivery"):
        v = model.valve(pos)
        if type(v) is not cls:
            raise AssertionError(f"the default model {kind.default_model!r} has no {kind.name} valve at {pos}")
        c = v.common(model.oil)
        if not isinstance(c, Common):
            raise AssertionError(f"{cls.__name__}.common() returned {type(c).__name__}, not lumped.valves.kind.Common")
        missing = set(cls.DERIVED) - set(v.packed_extra(model.oil))
        if missing:
            raise AssertionError(f"{cls.__name__}.packed_extra() lacks {sorted(missing)} (declared in DERIVED)")
        if not _finite_positive(v.natural_frequency()):
            raise AssertionError(f"{cls.__name__}.natural_frequency() = {v.natural_frequency()!r}: expected a "
                                 "positive finite number [rad/s]")
    report.checks.append(f"{cls.__name__}: frozen ValveParams dataclass, the fields its acceleration reads packed, "
                         f"common() a checked Common, DERIVED packed, default model {kind.default_model!r}")


def _unregistered(kind):
    """The kind as register() saw it (its own name is taken now: check it under a name of its own)."""
    from dataclasses import replace as _replace

    return _replace(kind, name=f"{kind.name}_unregistered_check")


def _check_reports(report, kind) -> None:
    """What `model check` prints and warns of the default model's valves: describe() a dict of reportable values,
    damping_ratios() finite, validity() an Envelope whose limits name quantities a run measures."""
    import json

    from lumped.model.model_file import kind_default_model, load_model
    from lumped.validity import QUANTITIES, Envelope

    model = load_model(kind_default_model(kind.name))
    for pos in ("inlet", "delivery"):
        v = model.valve(pos)
        d = v.describe()
        if not isinstance(d, dict):
            raise AssertionError(f"{type(v).__name__}.describe() returned {type(d).__name__}, not a dict")
        json.dumps(d)                                          # model check --json prints it
        ratios = v.damping_ratios()
        bad = {k: z for k, z in ratios.items() if not (isinstance(z, float) and math.isfinite(z) and z >= 0)}
        if bad:
            raise AssertionError(f"{type(v).__name__}.damping_ratios() = {bad}: expected finite ratios >= 0")
        env = v.validity(model.oil)
        if not isinstance(env, Envelope):
            raise AssertionError(f"{type(v).__name__}.validity() returned {type(env).__name__}, not "
                                 "lumped.validity.Envelope")
        unknown = [lim.quantity for lim in env.limits if lim.quantity not in QUANTITIES]
        if unknown:
            raise AssertionError(f"{type(v).__name__}.validity(): a limit on {unknown[0]!r}, which a run does not "
                                 f"measure (one of {', '.join(QUANTITIES)})")
        if env.rest_opening is not None and not math.isfinite(env.rest_opening):
            raise AssertionError(f"{type(v).__name__}.validity(): rest opening {env.rest_opening!r} [m]")
        if env.cracking_pressure is not None and not (math.isfinite(env.cracking_pressure)
                                                      and env.cracking_pressure >= 0):
            raise AssertionError(f"{type(v).__name__}.validity(): cracking pressure {env.cracking_pressure!r} [Pa]")
    report.checks.append(f"describe(), damping_ratios() and validity() of the default model's valves: "
                         f"{len(env.limits)} validity limits ({', '.join(lim.code for lim in env.limits)})")


def check_valve_kind(kind, *, points: int = 3, revolutions: int = 3, quick: bool = False,
                     seed: int = 0) -> ConformanceReport:
    """Check a registered valve kind against the kind contract by running it (see the module docstring).

    Every check is guarded and named: a check that raises is one failure line (its name, the exception's type
    and message), never an exception out of this function.

    Parameters
    ----------
    kind : str or lumped.valves.kind.ValveKind
        The kind (its registered name).
    points : int
        Operating points (of :data:`POINTS`) the two steppers are compared on, for the pump with the
        kind at both positions; the mixed pumps are compared on the first.
    revolutions : int
        Revolutions per run (from TDC).
    quick : bool
        Skip the mixed pumps and check the effects on the fast stepper only.
    seed : int
        Seed of the drawn states (Jacobian) and designs.

    Returns
    -------
    ConformanceReport
        ``passed`` and ``failures`` (CONTRACT.md), and the measured ``checks``.

    Raises
    ------
    geometry.errors.InputError
        An unknown kind or a bad ``points`` (the call, not the kind, is wrong).

    Examples
    --------
    >>> report = check_valve_kind("ball", points=1, quick=True)
    >>> report.passed, report.failures
    (True, [])
    """
    from geometry.errors import InputError
    from lumped.valves.kind import KINDS

    name = getattr(kind, "name", kind)
    if name not in KINDS:
        raise InputError("kind", f"expected one of {', '.join(KINDS)}, got {name!r}")
    if not isinstance(points, int) or isinstance(points, bool) or not 1 <= points <= len(POINTS):
        raise InputError("points", f"expected an integer from 1 to {len(POINTS)}, got {points!r}")
    kind = KINDS[name]
    report = ConformanceReport(name)
    _guarded(report, "contract", _contract, report, kind)
    if report.failures:
        return report
    _guarded(report, "reports", _check_reports, report, kind)
    pumps = []
    _guarded(report, "pumps", _pumps, pumps, name, quick)
    _run_pumps(report, kind, pumps, (points, revolutions, seed))
    _guarded(report, "design_ranges", _check_designs, report, name, seed)
    if pumps:
        _check_effects(report, kind, pumps[0][1])
    return report


def _run_pumps(report, kind, pumps: list, how: tuple) -> None:
    """The checks that run the kind's pumps: the two steppers compared (the first pump on ``points`` operating
    points, the mixed ones on the first), the Jacobian in both circuits and the model file's round trip;
    ``how`` = (points, revolutions, seed)."""
    points, revolutions, seed = how
    for i, (label, model) in enumerate(pumps):
        for speed, load in POINTS[:points if i == 0 else 1]:
            _guarded(report, f"{label} at {speed:.0f} rpm", _compare, report, label, model, speed, load, revolutions)
    for label, model in pumps:
        for circuit in ("simplified", "complete"):
            _guarded(report, f"{label}, {circuit} circuit: Jacobian", _check_jacobian, report, label, model,
                     circuit, seed, kind)
        _guarded(report, f"{label}: model show --toml", _check_round_trip, report, label, model)


def _pumps(out: list, name: str, quick: bool) -> None:
    """The pumps the kind is run in: at both positions (its default model) and, unless quick, mixed with the
    first other registered kind at either position."""
    from lumped.model.model_file import kind_default_model, load_model
    from lumped.model.random_designs import mixed_model
    from lumped.valves.kind import KINDS

    out.append((f"{name} pump", load_model(kind_default_model(name))))
    others = [k for k in KINDS if k != name]
    if others and not quick:
        out += [(f"{name} inlet / {others[0]} delivery", mixed_model(name, others[0])),
                (f"{others[0]} inlet / {name} delivery", mixed_model(others[0], name))]


def _guarded(report, label: str, fn, *args) -> None:
    """Run one named check; an exception is a failure of the kind, reported with its name and what raised."""
    try:
        fn(*args)
    except Exception as exc:  # noqa: BLE001 - reported, not hidden
        report.failures.append(f"{label}: {type(exc).__name__}: {exc}")


def _check_jacobian(report, label: str, model, circuit: str, seed: int, kind) -> None:
    """The analytic Jacobian of the flavour the fast path uses against central differences; a mismatch names
    the worst entry (state names) and its likely cause."""
    from lumped.solver import compiled
    from lumped.solver.problem import PumpProblem

    problem = PumpProblem.build(model, 650.0, 2.8e6, circuit, needle_area=2e-7 if circuit == "complete" else None)
    jac = compiled.cached("lumped.solver.jacobian", "pump_jacobian", problem.layout.one_dof)
    c = compare_jacobian(problem, seed + 7, jac)
    what = (f"{label}, {circuit} circuit: Jacobian vs central differences {c.worst_j:.3g} / {c.worst_t:.3g} "
            "tolerance units")
    if c.worst_j < 1.0 and c.worst_t < 1.0:
        report.checks.append(what)
        return
    entry = c.where() if c.worst_j >= 1.0 else f"d({c.names[c.t_row]})/dt"
    report.failures.append(f"{what}; worst entry {entry} ({c.contact}); likely cause: {likely_cause(c, kind)}")


def _check_round_trip(report, label: str, model) -> None:
    """``model show --toml`` read back by ``model check`` gives the same model."""
    from lumped.model.model_file import describe, parse_model, to_toml

    again = parse_model(tomllib.loads(to_toml(model)), name=model.name, source=model.source)
    describe(again)
    same = again == model
    (report.checks if same else report.failures).append(
        f"{label}: model show --toml round-trips through model check" + ("" if same else " to another model"))


def _check_designs(report, name: str, seed: int) -> None:
    """Random designs from the kind's design ranges are valid models, alone and in a mixed pump."""
    from lumped.model.random_designs import random_design
    from lumped.valves.kind import KINDS

    rng = np.random.default_rng(seed)
    others = [o for o in KINDS if o != name][:1]
    for valve in (name, *(f"{name}/{o}" for o in others)):
        random_design(rng, valve)
    report.checks.append(f"design_ranges {sorted(KINDS[name].design_ranges)} give valid models")


def _check_effects(report, kind, model) -> None:
    """Every effect that claims the kind declares the fields it sets on it, switches on at its priors and runs."""
    from lumped.model.effect_library import LIBRARY
    from lumped.model.effects import missing_fields
    from lumped.model.model_file import with_values
    from lumped.run.simulate import simulate

    for e in LIBRARY.effects.values():
        missing = missing_fields(e, [kind]) if e.valve_types is None or kind.name in e.valve_types else []
        if missing:
            report.failures.extend(missing)
            continue
        targets = [t for t in e.targets if e.applies_to(model, t)]
        for t in targets[:1]:
            key = f"effects.{e.name}" + ("" if t in ("both", "pump") else f".{t}")

            def run(key=key, t=t, e=e):
                r = simulate(with_values(model, {key: True}), 600.0, 2.76e6, revolutions=2)
                report.checks.append(f"effect {e.name}@{t} runs: {r.delivery_per_rev * 1e6:.4f} cc/rev")

            _guarded(report, f"effect {e.name}@{t}", run)
