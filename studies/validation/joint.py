"""A rig's comparisons judged together: linear combinations of its comparison errors with their joint uncertainty.

The runs of one rig share their unknown inputs (the air content, the oil's viscosity, the
valves' Cd; a draw of the joint Monte Carlo is one set of them for every run) and their flow
meter, so their comparison errors E_i = S_i - D_i are correlated. Every statement
``valvelab validate`` makes about a rig is a linear combination c^T E of them (ASME V&V 20
applied to a derived quantity, GUM 5.2 for correlated inputs):

- a run: c = e_j (the ``validation`` rows);
- a difference between conditions: c = e_a - e_b (the shared air content largely cancels);
- a prediction after calibration: c = row j of L = I - G (G_C^T W G_C)^-1 G_C^T W P_C, the
  linearised map from the errors at the nominal inputs to the errors after the parameters
  with slopes G (per standard score, from the draws) are fitted to the calibration runs C
  (weighted least squares, W the inverse variance of their measurements; the generalised
  least squares of Kennedy and O'Hagan 2001 without a discrepancy term);
- the rig's held-out runs together: the generalised least-squares estimate of one relative
  model-form error delta common to them, c = L^T V^-1 D_H / (D_H^T V^-1 D_H).

For a combination c: u_input = sd(c^T Y) over the draws Y (inputs moved jointly, not in
quadrature), with its Monte Carlo standard error from the Sobol scrambles; u_D from the runs'
repeatability, sqrt(sum (c_i s D_i)^2) (Type A, the pooled paired runs' nu), and the flow meter,
u_m |c^T D| (Type B, one meter: it cancels from differences); u_num = sqrt(sum (c_i u_num,i)^2).
U_val = k u_val with k = t(nu_eff) (Welch-Satterthwaite, the declarations Type B with infinite
dof) unless one non-normal input carries more than half of u_val^2: then the 95.45 % coverage
interval of the combination's error distribution by Monte Carlo (GUM Supplement 1, 7.7: the
input draws resampled, the repeatability as s t_nu, the meter uniform, the numerics normal),
U_val its symmetric half-width and k = U_val / u_val. The smallest model-form error detected with
80 % probability solves P(|a delta + X| > U_val) = 0.8 on the same distribution X, a the
combination's response to a relative model-form error delta (D_j for one run, 1 for the rig's
delta).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from studies.validation.measurement import welch_satterthwaite

#: coverage probability of U_val (k = 2 for a normal distribution)
COVERAGE = 0.9545
#: a non-normal input carrying more than this share of u_val^2 makes the interval a Monte Carlo one
DOMINANT_SHARE = 0.5
#: probability of detection that defines the detectable error
POWER = 0.80
#: samples of a Monte Carlo coverage interval
INTERVAL_SAMPLES = 40_000


@dataclass(frozen=True)
class Rig:
    """The runs of one rig: model, measurement, numerics and the joint input draws (output units throughout).

    ``draws``: N x n, the fast model's output at draw k for run i (the same inputs at every run);
    ``scores``: N x d standard scores of the declarations ``keys`` (``uniform``: which are uniform);
    ``scramble``: the Sobol scramble of each draw; ``repeat_rel``, ``repeat_dof``: a single run's relative
    standard deviation and its dof; ``meter_rel``: the common flow meter's relative standard uncertainty.
    """

    name: str
    cases: tuple[str, ...]
    S: np.ndarray
    D: np.ndarray
    u_num: np.ndarray
    draws: np.ndarray
    scores: np.ndarray
    scramble: np.ndarray
    keys: tuple[str, ...]
    uniform: tuple[bool, ...]
    repeat_rel: float
    repeat_dof: float
    meter_rel: float
    suspect: tuple[bool, ...]
    priors: dict = field(default_factory=dict)      # {key: (nominal, standard uncertainty)} in the key's units
    unit: str = "cc/rev"

    def index(self, case: str) -> int:
        return self.cases.index(case)

    def slopes(self) -> np.ndarray:
        """n x d: each run's output per standard score of each declaration (linear regression on the draws)."""
        X = np.column_stack([np.ones(len(self.scores)), self.scores])
        beta, *_ = np.linalg.lstsq(X, self.draws, rcond=None)
        return beta[1:].T

    def covariance(self, inputs: bool = True) -> np.ndarray:
        """n x n covariance of the runs' comparison errors: the inputs (the draws), the repeatability (independent
        runs), the meter (common to all) and the numerics."""
        D = self.D
        cov = np.diag((self.repeat_rel * D) ** 2 + self.u_num**2) + self.meter_rel**2 * np.outer(D, D)
        if inputs:
            cov = cov + np.cov(self.draws, rowvar=False)
        return cov


