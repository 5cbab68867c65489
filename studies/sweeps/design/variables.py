"""What a sensitivity or optimisation study varies and asks for: variables, objectives, constraints.

A variable (``[variables]`` of the spec, CONTRACT.md) is a range ``[low, high]`` or
``{low, high, scale}``, a list of levels ``{values = [...]}`` (sensitivity only) or a
distribution (sensitivity only): ``uniform``, ``loguniform``, ``normal`` (truncated with
``low``/``high``), ``lognormal`` (``median``, ``sigma``), ``triangular`` (``low``, ``mode``,
``high``). Samples in the unit hypercube map onto it by its inverse CDF
(:meth:`Variable.from_unit`). The table is checked through :mod:`studies.sweeps.schema`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from geometry.errors import InputError
from studies.sweeps import schema

DISTRIBUTIONS = ("uniform", "loguniform", "normal", "lognormal", "triangular")
#: the quantiles at which an unbounded distribution is checked against the model
CHECK_QUANTILES = (1e-3, 1 - 1e-3)
#: every key a variable's table may hold (a table holding one is a variable, not a namespace of key paths)
VARIABLE_KEYS = {"low", "high", "scale", "values", "distribution", "mean", "std", "median", "sigma", "mode"}
#: the keys each distribution takes
DISTRIBUTION_KEYS = {"uniform": {"low", "high", "scale", "distribution"},
                     "loguniform": {"low", "high", "scale", "distribution"},
                     "normal": {"mean", "std", "low", "high", "distribution"},
                     "lognormal": {"median", "sigma", "distribution"},
                     "triangular": {"low", "mode", "high", "distribution"}}


@dataclass(frozen=True)
class Variable:
    """One varied input: a range (linear or log), a list of values, or a distribution.

    Parameters
    ----------
    name : str
        A model-file key path, ``speed_rpm``, ``load_pressure_mpa`` or a name read by ``[derived]``.
    role : str
        ``key`` (a model key path or a module model's input), ``operating`` or ``auxiliary``.
    low, high : float, optional
        The range (or a distribution's truncation), in ``unit``.
    scale : str
        ``linear`` or ``log`` (a range).
    values : tuple, optional
        Categorical levels, equally likely.
    distribution : str
        ``uniform`` (a range, linear or log), ``normal``, ``lognormal`` or ``triangular``.
    params : tuple of (str, float)
        The distribution's parameters: mean and std, median and sigma, or mode.
    unit : str
        The input's unit (from the model's key declarations).
    """

    name: str
    role: str
    low: float | None = None
    high: float | None = None
    scale: str = "linear"
    values: tuple | None = None
    distribution: str = "uniform"
    params: tuple = ()
    unit: str = "-"

    @property
    def is_range(self) -> bool:
        """Whether the variable is a plain range (linear or log), the only kind an optimiser varies."""
        return self.values is None and self.distribution in ("uniform", "loguniform")

    def _dist(self):
        """The frozen scipy.stats distribution of a normal, lognormal or triangular variable."""
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
        """Map uniform samples onto this variable.

        Parameters
        ----------
        u : array_like
            Samples in [0, 1].

        Returns
        -------
        list
            One value per sample, in ``unit``: a level, a point of the range (linear or log) or
            the distribution's inverse CDF at u (clipped to [1e-12, 1 - 1e-12]).
        """
        u = np.asarray(u, dtype=float)
        if self.values is not None:
            return schema.from_unit_levels(u, self.values)
        if self.is_range:
            return [float(v) for v in schema.from_unit_range(u, self.low, self.high, self.scale)]
        return [float(v) for v in self._dist().ppf(np.clip(u, 1e-12, 1 - 1e-12))]

    def opt_bounds(self) -> tuple[float, float]:
        """The variable's bounds in the optimiser's space.

        Returns
        -------
        tuple of float
            (low, high) in ``unit``, or (ln low, ln high) on a log scale.
        """
        if self.scale == "log":
            return math.log(self.low), math.log(self.high)
        return self.low, self.high

    def from_opt(self, z: float) -> float:
        """A value from a coordinate of the optimiser's space.

        Parameters
        ----------
        z : float

        Returns
        -------
        float
            In ``unit``: z, or exp(z) on a log scale.
        """
        return float(math.exp(z)) if self.scale == "log" else float(z)

    def to_opt(self, x: float) -> float:
        """The coordinate in the optimiser's space of a value.

        Parameters
        ----------
        x : float
            In ``unit``.

        Returns
        -------
        float
            x, or ln x on a log scale.
        """
        return math.log(x) if self.scale == "log" else float(x)

    def check_points(self) -> list:
        """The values checked against the model before running.

        Returns
        -------
        list
            The ends of the range, every level, or the 0.1 % and 99.9 % quantiles of a distribution.
        """
        if self.values is not None:
            return list(self.values)
        if self.is_range:
            return [self.low, self.high]
        return self.from_unit(np.array(CHECK_QUANTILES))

    def centre(self):
        """The variable's value in the centre design.

        Returns
        -------
        object
            The first level, or the median (the middle of a range, on its scale).
        """
        if self.values is not None:
            return self.values[0]
        return self.from_unit(np.array([0.5]))[0]

    @property
    def label(self) -> str:
        """``name [unit]`` for plot axes and tables."""
        return f"{self.name} [{self.unit}]"

    def describe(self) -> dict:
        """The variable as the summary JSON lists it.

        Returns
        -------
        dict
            ``name``, ``role``, ``unit`` and its range, levels or distribution parameters.
        """
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
    """One objective of an optimisation: ``sense`` (min or max) ``aggregate`` (mean or worst) of ``output``."""

    sense: str
    output: str
    aggregate: str

    @property
    def label(self) -> str:
        """``max mean(volumetric_efficiency)`` style text."""
        return f"{self.sense} {self.aggregate}({self.output})"


@dataclass(frozen=True)
class Constraint:
    """One constraint of an optimisation, met at every operating point.

    Parameters
    ----------
    output : str
        The constrained output.
    low, high : float, optional
        output >= low, output <= high (in the output's unit).
    source : str
        The spec field that made it.
    loop_margin : float
        In the optimisation loop the limits are tightened by this factor (the final check uses them as given).
    """

    output: str
    low: float | None = None
    high: float | None = None
    source: str = ""
    loop_margin: float = 1.0

    @property
    def label(self) -> str:
        """``reed_stress_mpa <= 42`` style text."""
        parts = []
        if self.low is not None:
            parts.append(f"{self.output} >= {self.low:g}")
        if self.high is not None:
            parts.append(f"{self.output} <= {self.high:g}")
        return " and ".join(parts)


# --------------------------------------------------------------------------- parsing
def parse_variable(name: str, d, command: str, role: str, unit: str) -> Variable:
    """Check one ``[variables]`` entry and make its :class:`Variable`.

    Parameters
    ----------
    name : str
        The variable's key path or name.
    d : list or dict
        ``[low, high]`` or its table.
    command : str
        ``sensitivity`` or ``optimize`` (which varies ranges only).
    role : str
        ``key``, ``operating`` or ``auxiliary`` (:class:`Variable`).
    unit : str
        The input's unit.

    Returns
    -------
    Variable
    """
    where = f"variables.{schema.quoted(name)}"
    if isinstance(d, list):
        if len(d) != 2:
            raise InputError(where, f"a range is [low, high], got {len(d)} values")
        d = {"low": d[0], "high": d[1]}
    schema.table(d, where, "[low, high] or a table (low/high [scale], values, or a distribution)")
    schema.check_keys(d, VARIABLE_KEYS, where)
    if "values" in d:
        return _levels_variable(name, d, command, role, unit)
    dist = d.get("distribution", "loguniform" if d.get("scale") == "log" else "uniform")
    schema.read_key(dist, schema.Key("choice", choices=DISTRIBUTIONS), f"{where}.distribution")
    if command == "optimize" and dist not in ("uniform", "loguniform"):
        raise InputError(f"{where}.distribution", "optimize needs a range (low, high [, scale]); distributions are "
                                                  "for sensitivity")
    allowed = DISTRIBUTION_KEYS[dist]
    bad = set(d) - allowed
    if bad:
        raise InputError(f"{where}.{sorted(bad)[0]}", f"does not apply to a {dist} variable "
                                                      f"(expected {', '.join(sorted(allowed - {'distribution'}))})")
    if dist in ("uniform", "loguniform"):
        low, high, scale = schema.parse_range(d, where, ("log",) if dist == "loguniform" else schema.SCALES,
                                              "log" if dist == "loguniform" else "linear")
        return Variable(name, role, low, high, scale=scale, distribution="uniform", unit=unit)
    return {"normal": _normal, "lognormal": _lognormal, "triangular": _triangular}[dist](name, d, where, role, unit)


def _levels_variable(name: str, d: dict, command: str, role: str, unit: str) -> Variable:
    """A variable of equally likely levels (``values = [...]``; sensitivity, a model key path)."""
    where = f"variables.{schema.quoted(name)}"
    if command == "optimize":
        raise InputError(f"{where}.values", "optimize varies numbers over ranges; a list of values is for "
                                            "sensitivity (fix it in [fixed] instead)")
    if set(d) - {"values"}:
        raise InputError(where, "give values = [...] alone, or a range or distribution")
    vals = schema.levels(d["values"], f"{where}.values", minimum=2)
    if role != "key":
        raise InputError(f"{where}.values", "a list of values needs a model key path")
    return Variable(name, role, values=vals, unit=unit)


def _triangular(name: str, d: dict, where: str, role: str, unit: str) -> Variable:
    """A triangular distribution on [low, high] with its mode inside."""
    low, high, _ = schema.parse_range(d, where, ("linear",))
    mode = schema.number(d.get("mode"), f"{where}.mode")
    if not low <= mode <= high:
        raise InputError(f"{where}.mode", f"must lie in [low, high] = [{low:g}, {high:g}], got {mode:g}")
    return Variable(name, role, low, high, distribution="triangular", params=(("mode", mode),), unit=unit)


def _normal(name: str, d: dict, where: str, role: str, unit: str) -> Variable:
    """A normal distribution (mean, std), truncated to [low, high] when both are given."""
    mean = schema.number(d.get("mean"), f"{where}.mean")
    std = schema.number(d.get("std"), f"{where}.std", positive=True)
    low = schema.number(d["low"], f"{where}.low") if "low" in d else None
    high = schema.number(d["high"], f"{where}.high") if "high" in d else None
    if (low is None) != (high is None):
        raise InputError(f"{where}.{'high' if low is not None else 'low'}",
                         "a truncated normal needs both low and high")
    if low is not None and not low < mean < high:
        raise InputError(f"{where}.mean", f"must lie inside the truncation [{low:g}, {high:g}]")
    return Variable(name, role, low, high, distribution="normal", params=(("mean", mean), ("std", std)), unit=unit)


def _lognormal(name: str, d: dict, where: str, role: str, unit: str) -> Variable:
    """A lognormal distribution: ln x normal with median ``median`` and standard deviation ``sigma``."""
    median = schema.number(d.get("median"), f"{where}.median", positive=True)
    sigma = schema.number(d.get("sigma"), f"{where}.sigma", positive=True)
    return Variable(name, role, distribution="lognormal", params=(("median", median), ("sigma", sigma)), unit=unit)
