"""The spec file of ``valvelab sensitivity`` and ``valvelab optimize`` (schema: CONTRACT.md).

```toml
model = "thesis-disc"        # shipped name, model file (relative to this file) or an importable sweep-model module
[fixed]                      # model-file key paths set on the base model before anything varies
"valves.geometry" = "prototype"
[operating]                  # every combination is run (default: the model's [operating])
speed_rpm = [593.0]
load_pressure_mpa = [2.76]
[variables]                  # key paths (or speed_rpm, load_pressure_mpa, or names used by [derived])
"oil.air_content" = [0.005, 0.02]
"valves.spring.stiffness" = { low = 150.0, high = 300.0, scale = "log" }
[derived]                    # key paths computed from the variables (arithmetic on their names)
"valves.geometry.step_fraction" = "step_length / valves.geometry.length"
[run]
outputs = ["delivery_cc_per_rev"]
```

Everything is checked here, before any computation; a bad field raises
:class:`~geometry.errors.InputError` naming it (``variables."oil.air_content".high``).
"""

from __future__ import annotations

import ast
import hashlib
import math
import os
import re
import shutil
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from geometry.declare import flatten
from geometry import validate
from geometry.errors import InputError

COMMANDS = ("sensitivity", "optimize")
OPERATING_VARIABLES = {"speed_rpm": "rpm", "load_pressure_mpa": "MPa"}
DISTRIBUTIONS = ("uniform", "loguniform", "normal", "lognormal", "triangular")
#: the quantiles at which an unbounded distribution is checked against the model
CHECK_QUANTILES = (1e-3, 1 - 1e-3)
#: at most this many evaluation rows (designs x operating points) in one study
MAX_ROWS = 20_000_000
#: bytes per evaluation row: in memory (the designs and results tables) and on disk (Parquet)
ROW_BYTES_MEMORY = 1200
ROW_BYTES_DISK = 400
GEOMETRY_UNITS = {"length": "m", "thickness": "m", "width_root": "m", "width_tip": "m", "tip_radius": "m",
                  "step_fraction": "-", "material.youngs_modulus": "Pa", "material.density": "kg/m^3",
                  "material.poisson_ratio": "-"}

RUN_KEYS = {
    "sensitivity": {"outputs", "method", "samples", "seed", "num_levels", "num_resamples", "conf_level",
                    "revolutions", "max_revolutions", "steady_tol", "integrator", "rtol", "atol", "on_warning"},
    "optimize": {"objectives", "aggregate", "algorithm", "population", "generations", "seed", "revolutions",
                 "max_revolutions", "steady_tol", "integrator", "rtol", "atol", "max_evaluations", "on_warning"},
}
SHARED_RUN_KEYS = {"sensitivity": {"objectives"}, "optimize": {"outputs", "samples"}}
TOP_KEYS = {
    "sensitivity": {"model", "description", "fixed", "operating", "variables", "derived", "run", "stress"},
    "optimize": {"model", "description", "fixed", "operating", "variables", "derived", "run", "constraints",
                 "stress", "recheck"},
}


# --------------------------------------------------------------------------- variables
@dataclass(frozen=True)
class Variable:
    """One varied input: a range (linear or log), a list of values, or a distribution."""

    name: str
    role: str                      # key | operating | auxiliary
    low: float | None = None
    high: float | None = None
    scale: str = "linear"          # linear | log (ranges)
    values: tuple | None = None    # categorical levels, equally likely
    distribution: str = "uniform"  # uniform | loguniform | normal | lognormal | triangular
    params: tuple = ()             # the distribution's parameters, (name, value) pairs
    unit: str = "-"

    @property
    def is_range(self) -> bool:
        return self.values is None and self.distribution in ("uniform", "loguniform")

    def _dist(self):
        from scipy import stats

        p = dict(self.params)
        if self.distribution == "normal":
            lo = -np.inf if self.low is None else (self.low - p["mean"]) / p["std"]
            hi = np.inf if self.high is None else (self.high - p["mean"]) / p["std"]
            return stats.truncnorm(lo, hi, loc=p["mean"], scale=p["std"])
        if self.distribution == "lognormal":
            return stats.lognorm(s=p["sigma"], scale=p["median"])
        if self.distribution == "triangular":
            c = (p["mode"] - self.low) / (self.high - self.low)
            return stats.triang(c, loc=self.low, scale=self.high - self.low)
        raise AssertionError(self.distribution)

    def from_unit(self, u) -> list:
        """Map uniform samples u in [0, 1] onto this variable (inverse CDF; levels for a list)."""
        u = np.asarray(u, dtype=float)
        if self.values is not None:
            idx = np.minimum((u * len(self.values)).astype(int), len(self.values) - 1)
            return [self.values[i] for i in idx]
        if self.is_range:
            if self.scale == "log":
                x = np.exp(np.log(self.low) + u * (np.log(self.high) - np.log(self.low)))
            else:
                x = self.low + u * (self.high - self.low)
            return [float(v) for v in x]
        return [float(v) for v in self._dist().ppf(np.clip(u, 1e-12, 1 - 1e-12))]

    # optimiser space: the range itself, or its logarithm
    def opt_bounds(self) -> tuple[float, float]:
        if self.scale == "log":
            return math.log(self.low), math.log(self.high)
        return self.low, self.high

    def from_opt(self, z: float) -> float:
        return float(math.exp(z)) if self.scale == "log" else float(z)

    def to_opt(self, x: float) -> float:
        return math.log(x) if self.scale == "log" else float(x)

    def check_points(self) -> list:
        """Values checked against the model before running: the ends of the range (or quantiles), every level."""
        if self.values is not None:
            return list(self.values)
        if self.is_range:
            return [self.low, self.high]
        return self.from_unit(np.array(CHECK_QUANTILES))

    def centre(self):
        if self.values is not None:
            return self.values[0]
        return self.from_unit(np.array([0.5]))[0]

    @property
    def label(self) -> str:
        return f"{self.name} [{self.unit}]"

    def describe(self) -> dict:
        d = {"name": self.name, "role": self.role, "unit": self.unit}
        if self.values is not None:
            d["values"] = list(self.values)
        elif self.is_range:
            d.update(low=self.low, high=self.high, scale=self.scale)
        else:
            d.update(distribution=self.distribution, **dict(self.params))
            if self.low is not None:
                d.update(low=self.low, high=self.high)
        return d