@dataclass(frozen=True)
class Budget:
    """The uncertainty of one combination c^T E, its components and their degrees of freedom."""

    u_num: float
    u_input: float
    u_input_se: float | None
    u_repeat: float
    u_meter: float
    repeat_dof: float
    contributors: tuple[tuple[str, float], ...]
    linear_r2: float | None
    dominant: str | None            # the non-normal input carrying most of u_val^2, if beyond DOMINANT_SHARE

    @property
    def u_D(self) -> float:
        return math.hypot(self.u_repeat, self.u_meter)

    @property
    def u_D_dof(self) -> float:
        return welch_satterthwaite([self.u_repeat, self.u_meter], [self.repeat_dof, math.inf])

    @property
    def u_val(self) -> float:
        return math.sqrt(self.u_num**2 + self.u_input**2 + self.u_D**2)

    @property
    def nu_eff(self) -> float:
        return welch_satterthwaite([self.u_num, self.u_input, self.u_repeat, self.u_meter],
                                   [math.inf, math.inf, self.repeat_dof, math.inf])


def budget(rig: Rig, c) -> Budget:
    """The uncertainty of c^T E (see the module docstring)."""
    c = np.asarray(c, dtype=float)
    y = rig.draws @ c
    u_input = float(np.std(y, ddof=1))
    per = [float(np.std(y[rig.scramble == r], ddof=1)) for r in np.unique(rig.scramble)
           if np.sum(rig.scramble == r) >= 2]
    se = float(np.std(per, ddof=1) / math.sqrt(len(per))) if len(per) >= 2 else None
    contributors, r2 = _contributors(rig, y)
    u_rep = rig.repeat_rel * float(np.sqrt(np.sum((c * rig.D) ** 2)))
    u_met = rig.meter_rel * abs(float(c @ rig.D))
    u_num = float(np.sqrt(np.sum((c * rig.u_num) ** 2)))
    u_val2 = u_num**2 + u_input**2 + u_rep**2 + u_met**2
    shares = [(k, v**2) for (k, v), uni in zip(contributors, _uniform_of(rig, contributors)) if uni]
    shares.append(("flow meter", u_met**2))
    name, top = max(shares, key=lambda kv: kv[1])
    dominant = name if u_val2 > 0.0 and top > DOMINANT_SHARE * u_val2 else None
    return Budget(u_num, u_input, se, u_rep, u_met, rig.repeat_dof, contributors, r2, dominant)


def _contributors(rig: Rig, y: np.ndarray) -> tuple[tuple[tuple[str, float], ...], float | None]:
    """Every declaration's linear contribution |beta_j| sd(z_j) to y, largest first, and the regression's R^2."""
    if np.std(y) == 0.0:
        return (), None
    X = np.column_stack([np.ones(len(y)), rig.scores])
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    resid = y - X @ beta
    r2 = float(1.0 - np.sum(resid**2) / np.sum((y - y.mean()) ** 2))
    contrib = [(k, float(abs(b) * np.std(rig.scores[:, j], ddof=1))) for j, (k, b) in enumerate(zip(rig.keys, beta[1:]))]
    return tuple(sorted(contrib, key=lambda kv: -kv[1])), r2


def _uniform_of(rig: Rig, contributors) -> list[bool]:
    return [rig.uniform[rig.keys.index(k)] for k, _ in contributors]


# --------------------------------------------------------------------------- the interval and the power
def error_samples(rig: Rig, c, b: Budget, rng, n: int = INTERVAL_SAMPLES) -> np.ndarray:
    """Draws of c^T E when the model is right: the input draws resampled, the repeatability s t_nu (GUM S1 6.4.9
    for a Type A estimate), the meter uniform, the numerics normal."""
    y = rig.draws @ np.asarray(c, dtype=float)
    y = y - y.mean()
    x = y[rng.integers(0, len(y), n)]
    t = rng.standard_t(b.repeat_dof, n) if math.isfinite(b.repeat_dof) else rng.standard_normal(n)
    x = x + b.u_repeat * t + b.u_meter * math.sqrt(3.0) * rng.uniform(-1.0, 1.0, n)
    return x + b.u_num * rng.standard_normal(n)


def interval(b: Budget, samples: np.ndarray | None) -> tuple[float, str]:
    """(k, "welch" or "monte_carlo"): the Monte Carlo coverage interval where one non-normal input dominates."""
    from studies.validation.vv20 import coverage_factor

    if b.dominant is None or samples is None or b.u_val == 0.0:
        return coverage_factor(b.nu_eff), "welch"
    return float(np.quantile(np.abs(samples), COVERAGE)) / b.u_val, "monte_carlo"


