"""u_D, the measurement's standard uncertainty: Type A from repeated and paired runs, Type B from instruments.

Delivery (cc/rev) of the thesis runs (Tables 5.4, 5.6). Each condition was run twice, once
measuring the inlet valve and once the delivery valve; the two deliveries should agree but
differ by up to nearly 6 % (Table 5.4), which section 5.5 traces to the accumulator not yet
at cyclic steady state. That scatter is the delivery measurement's repeatability: from n
pairs with differences d_i, a single run's standard deviation is

    s^2 = sum d_i^2 / (2 n),   nu = n degrees of freedom

(the duplicate-pairs estimator, GUM 4.2 / ISO 5725-2; its expectation is sigma^2 when both
runs of a pair scatter with sigma). The runs of a pair were at slightly different load
pressures, so each d_i is taken net of the model's difference between the two conditions
(d_i = (D_a - D_b) - (S_a - S_b), i.e. the difference of the comparison errors E) when the
model's values are given. To it adds the flow meter (Type B): the thesis names a
positive-displacement gear meter without its accuracy; assumed +-0.5 % of reading
(uniform), typical of the class.

Positions: the laser triangulation sensor's +-1.12 % of the reading (section 5.3, eq 5.11),
taken as a standard uncertainty.

Pooled and honest (:func:`repeatability`): the paired differences are taken relative to the
pair's mean delivery, the pair holding the run the thesis itself doubts (:data:`SUSPECT`:
section 5.4.4, the disc's delivery-measured high-pressure run, taken while the accumulator was
still charging, which lowers the measured delivery) is left out, and the two rigs' estimates
are pooled, s^2 = sum nu_r s_r^2 / sum nu_r with nu = sum nu_r, when a two-sided F test of
their variances does not reject equality at 5 % (they share the flow meter, the procedure
and the accumulator; pooling is reported with F and p). s itself is uncertain: with nu
degrees of freedom sigma lies in [s sqrt(nu / chi2_0.975), s sqrt(nu / chi2_0.025)] with
95 % confidence (its relative standard deviation is about 1 / sqrt(2 nu)).

The flow meter's error is a scale error of one instrument: it is common to every run of both
rigs (fully correlated), so it cancels from differences between runs and from a calibration's
prediction of other runs (:mod:`studies.validation.joint`).

A user's dataset (``run.toml``) may state ``delivery_uncertainty_cc`` (standard, cc/rev) and
``position_uncertainty_rel`` (standard, relative); runs repeated at one condition add a
Type A estimate (sample standard deviation, nu = n - 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: the LTS position uncertainty (thesis section 5.3, eq 5.11: +-1.12 %), relative
LTS_POSITION_REL = 0.0112
#: gear flow meter, assumed +-0.5 % of reading (uniform): relative standard uncertainty
FLOW_METER_HALF_WIDTH = 0.005
FLOW_METER_REL = FLOW_METER_HALF_WIDTH / math.sqrt(3.0)
#: runs at one condition: speeds within this fraction, load pressures within this fraction
SAME_SPEED, SAME_LOAD = 0.005, 0.02
#: the runs the thesis itself says were not at cyclic steady state: left out of u_D, the calibrations and the
#: rig-level tests, and reported with their verdicts and this reason
SUSPECT = {"disc_delivery_high_pressure": "section 5.4.4: almost certainly taken before the accumulator reached "
                                          "cyclic steady state (still charging), which lowers the measured delivery"}
#: significance level of the F test that allows pooling the two rigs' repeatability
POOL_ALPHA = 0.05


def welch_satterthwaite(u, dof) -> float:
    """Effective degrees of freedom of a combined standard uncertainty: (sum u_i^2)^2 / sum(u_i^4 / nu_i)
    (GUM G.4.1, eq G.2b); infinite components (Type B) add nothing below; inf if all are."""
    u = [float(x) for x in u]
    den = sum(x**4 / float(n) for x, n in zip(u, dof) if n is not None and math.isfinite(n) and x > 0.0)
    num = sum(x * x for x in u) ** 2
    if den == 0.0:
        return math.inf
    return num / den


@dataclass(frozen=True)
class Component:
    """One contribution to u_D (output units)."""

    name: str
    u: float
    dof: float              # math.inf for a Type B estimate
    kind: str               # "A" or "B"
    source: str


@dataclass(frozen=True)
class MeasurementUncertainty:
    """u_D of one measured value: its components combined in quadrature, and their Welch-Satterthwaite dof."""

    components: tuple[Component, ...]

    @property
    def u(self) -> float:
        return math.sqrt(sum(c.u**2 for c in self.components))

    @property
    def dof(self) -> float:
        return welch_satterthwaite([c.u for c in self.components], [c.dof for c in self.components])

    def as_dict(self) -> dict:
        return {"u": self.u, "dof": None if math.isinf(self.dof) else self.dof,
                "components": [{"name": c.name, "u": c.u, "dof": None if math.isinf(c.dof) else c.dof,
                                "type": c.kind, "source": c.source} for c in self.components]}


def paired_type_a(differences) -> tuple[float, int]:
    """(s, nu): a single run's standard deviation from the differences of n duplicate pairs,
    s = sqrt(sum d^2 / (2 n)), nu = n (GUM 4.2, ISO 5725-2 duplicates)."""
    d = [float(x) for x in differences]
    if not d:
        raise ValueError("no pairs")
    return math.sqrt(sum(x * x for x in d) / (2 * len(d))), len(d)


def repeated_type_a(values) -> tuple[float, int]:
    """(s, nu): sample standard deviation of n repeated readings (n - 1 degrees of freedom)."""
    v = [float(x) for x in values]
    if len(v) < 2:
        raise ValueError("need at least two readings")
    m = sum(v) / len(v)
    return math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1)), len(v) - 1


def thesis_pairs(cases) -> dict[str, list[tuple[dict, dict]]]:
    """{valve: [(inlet-measured case, delivery-measured case), ...]} of the cases at one condition."""
    out: dict = {}
    for c in cases:
        if c["measured_valve"] != "inlet":
            continue
        other = next((o for o in cases if o["valve"] == c["valve"] and o["condition"] == c["condition"]
                      and o["measured_valve"] == "delivery"), None)
        if other is not None:
            out.setdefault(c["valve"], []).append((c, other))
    return out


@dataclass(frozen=True)
class Pair:
    """Two runs at one condition and their relative difference net of the model's."""

    valve: str
    condition: str
    runs: tuple[str, str]
    d_rel: float            # ((D_a - D_b) - (S_a - S_b)) / mean(D_a, D_b)
    suspect: bool