@dataclass(frozen=True)
class Objective:
    sense: str        # min | max
    output: str
    aggregate: str    # mean | worst

    @property
    def label(self) -> str:
        return f"{self.sense} {self.aggregate}({self.output})"


@dataclass(frozen=True)
class Constraint:
    output: str
    low: float | None = None    # output >= low
    high: float | None = None   # output <= high
    source: str = ""            # the spec field that made it
    loop_margin: float = 1.0    # in the optimisation loop the limits are tightened by this factor

    @property
    def label(self) -> str:
        parts = []
        if self.low is not None:
            parts.append(f"{self.output} >= {self.low:g}")
        if self.high is not None:
            parts.append(f"{self.output} <= {self.high:g}")
        return " and ".join(parts)


@dataclass(frozen=True)
class DesignSpec:
    """A parsed sensitivity or optimisation spec."""

    command: str
    model: str                     # shipped name, absolute model file, or module name
    model_kind: str                # pump | module
    fixed: tuple = ()              # (key, value) applied to the base model
    points: tuple = ()             # operating points: ({"speed_rpm": ..., "load_pressure": Pa}, ...) or ({},)
    variables: tuple = ()
    derived: tuple = ()            # (key, expression text)
    run: tuple = ()                # (key, value) of [run], defaults filled in
    outputs: tuple = ()            # sensitivity
    objectives: tuple = ()         # optimize
    constraints: tuple = ()
    stress: tuple = ()             # (key, value): yield_stress_mpa, safety_factor, calibration
    recheck: tuple = ()            # (key, value)
    description: str = ""
    text: str = field(default="", compare=False, repr=False)
    model_digest: str = field(default="", compare=True, repr=False)

    @property
    def run_dict(self) -> dict:
        return dict(self.run)

    @property
    def stress_dict(self) -> dict:
        return dict(self.stress)

    @property
    def recheck_dict(self) -> dict:
        return dict(self.recheck)

    @property
    def digest(self) -> str:
        key = repr((self.command, self.model, self.model_kind, self.fixed, self.points, self.variables, self.derived,
                    self.run, self.outputs, self.objectives, self.constraints, self.stress, self.recheck,
                    self.model_digest))
        return hashlib.sha256(key.encode()).hexdigest()[:16]

    def variable(self, name: str) -> Variable:
        return next(v for v in self.variables if v.name == name)

    @property
    def point_labels(self) -> list[str]:
        return [point_label(p) for p in self.points]


def point_label(p: dict) -> str:
    if not p:
        return "default"
    parts = []
    if "speed_rpm" in p:
        parts.append(f"{p['speed_rpm']:g} rpm")
    if "load_pressure" in p:
        parts.append(f"{p['load_pressure'] / 1e6:g} MPa")
    return ", ".join(parts)


# --------------------------------------------------------------------------- helpers
def _num(v, where: str, positive: bool = False) -> float:
    return validate.number(v, where, positive=positive)


def _int(v, where: str, lo: int, hi: int) -> int:
    return validate.number(v, where, bounds=(lo, hi), integer=True)


def _q(name: str) -> str:
    """A key as the user writes it in a dotted field name (quoted if it holds dots)."""
    return f'"{name}"' if "." in name else name


_VAR_KEYS = {"low", "high", "scale", "values", "distribution", "mean", "std", "median", "sigma", "mode"}