def detectable(samples: np.ndarray, U: float, response: float, power: float = POWER) -> float | None:
    """The smallest model-form error delta with P(|response delta + X| > U) >= ``power``, X the samples of the
    error when the model is right (in the units response delta is in; None for a comparison blind to it)."""
    from scipy.optimize import brentq

    if response == 0.0:
        return None
    x = np.sort(samples)

    def p(delta):
        shift = abs(response) * delta
        return (np.searchsorted(x, -U - shift) + len(x) - np.searchsorted(x, U - shift, side="right")) / len(x) - power

    if p(0.0) >= 0.0:
        return 0.0
    hi = (U + float(np.max(np.abs(x)))) / abs(response)       # every sample beyond U there: p = 1 - power > 0
    return float(brentq(p, 0.0, hi, xtol=1e-9 * hi))


# --------------------------------------------------------------------------- calibration
@dataclass(frozen=True)
class Calibration:
    """Parameters fitted to the calibration runs: their score shift, its covariance and the prediction map L."""

    keys: tuple[str, ...]
    runs: tuple[int, ...]
    shift: np.ndarray          # the fitted standard scores (linear)
    cov_data: np.ndarray       # their covariance from the calibration runs' measurements and numerics
    cov_inputs: np.ndarray     # ... from the other inputs (the draws)
    L: np.ndarray


def gain(rig: Rig, keys, runs) -> tuple[np.ndarray, np.ndarray]:
    """(G, A): the runs' slopes in the declarations ``keys`` (n x p) and the weighted least-squares map A (p x |C|)
    from the calibration runs' errors to minus the fitted scores. ValueError when the runs cannot determine the
    keys (fewer runs than keys, or slopes that do not tell them apart)."""
    C = list(runs)
    G = rig.slopes()[:, [rig.keys.index(k) for k in keys]]
    if len(C) < len(keys) or np.linalg.matrix_rank(G[C]) < len(keys):
        raise ValueError(f"{len(C)} calibration runs of the {rig.name} rig cannot determine {', '.join(keys)}")
    w = 1.0 / ((rig.repeat_rel * rig.D[C]) ** 2 + rig.u_num[C] ** 2 + (1e-9 * rig.D[C]) ** 2)
    GW = G[C].T * w
    return G, np.linalg.solve(GW @ G[C], GW)


def calibrate(rig: Rig, keys, runs, E: np.ndarray | None = None) -> Calibration:
    """Fit the declarations ``keys`` to the runs ``runs`` (indices) by weighted least squares on their slopes.

    ``E``: the comparison errors at the nominal inputs (default S - D).
    """
    keys = tuple(keys)
    C = list(runs)
    G, A = gain(rig, keys, C)
    E = rig.S - rig.D if E is None else np.asarray(E, dtype=float)
    shift = -A @ E[C]
    P = np.zeros((len(C), len(rig.cases)))
    P[np.arange(len(C)), C] = 1.0
    L = np.eye(len(rig.cases)) - G @ A @ P
    cov_meas = rig.covariance(inputs=False)[np.ix_(C, C)]
    resid = rig.draws - rig.scores[:, [rig.keys.index(k) for k in keys]] @ G.T
    cov_in = np.cov(resid[:, C], rowvar=False).reshape(len(C), len(C))
    return Calibration(keys, tuple(C), shift, A @ cov_meas @ A.T, A @ cov_in @ A.T, L)


def rig_weights(rig: Rig, cal: Calibration | None, held) -> tuple[np.ndarray, np.ndarray]:
    """(c, c_H): c^T E (errors at the nominal inputs) = c_H^T E_after is the generalised least-squares estimate
    of one relative model-form error common to the runs ``held`` after the calibration ``cal`` (or at the
    nominal inputs): c_H = V^-1 D_H / (D_H^T V^-1 D_H) on the held runs, c = L^T c_H."""
    L = np.eye(len(rig.cases)) if cal is None else cal.L
    H = list(held)
    V = (L @ rig.covariance() @ L.T)[np.ix_(H, H)]
    DH = rig.D[H]
    a = np.linalg.solve(V, DH)
    cH = a / float(DH @ a)
    c = np.zeros(len(rig.cases))
    c[H] = cH
    return L.T @ c, c


def chi_square(rig: Rig, cal: Calibration | None, held, E_after: np.ndarray) -> tuple[float, int, float]:
    """(chi^2, dof, p) of the errors of the runs ``held`` against their joint covariance (any pattern of error)."""
    from scipy.stats import chi2

    L = np.eye(len(rig.cases)) if cal is None else cal.L
    H = list(held)
    V = (L @ rig.covariance() @ L.T)[np.ix_(H, H)]
    e = np.asarray(E_after, dtype=float)[H]
    x2 = float(e @ np.linalg.solve(V, e))
    return x2, len(H), float(chi2.sf(x2, len(H)))
