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
from dataclasses import dataclass, field, fields, is_dataclass

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


def jacobian_errors(problem, seed: int, jac_fn, n: int = 8) -> tuple[float, float]:
    """Largest normalised |analytic - central| over ``n`` states drawn, for df/dy and df/dt (< 1: agree).

    Each entry is measured against its own size (1e-3 of it) and the size of its row times the state's
    scale (1e-6 of it); ``jac_fn`` is lumped.solver.jacobian.pump_jacobian or its compiled copy.
    """
    p, lay = problem.p, problem.layout
    n_dyn, scales = lay.n_dyn, problem.scales
    masses = (lay.index("m_cyl"), lay.index("m_load"))
    atol = 1e-8 * scales
    worst_j = worst_t = 0.0
    rng = np.random.default_rng(seed)
    for t, y, mode in random_states(problem, rng, n):
        f0, jfd, ftfd = central_differences(t, y, p, mode, n_dyn, scales, masses)
        ja = np.zeros((len(y), len(y)))
        fa = np.zeros(len(y))
        jac_fn(t, y, p, mode, np.nan, ja, fa, np.zeros(len(y)), np.zeros(len(y)), atol, 1e-6, n_dyn)
        row = np.abs(jfd[:, :n_dyn] * scales[:n_dyn]).max(axis=1, keepdims=True) + 1e-300
        err = np.abs(ja[:, :n_dyn] - jfd[:, :n_dyn]) * scales[:n_dyn] / (1e-3 * np.abs(jfd[:, :n_dyn] * scales[:n_dyn])
                                                                           + 1e-6 * row)
        worst_j = max(worst_j, float(err.max()))
        if np.any(ja[:, n_dyn:] != 0.0):                     # quadratures never feed back
            worst_j = math.inf
        tscale = np.abs(ftfd) + 1e-5 * np.abs(f0) / 1e-3 + 1e-300
        worst_t = max(worst_t, float((np.abs(fa - ftfd) / (1e-3 * tscale)).max()))
    return worst_j, worst_t


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


def _contract(report, kind) -> None:
    """The static contract: a frozen ValveParams dataclass whose common() is a checked Common."""
    from lumped.model.model_file import kind_default_model, load_model
    from lumped.valves.kind import Common, ValveParams

    cls = kind.params
    if not (is_dataclass(cls) and cls.__dataclass_params__.frozen and issubclass(cls, ValveParams)):
        report.failures.append(f"{cls.__name__} must be a frozen dataclass subclassing lumped.valves.kind.ValveParams")
        return
    if "position" not in {f.name for f in fields(cls)}:
        report.failures.append(f"{cls.__name__} has no 'position' field")
    model = load_model(kind_default_model(kind.name))
    for pos in ("inlet", "delivery"):
        v = model.valve(pos)
        if type(v) is not cls:
            report.failures.append(f"the default model {kind.default_model!r} has no {kind.name} valve at {pos}")
            return
        c = v.common(model.oil)
        if not isinstance(c, Common):
            report.failures.append(f"{cls.__name__}.common() must return lumped.valves.kind.Common")
            return
        extra = v.packed_extra(model.oil)
        missing = set(cls.DERIVED) - set(extra)
        if missing:
            report.failures.append(f"{cls.__name__}.packed_extra() lacks {sorted(missing)} (declared in DERIVED)")
        for name, val in (("natural_frequency", v.natural_frequency()),):
            if not (isinstance(val, float) and math.isfinite(val) and val > 0):
                report.failures.append(f"{cls.__name__}.{name}() = {val!r}: expected a positive finite number")
    report.checks.append(f"{cls.__name__}: frozen ValveParams dataclass, common() a checked Common, "
                         f"DERIVED packed, default model {kind.default_model!r}")


def _mixed(inlet: str, delivery: str):
    from lumped.model.model_file import parse_model

    return parse_model({"name": f"mixed-{inlet}-{delivery}", "valves": {"inlet": {"kind": inlet},
                                                                         "delivery": {"kind": delivery}}})