def _parse_variable(name: str, d, command: str, role: str, unit: str) -> Variable:
    where = f"variables.{_q(name)}"
    if isinstance(d, list):
        if len(d) != 2:
            raise InputError(where, f"a range is [low, high], got {len(d)} values")
        d = {"low": d[0], "high": d[1]}
    if not isinstance(d, dict):
        raise InputError(where, "expected [low, high] or a table (low/high [scale], values, or a distribution)")
    extra = set(d) - _VAR_KEYS
    if extra:
        raise InputError(f"{where}.{sorted(extra)[0]}", f"unknown key; expected some of {', '.join(sorted(_VAR_KEYS))}")
    if "values" in d:
        if command == "optimize":
            raise InputError(f"{where}.values", "optimize varies numbers over ranges; a list of values is for "
                                                "sensitivity (fix it in [fixed] instead)")
        if set(d) - {"values"}:
            raise InputError(where, "give values = [...] alone, or a range or distribution")
        vals = d["values"]
        if not isinstance(vals, list) or len(vals) < 2:
            raise InputError(f"{where}.values", "must list at least two values")
        for i, v in enumerate(vals):
            if not isinstance(v, (bool, str, int, float)) or (isinstance(v, float) and not math.isfinite(v)):
                raise InputError(f"{where}.values[{i}]", f"must be a number, string or boolean, got {v!r}")
        if len(set(map(repr, vals))) != len(vals):
            raise InputError(f"{where}.values", "has repeated values")
        if role != "key":
            raise InputError(f"{where}.values", "a list of values needs a model key path")
        return Variable(name, role, values=tuple(vals), unit=unit)
    dist = d.get("distribution", "loguniform" if d.get("scale") == "log" else "uniform")
    if dist not in DISTRIBUTIONS:
        raise InputError(f"{where}.distribution", f"expected one of {', '.join(DISTRIBUTIONS)}, got {dist!r}")
    if command == "optimize" and dist not in ("uniform", "loguniform"):
        raise InputError(f"{where}.distribution", "optimize needs a range (low, high [, scale]); distributions are "
                                                  "for sensitivity")
    allowed = {"uniform": {"low", "high", "scale", "distribution"},
               "loguniform": {"low", "high", "scale", "distribution"},
               "normal": {"mean", "std", "low", "high", "distribution"},
               "lognormal": {"median", "sigma", "distribution"},
               "triangular": {"low", "mode", "high", "distribution"}}[dist]
    bad = set(d) - allowed
    if bad:
        raise InputError(f"{where}.{sorted(bad)[0]}", f"does not apply to a {dist} variable "
                                                      f"(expected {', '.join(sorted(allowed - {'distribution'}))})")
    if dist in ("uniform", "loguniform", "triangular"):
        for k in ("low", "high"):
            if k not in d:
                raise InputError(f"{where}.{k}", "missing")
        low, high = _num(d["low"], f"{where}.low"), _num(d["high"], f"{where}.high")
        if not high > low:
            raise InputError(f"{where}.high", f"must be greater than low ({low:g}), got {high:g}")
        scale = d.get("scale", "log" if dist == "loguniform" else "linear")
        if scale not in ("linear", "log") or (dist == "loguniform" and scale != "log"):
            raise InputError(f"{where}.scale", f"expected 'linear' or 'log', got {scale!r}")
        if scale == "log" and not low > 0:
            raise InputError(f"{where}.low", f"a log scale needs low > 0, got {low:g}")
        if dist == "triangular":
            mode = _num(d.get("mode"), f"{where}.mode")
            if not low <= mode <= high:
                raise InputError(f"{where}.mode", f"must lie in [low, high] = [{low:g}, {high:g}], got {mode:g}")
            return Variable(name, role, low, high, distribution="triangular", params=(("mode", mode),), unit=unit)
        return Variable(name, role, low, high, scale=scale, distribution="uniform", unit=unit)
    if dist == "normal":
        mean = _num(d.get("mean"), f"{where}.mean")
        std = _num(d.get("std"), f"{where}.std", positive=True)
        low = _num(d["low"], f"{where}.low") if "low" in d else None
        high = _num(d["high"], f"{where}.high") if "high" in d else None
        if (low is None) != (high is None):
            raise InputError(f"{where}.{'high' if low is not None else 'low'}", "a truncated normal needs both low and high")
        if low is not None and not low < mean < high:
            raise InputError(f"{where}.mean", f"must lie inside the truncation [{low:g}, {high:g}]")
        return Variable(name, role, low, high, distribution="normal", params=(("mean", mean), ("std", std)), unit=unit)
    median = _num(d.get("median"), f"{where}.median", positive=True)
    sigma = _num(d.get("sigma"), f"{where}.sigma", positive=True)
    return Variable(name, role, distribution="lognormal", params=(("median", median), ("sigma", sigma)), unit=unit)


# --------------------------------------------------------------------------- derived expressions
_FUNCS = {"min": min, "max": max, "sqrt": math.sqrt, "exp": math.exp, "log": math.log, "abs": abs}
_BINOPS = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
           ast.Div: lambda a, b: a / b, ast.Pow: lambda a, b: a ** b}


def _dotted(node) -> str | None:
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        parts.append(node.id)
        return ".".join(reversed(parts))
    return None