@dataclass(frozen=True)
class Repeatability:
    """A single run's relative standard deviation of the measured delivery, per rig, from the paired runs.

    ``rigs``: {valve: (s_rel, dof)} of each rig alone; ``s_rel``, ``dof``: the estimate every rig uses
    (pooled when ``pooled``; else ``per_rig`` holds each rig's own); ``F``, ``p``: the variance test.
    """

    pairs: tuple[Pair, ...]
    rigs: dict
    pooled: bool
    s_rel: float | None
    dof: int | None
    F: float | None
    p: float | None

    def of(self, valve: str) -> tuple[float, int]:
        """(s_rel, dof) a run of ``valve``'s rig uses."""
        return (self.s_rel, self.dof) if self.pooled else self.rigs[valve]

    def source(self, valve: str) -> str:
        used = [q for q in self.pairs if not q.suspect]
        left = [q.runs for q in self.pairs if q.suspect]
        if self.pooled:
            how = (f"pooled over both rigs ({len(used)} pairs; F = {self.F:.3g}, p = {self.p:.2g}: the variances do "
                   "not differ at 5 %)")
        elif self.F is not None:
            how = f"{valve} rig alone (F = {self.F:.3g}, p = {self.p:.2g}: the rigs' variances differ, not pooled)"
        else:
            how = f"{valve} rig alone"
        out = f"paired runs at one condition (inlet and delivery valve measured), s^2 = sum d^2 / (2 n), {how}"
        if left:
            out += "; left out: " + ", ".join(" / ".join(r) for r in left) + " (suspect run, " + \
                   "; ".join(SUSPECT[r] for pair in left for r in pair if r in SUSPECT) + ")"
        return out

    def as_dict(self) -> dict:
        def interval(s, nu):
            lo, hi = sigma_interval(s, nu)
            return [lo * 100.0, hi * 100.0]

        return {"pairs": [{"valve": q.valve, "condition": q.condition, "runs": list(q.runs),
                           "d_pct": q.d_rel * 100.0, "suspect": q.suspect} for q in self.pairs],
                "rigs": {v: {"s_pct": s * 100.0, "dof": nu, "s_interval_95_pct": interval(s, nu)}
                         for v, (s, nu) in self.rigs.items()},
                "pooled": self.pooled, "F": self.F, "p": self.p,
                "s_pct": None if self.s_rel is None else self.s_rel * 100.0, "dof": self.dof,
                "s_interval_95_pct": None if self.s_rel is None else interval(self.s_rel, self.dof),
                "suspect": dict(SUSPECT)}