def check_valve_kind(kind, *, points: int = 3, revolutions: int = 3, quick: bool = False,
                     seed: int = 0) -> ConformanceReport:
    """Check a registered valve kind against the kind contract by running it (see the module docstring).

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

    Returns
    -------
    ConformanceReport
        ``passed`` and ``failures`` (CONTRACT.md), and the measured ``checks``.

    Examples
    --------
    >>> report = check_valve_kind("ball", points=1, quick=True)
    >>> report.passed, report.failures
    (True, [])
    """
    from geometry.errors import InputError
    from lumped.model.model_file import kind_default_model, load_model
    from lumped.valves.kind import KINDS

    name = getattr(kind, "name", kind)
    if name not in KINDS:
        raise InputError("kind", f"expected one of {', '.join(KINDS)}, got {name!r}")
    if not isinstance(points, int) or isinstance(points, bool) or not 1 <= points <= len(POINTS):
        raise InputError("points", f"expected an integer from 1 to {len(POINTS)}, got {points!r}")
    kind = KINDS[name]
    report = ConformanceReport(name)
    _contract(report, kind)
    if report.failures:
        return report
    pure = load_model(kind_default_model(name))
    others = [k for k in KINDS if k != name]
    pumps = [(f"{name} pump", pure)]
    if others and not quick:
        pumps += [(f"{name} inlet / {others[0]} delivery", _mixed(name, others[0])),
                  (f"{others[0]} inlet / {name} delivery", _mixed(others[0], name))]
    for i, (label, model) in enumerate(pumps):
        for speed, load in POINTS[:points if i == 0 else 1]:
            _guarded(report, f"{label} at {speed:.0f} rpm", _compare, report, label, model, speed, load, revolutions)
    for label, model in pumps:
        _check_jacobians(report, label, model, seed)
        _check_round_trip(report, label, model)
    _guarded(report, "design_ranges", _check_designs, report, name, seed)
    _check_effects(report, pure)
    return report


def _guarded(report, label: str, fn, *args) -> None:
    """Run one check; an exception is a failure of the kind, reported with what raised it."""
    try:
        fn(*args)
    except Exception as exc:  # noqa: BLE001 - reported, not hidden
        report.failures.append(f"{label}: {type(exc).__name__}: {exc}")


def _check_jacobians(report, label: str, model, seed: int) -> None:
    """The analytic Jacobian of the flavour the fast path uses, against central differences, in both circuits."""
    from lumped.solver import compiled
    from lumped.solver.problem import PumpProblem

    for circuit in ("simplified", "complete"):
        problem = PumpProblem.build(model, 650.0, 2.8e6, circuit, needle_area=2e-7 if circuit == "complete" else None)
        jac = compiled.cached("lumped.solver.jacobian", "pump_jacobian", problem.layout.one_dof)
        ej, et = jacobian_errors(problem, seed + 7, jac)
        what = f"{label}, {circuit} circuit: Jacobian vs central differences {ej:.3g} / {et:.3g} tolerance units"
        (report.checks if ej < 1.0 and et < 1.0 else report.failures).append(what)


def _check_round_trip(report, label: str, model) -> None:
    """``model show --toml`` read back by ``model check`` gives the same model."""
    from geometry.errors import InputError
    from lumped.model.model_file import describe, parse_model, to_toml

    try:
        again = parse_model(tomllib.loads(to_toml(model)), name=model.name, source=model.source)
        describe(again)
    except InputError as exc:
        report.failures.append(f"{label}: model show --toml is refused by model check: {exc}")
        return
    same = again == model
    (report.checks if same else report.failures).append(
        f"{label}: model show --toml round-trips through model check" + ("" if same else " to another model"))


def _check_designs(report, name: str, seed: int) -> None:
    """Random designs from the kind's design ranges are valid models."""
    from lumped.valves.kind import KINDS

    _random_design(np.random.default_rng(seed), name)
    report.checks.append(f"design_ranges {sorted(KINDS[name].design_ranges)} give valid models")


def _check_effects(report, model) -> None:
    """Every effect that applies to the kind's pump switches on at its priors and runs."""
    from lumped.run.simulate import simulate
    from lumped.model.effect_library import LIBRARY
    from lumped.model.model_file import with_values

    for e in LIBRARY.effects.values():
        targets = [t for t in e.targets if e.applies_to(model, t)]
        for t in targets[:1]:
            key = f"effects.{e.name}" + ("" if t in ("both", "pump") else f".{t}")
            try:
                r = simulate(with_values(model, {key: True}), 600.0, 2.76e6, revolutions=2)
                report.checks.append(f"effect {e.name}@{t} runs: {r.delivery_per_rev * 1e6:.4f} cc/rev")
            except Exception as exc:  # noqa: BLE001 - a failure of the kind, reported
                report.failures.append(f"effect {e.name}@{t}: {type(exc).__name__}: {exc}")


def _random_design(rng, name: str):
    """A model with the kind's design_ranges drawn (as studies.sweeps.random_designs does, in this layer)."""
    from lumped.model.model_file import kind_default_model, load_model, with_values
    from lumped.valves.kind import KINDS

    values = {}
    for key, (lo, hi) in KINDS[name].design_ranges.items():
        val = 10.0 ** rng.uniform(math.log10(lo), math.log10(hi)) if lo > 0 and hi / lo > 10 else rng.uniform(lo, hi)
        parts = key.split(".")
        path = key if parts[0] in ("effects", "valves", "pump", "oil", "circuit") else f"valves.{key}"
        values[path] = val
    return with_values(load_model(kind_default_model(name)), values)