def expression_names(text: str, where: str) -> list[str]:
    """The names an arithmetic expression reads; InputError for anything but numbers, names, ``+ - * / **``, calls
    of min, max, sqrt, exp, log, abs."""
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise InputError(where, f"not an arithmetic expression ({exc.msg})") from None
    names = []

    def visit(n):
        if isinstance(n, ast.Expression):
            return visit(n.body)
        if isinstance(n, ast.Constant) and isinstance(n.value, (int, float)) and not isinstance(n.value, bool):
            return
        if isinstance(n, (ast.Name, ast.Attribute)):
            d = _dotted(n)
            if d is None:
                raise InputError(where, "only names and numbers may be combined")
            names.append(d)
            return
        if isinstance(n, ast.BinOp) and type(n.op) in _BINOPS:
            visit(n.left), visit(n.right)
            return
        if isinstance(n, ast.UnaryOp) and isinstance(n.op, (ast.USub, ast.UAdd)):
            return visit(n.operand)
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in _FUNCS and not n.keywords:
            for a in n.args:
                visit(a)
            return
        raise InputError(where, f"unsupported element {type(n).__name__}: use numbers, variable names, "
                                "+ - * / **, min, max, sqrt, exp, log, abs")

    visit(tree)
    return names


def evaluate_expression(text: str, values: dict) -> float:
    """The value of an expression checked by :func:`expression_names` with ``values`` {name: number}."""
    tree = ast.parse(text, mode="eval")

    def ev(n):
        if isinstance(n, ast.Expression):
            return ev(n.body)
        if isinstance(n, ast.Constant):
            return n.value
        if isinstance(n, (ast.Name, ast.Attribute)):
            return values[_dotted(n)]
        if isinstance(n, ast.BinOp):
            return _BINOPS[type(n.op)](ev(n.left), ev(n.right))
        if isinstance(n, ast.UnaryOp):
            v = ev(n.operand)
            return -v if isinstance(n.op, ast.USub) else v
        return _FUNCS[n.func.id](*[ev(a) for a in n.args])

    return float(ev(tree))


# --------------------------------------------------------------------------- parsing
def model_reference(model: str, base_dir: Path | None, field: str = "model") -> tuple[str, str]:
    """(name, kind) of a spec's model: a shipped pump model, a model file (made absolute) or a module."""
    from lumped.model.model_file import SHIPPED

    if not isinstance(model, str) or not model:
        raise InputError(field, f"expected a model name, model file or module, got {model!r}")
    if model in SHIPPED or model in ("disc", "reed"):
        return (f"thesis-{model}" if model in ("disc", "reed") else model), "pump"
    if model.endswith(".toml") or "/" in model or os.sep in model:
        p = Path(model)
        if base_dir is not None and not p.is_absolute():
            p = base_dir / p
        if not p.is_file():
            raise InputError(field, f"{model!r}: no such model file")
        return str(p.resolve()), "pump"
    from lumped.plugins import import_object

    try:
        mod = import_object(model, field)
    except InputError as exc:
        raise InputError(field, f"{model!r} is not a shipped model ({', '.join(SHIPPED)}), a model file or an "
                                f"importable module ({exc.message})") from None
    for attr in ("OUTPUTS", "evaluate"):
        if not hasattr(mod, attr):
            raise InputError(field, f"module {model} has no {attr} (a sweep model, see studies/sweeps/sweep.py)")
    return model, "module"


def _model_digest(name: str, kind: str) -> str:
    if kind == "pump" and Path(name).is_file():
        return hashlib.sha256(Path(name).read_bytes()).hexdigest()[:16]
    return ""