def sigma_interval(s: float, dof: float, confidence: float = 0.95) -> tuple[float, float]:
    """The confidence interval of sigma from s with ``dof`` degrees of freedom: s sqrt(nu / chi2) (chi-square
    quantiles at (1 +- confidence) / 2).

    Examples
    --------
    >>> [round(x, 3) for x in sigma_interval(1.0, 5)]     # s with 5 dof: sigma within a factor 0.62 to 2.45
    [0.624, 2.453]
    """
    from scipy.stats import chi2

    a = 0.5 * (1.0 - confidence)
    return s * math.sqrt(dof / chi2.ppf(1.0 - a, dof)), s * math.sqrt(dof / chi2.ppf(a, dof))


def variance_test(s1: float, nu1: int, s2: float, nu2: int) -> tuple[float, float]:
    """(F, p): the larger variance over the smaller and the two-sided p of equal variances (F test)."""
    from scipy.stats import f

    if s1 < s2:
        s1, nu1, s2, nu2 = s2, nu2, s1, nu1
    F = s1**2 / s2**2
    return F, min(1.0, 2.0 * float(f.sf(F, nu1, nu2)))


def repeatability(cases, modeled: dict, suspect=SUSPECT) -> Repeatability:
    """The paired runs' relative repeatability per rig, the suspect runs left out, pooled when an F test allows
    (see the module docstring). ``modeled``: {case name: the model's delivery} of every run in a pair."""
    from studies.validation.chain import case_name

    pairs = []
    for valve, ps in thesis_pairs(cases).items():
        for a, b in ps:
            na, nb = case_name(a), case_name(b)
            Da, Db = a["measured_delivery"] * 1e6, b["measured_delivery"] * 1e6
            d = ((Da - Db) - (modeled[na] - modeled[nb])) / (0.5 * (Da + Db))
            pairs.append(Pair(valve, a["condition"], (na, nb), d, na in suspect or nb in suspect))
    rigs = {}
    for valve in dict.fromkeys(q.valve for q in pairs):
        rigs[valve] = paired_type_a([q.d_rel for q in pairs if q.valve == valve and not q.suspect])
    if len(rigs) != 2:
        return Repeatability(tuple(pairs), rigs, False, None, None, None, None)
    (s1, n1), (s2, n2) = rigs.values()
    F, p = variance_test(s1, n1, s2, n2)
    if p <= POOL_ALPHA:
        return Repeatability(tuple(pairs), rigs, False, None, None, F, p)
    s = math.sqrt((n1 * s1**2 + n2 * s2**2) / (n1 + n2))
    return Repeatability(tuple(pairs), rigs, True, s, n1 + n2, F, p)


