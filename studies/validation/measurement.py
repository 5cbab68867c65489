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


def delivery_uncertainty(cases, modeled: dict | None = None) -> dict[str, MeasurementUncertainty]:
    """u_D [cc/rev] of each thesis case's measured delivery (``cases``: studies.validation.chain.cases()).

    ``modeled``: {case name: the model's delivery [cc/rev]} to take each pair's difference
    net of the model's (the conditions differ slightly); None: the raw differences.
    """
    from studies.validation.chain import case_name

    typea = {}
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
        if c["valve"] in typea:
            s, nu = typea[c["valve"]]
            comps.append(Component(
                "paired runs", s, float(nu), "A",
                f"Table {table.get(c['valve'], c['table'])}: {nu} pairs of runs at one condition (inlet and "
                "delivery valve measured), s^2 = sum d^2 / (2 n)"
                + (", d net of the model's difference between the pair's conditions" if modeled else "")
                + "; section 5.5: the accumulator not yet at cyclic steady state"))
        D = c["measured_delivery"] * 1e6
        comps.append(Component("flow meter", FLOW_METER_REL * D, math.inf, "B",
                               f"assumed: gear flow meter +-{FLOW_METER_HALF_WIDTH * 100:g} % of reading, uniform "
                               "(the thesis names no accuracy)"))
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