def _parse_run(run: dict, command: str) -> dict:
    if not isinstance(run, dict):
        raise InputError("run", "expected a table")
    # one spec may serve both commands (CONTRACT's minimal spec lists outputs, objectives and samples): the
    # other command's keys of that example are accepted and ignored
    extra = set(run) - RUN_KEYS[command] - SHARED_RUN_KEYS[command]
    if extra:
        k = sorted(extra)[0]
        hint = " (an optimize key)" if k in RUN_KEYS["optimize"] else (
            " (a sensitivity key)" if k in RUN_KEYS["sensitivity"] else "")
        raise InputError(f"run.{k}", f"unknown key{hint}; expected some of {', '.join(sorted(RUN_KEYS[command]))}")
    out = {}
    out["seed"] = _int(run.get("seed", 0), "run.seed", 0, 2**32 - 1)
    # at least `revolutions`, then until the cyclic steady-state test passes (lumped.run.revolutions.StopRule;
    # each row warm-started from a solved neighbour's state: two revolutions for most)
    out["revolutions"] = _int(run.get("revolutions", 2), "run.revolutions", 2, 10_000)
    out["max_revolutions"] = _int(run.get("max_revolutions", max(20, 4 * out["revolutions"])), "run.max_revolutions",
                                  out["revolutions"], 100_000)
    from lumped.run.revolutions import STEADY_TOL

    out["steady_tol"] = _num(run.get("steady_tol", STEADY_TOL), "run.steady_tol", positive=True)
    if not out["steady_tol"] < 0.1:
        raise InputError("run.steady_tol", f"must be below 0.1, got {out['steady_tol']:g}")
    integ = run.get("integrator", "fast")
    if integ not in ("fast", "reference"):
        raise InputError("run.integrator", f"expected 'fast' or 'reference', got {integ!r}")
    out["integrator"] = integ
    if "on_warning" in run:     # a result with a validity warning (lumped.validity): kept and flagged, or excluded
        if run["on_warning"] not in ("flag", "exclude"):
            raise InputError("run.on_warning", f"expected 'flag' or 'exclude', got {run['on_warning']!r}")
        out["on_warning"] = run["on_warning"]
    # valve losses need a tighter rtol than the fast path's 1e-3: reed within 0.07 % of the reference at 1e-4, the
    # disc's delivery valve +12.5 % (+0.24 % at 1e-5; CONTRACT.md, the [run] table)
    rtol_def, atol_def = (1e-4, 1e-6) if integ == "fast" else (1e-6, 1e-6)
    for k, d in (("rtol", rtol_def), ("atol", atol_def)):
        v = _num(run.get(k, d), f"run.{k}", positive=True)
        if not v < 0.1:
            raise InputError(f"run.{k}", f"must be below 0.1, got {v:g}")
        out[k] = v
    if command == "sensitivity":
        method = run.get("method", "sobol")
        if method not in ("sobol", "morris"):
            raise InputError("run.method", f"expected 'sobol' or 'morris', got {method!r}")
        out["method"] = method
        default_n = 256 if method == "sobol" else 20
        n = _int(run.get("samples", default_n), "run.samples", 2, 10**9)
        if method == "sobol" and n & (n - 1):
            lo = 1 << (n.bit_length() - 1)
            raise InputError("run.samples", f"Sobol sampling needs a power of 2 (its balance), got {n}; "
                                            f"use {lo} or {2 * lo}")
        out["samples"] = n
        out["num_levels"] = _int(run.get("num_levels", 4), "run.num_levels", 2, 100)
        if method == "morris" and out["num_levels"] % 2:
            raise InputError("run.num_levels", f"Morris screening needs an even number of levels, got "
                                               f"{out['num_levels']}")
        out["num_resamples"] = _int(run.get("num_resamples", 200), "run.num_resamples", 10, 100_000)
        cl = _num(run.get("conf_level", 0.95), "run.conf_level")
        if not 0.5 <= cl < 1:
            raise InputError("run.conf_level", f"must be in [0.5, 1), got {cl:g}")
        out["conf_level"] = cl
        outs = run.get("outputs")
        if not isinstance(outs, list) or not outs or not all(isinstance(o, str) for o in outs):
            raise InputError("run.outputs", "missing: list the outputs to analyse, e.g. [\"delivery_cc_per_rev\"]")
        if len(set(outs)) != len(outs):
            raise InputError("run.outputs", "has repeated outputs")
        out["outputs"] = tuple(outs)
    else:
        objs = run.get("objectives")
        if not isinstance(objs, list) or not objs or not all(isinstance(o, str) for o in objs):
            raise InputError("run.objectives", "missing: list them, e.g. [\"max volumetric_efficiency\", "
                                               "\"min valve_loss_j\"]")
        agg = run.get("aggregate", "mean")
        if agg not in ("mean", "worst"):
            raise InputError("run.aggregate", f"expected 'mean' or 'worst' (over the operating points), got {agg!r}")
        out["aggregate"] = agg
        parsed = []
        for i, o in enumerate(objs):
            m = re.fullmatch(r"\s*(max|min)\s+(?:(mean|worst)\(\s*([A-Za-z0-9_]+)\s*\)|([A-Za-z0-9_]+))\s*", o)
            if not m:
                raise InputError(f"run.objectives[{i}]", f"expected \"max NAME\", \"min NAME\" or "
                                                         f"\"max mean(NAME)\" / \"min worst(NAME)\", got {o!r}")
            parsed.append(Objective(m.group(1), m.group(3) or m.group(4), m.group(2) or agg))
        if len({o.output for o in parsed}) != len(parsed):
            raise InputError("run.objectives", "names an output twice")
        out["objectives"] = tuple(parsed)
        algo = run.get("algorithm", "nsga2" if len(parsed) > 1 else "de")
        if algo not in ("nsga2", "de"):
            raise InputError("run.algorithm", f"expected 'nsga2' (pymoo) or 'de' (scipy differential evolution), "
                                              f"got {algo!r}")
        if algo == "de" and len(parsed) > 1:
            raise InputError("run.algorithm", "differential evolution optimises one objective; use nsga2")
        out["algorithm"] = algo
        out["population"] = _int(run.get("population", 40), "run.population", 4, 100_000)
        out["generations"] = _int(run.get("generations", 40), "run.generations", 1, 100_000)
        out["max_evaluations"] = _int(run.get("max_evaluations", 5_000_000), "run.max_evaluations", 1, 10**9)
    return out