def delivery_uncertainty(cases, modeled: dict | None = None,
                         repeat: Repeatability | None = None) -> dict[str, MeasurementUncertainty]:
    """u_D [cc/rev] of each thesis case's measured delivery (``cases``: studies.validation.chain.cases()).

    ``repeat``: the pooled relative repeatability (:func:`repeatability`); None: each rig's own
    paired runs as given (all pairs, absolute differences), ``modeled`` ({case name: the model's
    delivery [cc/rev]}) taking each pair's difference net of the model's (the conditions differ
    slightly), None the raw differences.
    """
    from studies.validation.chain import case_name

    typea = {}
    if repeat is None:
        for valve, pairs in thesis_pairs(cases).items():
            diffs = []
            for a, b in pairs:
                d = (a["measured_delivery"] - b["measured_delivery"]) * 1e6
                if modeled is not None:
                    d -= modeled[case_name(a)] - modeled[case_name(b)]
                diffs.append(d)
            typea[valve] = paired_type_a(diffs)
    table = {"disc": "5.4", "reed": "5.6"}
    out = {}
    for c in cases:
        comps = []
        D = c["measured_delivery"] * 1e6
        if repeat is not None and c["valve"] in repeat.rigs:
            s, nu = repeat.of(c["valve"])
            comps.append(Component("paired runs", s * D, float(nu), "A", repeat.source(c["valve"])))
        elif c["valve"] in typea:
            s, nu = typea[c["valve"]]
            comps.append(Component(
                "paired runs", s, float(nu), "A",
                f"Table {table.get(c['valve'], c['table'])}: {nu} pairs of runs at one condition (inlet and "
                "delivery valve measured), s^2 = sum d^2 / (2 n)"
                + (", d net of the model's difference between the pair's conditions" if modeled else "")
                + "; section 5.5: the accumulator not yet at cyclic steady state"))
        comps.append(Component("flow meter", FLOW_METER_REL * D, math.inf, "B",
                               f"assumed: gear flow meter +-{FLOW_METER_HALF_WIDTH * 100:g} % of reading, uniform "
                               "(the thesis names no accuracy); one meter: common to every run"))
        out[case_name(c)] = MeasurementUncertainty(tuple(comps))
    return out


def position_uncertainty(position_m: float, rel: float = LTS_POSITION_REL) -> MeasurementUncertainty:
    """u_D [m] of a valve position reading (the LTS's 1.12 %, section 5.3, or a stated relative value)."""
    return MeasurementUncertainty((Component("position sensor", abs(rel * position_m), math.inf, "B",
                                             "LTS scale factor, section 5.3 (eq 5.11)" if rel == LTS_POSITION_REL
                                             else "stated in run.toml (position_uncertainty_rel)"),))


def dataset_uncertainty(runs) -> dict[str, dict]:
    """u_D of a measured dataset's runs (studies.discrepancy.measured.Run), per run name:
    ``{"delivery": MeasurementUncertainty or None, "position_rel": float or None}``.

    Delivery: the run.toml's ``delivery_uncertainty_cc`` (Type B) and, for runs repeated at one
    condition (same valve type, speed within 0.5 %, load within 2 %) with deliveries, their
    sample standard deviation (Type A, n - 1 dof). Position: ``position_uncertainty_rel``.
    None where the dataset states nothing and has no repeats.
    """
    groups: list[list] = []
    for r in runs:
        for g in groups:
            g0 = g[0]
            if (r.valve_type == g0.valve_type and abs(r.speed_rpm / g0.speed_rpm - 1) <= SAME_SPEED
                    and abs(r.load_pressure_pa / g0.load_pressure_pa - 1) <= SAME_LOAD):
                g.append(r)
                break
        else:
            groups.append([r])
    out = {}
    for g in groups:
        measured = [r.delivery_cc_per_rev for r in g if r.delivery_cc_per_rev is not None]
        a = repeated_type_a(measured) if len(measured) >= 2 else None
        for r in g:
            comps = []
            if a is not None and r.delivery_cc_per_rev is not None:
                comps.append(Component("repeated runs", a[0], float(a[1]), "A",
                                       f"{a[1] + 1} runs at {r.speed_rpm:g} rpm, {r.load_pressure_pa / 1e6:.3g} MPa"))
            stated = getattr(r, "delivery_uncertainty_cc", None)
            if stated is not None and r.delivery_cc_per_rev is not None:
                comps.append(Component("stated", float(stated), math.inf, "B", "run.toml delivery_uncertainty_cc"))
            out[r.name] = {"delivery": MeasurementUncertainty(tuple(comps)) if comps else None,
                           "position_rel": getattr(r, "position_uncertainty_rel", None)}
    return out