def _parse_operating(op, model_name: str, kind: str, var_names: set) -> tuple:
    if kind == "module":
        if op:
            raise InputError("operating", "a module model has no operating points; drop [operating]")
        return ({},)
    if not isinstance(op, dict):
        raise InputError("operating", "expected a table with speed_rpm and load_pressure_mpa lists")
    extra = set(op) - {"speed_rpm", "load_pressure_mpa"}
    if extra:
        k = sorted(extra)[0]
        raise InputError(f"operating.{k}", "unknown key; expected speed_rpm (rpm) and load_pressure_mpa (MPa, "
                                           "absolute) lists" + (" (load pressure in MPa: load_pressure_mpa)"
                                                                if k == "load_pressure" else ""))
    from geometry.declare import check_value
    from lumped.model.pump_model import LOAD_MPA, SPEED

    lists = {}
    for k, spec in (("speed_rpm", SPEED), ("load_pressure_mpa", LOAD_MPA)):
        if k in op and k in var_names:
            raise InputError(f"operating.{k}", "is also a variable; keep it in one place")
        v = op.get(k)
        if v is None:
            lists[k] = None
            continue
        if not isinstance(v, list):
            v = [v]
        if not v:
            raise InputError(f"operating.{k}", "is an empty list")
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, (int, float)):
                raise InputError(f"operating.{k}[{i}]", f"expected a number, got {x!r}")
            check_value(float(x), spec, f"operating.{k}[{i}]")
        if len(set(v)) != len(v):
            raise InputError(f"operating.{k}", "has repeated values")
        lists[k] = [float(x) for x in v]
    from lumped.model.model_file import load_model

    model = load_model(model_name, field="model")
    for k, attr, scale in (("speed_rpm", "speed_rpm", 1.0), ("load_pressure_mpa", "load_pressure", 1e-6)):
        if lists[k] is None and k not in var_names:
            dv = getattr(model.operating, attr)
            if dv is None:
                raise InputError(f"operating.{k}", f"missing, and the model {model.name!r} has no [operating] {attr}")
            lists[k] = [dv * scale]
    points = []
    for s in lists["speed_rpm"] or [None]:
        for p in lists["load_pressure_mpa"] or [None]:
            pt = {}
            if s is not None:
                pt["speed_rpm"] = s
            if p is not None:
                pt["load_pressure"] = p * 1e6
            points.append(pt)
    return tuple(points)


def _unit_of(model, path: str) -> str:
    from lumped.model.model_file import key_paths

    if path in OPERATING_VARIABLES:
        return OPERATING_VARIABLES[path]
    parts = path.split(".")
    if "geometry" in parts:
        return GEOMETRY_UNITS.get(".".join(parts[parts.index("geometry") + 1:]), "-")
    units = {k["path"]: k["unit"] for k in key_paths(model)}
    if path in units:
        return units[path]
    if parts[0] == "valves" and len(parts) > 1 and parts[1] not in ("inlet", "delivery"):
        return units.get("valves.delivery." + ".".join(parts[1:]), units.get("valves.inlet." + ".".join(parts[1:]), "-"))
    if parts[0] == "effects":
        from lumped.model.effect_library import LIBRARY

        if len(parts) >= 3 and parts[1] in LIBRARY.names():
            for p in LIBRARY[parts[1]].parameters:
                if p.name == parts[-1]:
                    return p.unit
    return "-"


def parse_spec(doc: dict, command: str, text: str = "", base_dir: Path | None = None,
               model_override: str | None = None) -> DesignSpec:
    """A :class:`DesignSpec` from a parsed spec TOML (see the module docstring and CONTRACT.md)."""
    if command not in COMMANDS:
        raise InputError("command", f"expected one of {', '.join(COMMANDS)}, got {command!r}")
    if model_override is not None and not isinstance(model_override, str):
        raise InputError("model_override", f"expected a model name or file, got {model_override!r}")
    if not isinstance(doc, dict):
        raise InputError("spec", "must be a TOML table")
    extra = set(doc) - TOP_KEYS[command]
    if extra:
        k = sorted(extra)[0]
        hint = " (an optimize section)" if k in TOP_KEYS["optimize"] else ""
        raise InputError(k, f"unknown section or key{hint}; expected some of {', '.join(sorted(TOP_KEYS[command]))}")
    description = doc.get("description", "")
    if not isinstance(description, str):
        raise InputError("description", "expected a string")
    if model_override is not None:
        model, kind = model_reference(model_override, Path.cwd(), "--model")
    else:
        if "model" not in doc:
            raise InputError("model", "missing: the base model (thesis-disc, thesis-reed, a model file or a module)")
        model, kind = model_reference(doc["model"], base_dir)

    fixed_doc = doc.get("fixed", {})
    if not isinstance(fixed_doc, dict):
        raise InputError("fixed", "expected a table of key path = value")
    fixed = []
    for k, v in flatten(fixed_doc, where="fixed").items():
        if isinstance(v, float) and not math.isfinite(v):
            raise InputError(f"fixed.{_q(k)}", f"must be finite, got {v}")
        if isinstance(v, list):
            v = tuple(v)
        fixed.append((k, v))

    var_doc = doc.get("variables")
    if not isinstance(var_doc, dict) or not var_doc:
        raise InputError("variables", "need at least one variable: \"key.path\" = [low, high]")
    var_doc = flatten(var_doc, leaf_keys=_VAR_KEYS, where="variables")
    der_doc = doc.get("derived", {})
    if not isinstance(der_doc, dict):
        raise InputError("derived", "expected a table of key path = \"expression\"")
    der_doc = flatten(der_doc, where="derived")

    model_obj = None
    if kind == "pump":
        from lumped.model.model_file import load_model

        model_obj = load_model(model, field="model")
    # which names the derived expressions read
    derived, used = [], set()
    for k, expr in der_doc.items():
        where = f"derived.{_q(k)}"
        if not isinstance(expr, str):
            raise InputError(where, f"expected an expression string such as \"step_length / valves.geometry.length\", "
                                    f"got {expr!r}")
        names = expression_names(expr, where)
        for n in names:
            if n not in var_doc and n not in dict(derived):
                raise InputError(where, f"reads {n!r}, which is neither a variable nor a key derived above")
        used.update(names)
        if k in var_doc:
            raise InputError(where, "is also a variable; keep it in one place")
        derived.append((k, expr))
    variables = []
    sections = ("pump.", "oil.", "circuit.", "operating.", "valves.", "effects.")
    for name, d in var_doc.items():
        if name in OPERATING_VARIABLES:
            if kind == "module":
                raise InputError(f"variables.{name}", "a module model has no operating point")
            role = "operating"
        elif kind == "pump" and name.startswith(sections):
            role = "key"
        elif kind == "module":
            role = "key"
        elif "." not in name and name in used:
            role = "auxiliary"
        else:
            raise InputError(f"variables.{_q(name)}", "not a model key path (pump.*, oil.*, circuit.*, valves.*, "
                                                      "effects.*), speed_rpm or load_pressure_mpa, nor a name "
                                                      "used by [derived]")
        unit = _unit_of(model_obj, name) if kind == "pump" and role != "auxiliary" else "-"
        if kind == "module":
            unit = getattr(__import__(model, fromlist=["x"]), "UNITS", {}).get(name, "-")
        variables.append(_parse_variable(name, d, command, role, unit))
    if len(variables) > 1000:
        raise InputError("variables", f"{len(variables)} variables; at most 1000")
    for k, _ in fixed:
        if k in var_doc or k in der_doc:
            raise InputError(f"fixed.{_q(k)}", "is also varied; keep it in one place")

    run = _parse_run(doc.get("run", {}), command)
    points = _parse_operating(doc.get("operating", {}), model, kind, set(var_doc))

    # outputs, objectives, constraints
    if kind == "pump":
        from studies.sweeps.design.outputs import PUMP_OUTPUTS as catalogue
    else:
        from studies.sweeps.design.outputs import module_outputs

        catalogue = module_outputs(__import__(model, fromlist=["x"]))

    def known(name, where):
        if name not in catalogue:
            close = [n for n in catalogue if name.split("_")[0] in n][:6]
            raise InputError(where, f"unknown output {name!r}; expected one of {', '.join(close or list(catalogue)[:12])}"
                                    f" ... (CONTRACT.md lists them all)")

    outputs, objectives = (), ()
    if command == "sensitivity":
        for i, o in enumerate(run["outputs"]):
            known(o, f"run.outputs[{i}]")
        outputs = run.pop("outputs")
    else:
        for i, o in enumerate(run["objectives"]):
            known(o.output, f"run.objectives[{i}]")
        objectives = run.pop("objectives")
        n_eval = run["population"] * (run["generations"] + 1)
        if n_eval > run["max_evaluations"]:
            raise InputError("run.generations", f"population x (generations + 1) = {n_eval} designs exceeds "
                                                f"run.max_evaluations = {run['max_evaluations']}")
    stress = _parse_stress(doc.get("stress", {}))
    constraints = []
    cons_doc = doc.get("constraints", {})
    if not isinstance(cons_doc, dict):
        raise InputError("constraints", "expected a table: OUTPUT = { max = X } or { min = X }, reed_stress = {...}")
    for name, d in cons_doc.items():
        where = f"constraints.{name}"
        if name == "reed_stress":
            if kind != "pump":
                raise InputError(where, "needs a pump model with reed valves")
            if not isinstance(d, dict):
                raise InputError(where, "expected a table: { safety_factor = 1.5, yield_stress_mpa = 63.0 }")
            bad = set(d) - {"safety_factor", "yield_stress_mpa", "loop_margin"}
            if bad:
                raise InputError(f"{where}.{sorted(bad)[0]}", "unknown key; expected safety_factor, yield_stress_mpa, "
                                                              "loop_margin")
            lm = _num(d.get("loop_margin", 1.0), f"{where}.loop_margin", positive=True)
            if lm < 1:
                raise InputError(f"{where}.loop_margin", f"must be at least 1, got {lm:g}")
            sf = _num(d.get("safety_factor", 1.5), f"{where}.safety_factor", positive=True)
            if sf < 1:
                raise InputError(f"{where}.safety_factor", f"must be at least 1, got {sf:g}")
            ys = _num(d.get("yield_stress_mpa", stress["yield_stress_mpa"]), f"{where}.yield_stress_mpa", positive=True)
            stress = dict(stress, yield_stress_mpa=ys, safety_factor=sf)
            constraints.append(Constraint("reed_stress_mpa", high=ys / sf, source=where, loop_margin=lm))
            continue
        known(name, where)
        if not isinstance(d, dict) or not d or set(d) - {"min", "max"}:
            raise InputError(where, "expected { max = X }, { min = X } or both")
        lo = _num(d["min"], f"{where}.min") if "min" in d else None
        hi = _num(d["max"], f"{where}.max") if "max" in d else None
        if lo is not None and hi is not None and not hi > lo:
            raise InputError(f"{where}.max", f"must exceed min ({lo:g})")
        constraints.append(Constraint(name, lo, hi, source=where))
    recheck = _parse_recheck(doc.get("recheck", {})) if command == "optimize" else {}
    spec = DesignSpec(command=command, model=model, model_kind=kind, fixed=tuple(fixed), points=points,
                      variables=tuple(variables), derived=tuple(derived), run=tuple(sorted(run.items())),
                      outputs=tuple(outputs), objectives=tuple(objectives), constraints=tuple(constraints),
                      stress=tuple(sorted(stress.items())), recheck=tuple(sorted(recheck.items())),
                      description=description, text=text, model_digest=_model_digest(model, kind))
    return spec


def _parse_stress(d) -> dict:
    if not isinstance(d, dict):
        raise InputError("stress", "expected a table")
    validate.keys(d, ("yield_stress_mpa", "calibration", "mesh_size"), "stress")
    from fea.reed_stress import YIELD_STRESS_DELRIN

    out = {"yield_stress_mpa": _num(d.get("yield_stress_mpa", YIELD_STRESS_DELRIN / 1e6), "stress.yield_stress_mpa",
                                    positive=True), "safety_factor": 1.0}
    cal = d.get("calibration", "base")
    if isinstance(cal, str):
        if cal not in ("base", "conservative"):
            raise InputError("stress.calibration", f"expected 'base', 'conservative' or a number, got {cal!r}")
    else:
        cal = _num(cal, "stress.calibration", positive=True)
    out["calibration"] = cal
    out["mesh_size"] = None if "mesh_size" not in d else _num(d["mesh_size"], "stress.mesh_size", positive=True)
    return out


def _parse_recheck(d) -> dict:
    if not isinstance(d, dict):
        raise InputError("recheck", "expected a table")
    validate.keys(d, ("enabled", "max_designs", "mesh_size", "stress_tolerance_pct", "tolerance_pct"), "recheck")
    en = d.get("enabled", True)
    if not isinstance(en, bool):
        raise InputError("recheck.enabled", f"expected true or false, got {en!r}")
    from studies.validation.reed_check import DEFAULT_TOLERANCE_PCT

    return {"enabled": en,
            "tolerance_pct": _num(d.get("tolerance_pct", DEFAULT_TOLERANCE_PCT), "recheck.tolerance_pct", positive=True),
            "stress_tolerance_pct": _num(d.get("stress_tolerance_pct", 10.0), "recheck.stress_tolerance_pct",
                                         positive=True),
            "mesh_size": None if "mesh_size" not in d else _num(d["mesh_size"], "recheck.mesh_size", positive=True),
            "max_designs": _int(d.get("max_designs", 1000), "recheck.max_designs", 1, 100_000)}


def load_spec(path, command: str, model_override: str | None = None) -> DesignSpec:
    """Read and check a spec file (a path)."""
    p = validate.path(path, "path")
    if command not in COMMANDS:
        raise InputError("command", f"expected one of {', '.join(COMMANDS)}, got {command!r}")
    text = validate.read_text(p, str(path))
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(str(path), f"not valid TOML ({exc})") from None
    return parse_spec(doc, command, text, base_dir=p.parent, model_override=model_override)


# --------------------------------------------------------------------------- designs
def design_inputs(spec: DesignSpec, values: dict) -> dict:
    """The evaluation inputs of one design from its variable values: key paths (variables, then derived keys),
    operating variables in SI (load_pressure in Pa); auxiliary variables only feed the derived keys."""
    out = {}
    for v in spec.variables:
        x = values[v.name]
        if v.role == "key":
            out[v.name] = x
        elif v.name == "load_pressure_mpa":
            out["load_pressure"] = x * 1e6
        elif v.name == "speed_rpm":
            out["speed_rpm"] = x
    env = dict(values)
    for k, expr in spec.derived:
        try:
            env[k] = evaluate_expression(expr, env)
        except (ZeroDivisionError, ValueError, OverflowError) as exc:
            raise InputError(f"derived.{_q(k)}", f"cannot be evaluated ({exc})") from None
        out[k] = env[k]
    return out


def check_size(n_rows: int, field: str, out_dir: Path, what: str) -> None:
    """InputError naming ``field`` if ``n_rows`` evaluations would not fit (row cap, memory, disk)."""
    if n_rows > MAX_ROWS:
        raise InputError(field, f"{what} = {n_rows:,} evaluations; at most {MAX_ROWS:,} in one study")
    need_mem = n_rows * ROW_BYTES_MEMORY
    try:
        avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        avail = None
    if avail and need_mem > 0.5 * avail:
        raise InputError(field, f"{what} = {n_rows:,} evaluations need about {need_mem / 1e9:.1f} GB of memory for "
                                f"their tables; {avail / 1e9:.1f} GB are free")
    anc = Path(out_dir).resolve()
    while not anc.exists() and anc != anc.parent:
        anc = anc.parent
    free = shutil.disk_usage(anc).free
    need_disk = n_rows * ROW_BYTES_DISK
    if need_disk > 0.9 * free:
        raise InputError(field, f"{what} = {n_rows:,} evaluations need about {need_disk / 1e9:.1f} GB on disk; "
                                f"{free / 1e9:.1f} GB are free in {anc}")
