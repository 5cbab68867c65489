"""The sweep file: its schema (CONTRACT.md, "Sweep file"), the parsed :class:`SweepSpec` and its designs.

A sweep file names the model, the sampler and the factors; everything else is fixed::

    [sweep]
    model = "thesis-disc"   # pump, a shipped pump model, a model file or a sweep-model module
    sampler = "sobol"       # grid | lhs | sobol | random
    samples = 16
    [factors.speed_rpm]
    low = 450.0
    high = 950.0
    [fixed]
    air_content = 0.01

Every field is checked by :mod:`studies.sweeps.schema` (the machinery the sensitivity and
optimisation specs use too) before anything runs; a bad one raises
:class:`~geometry.errors.InputError` naming it (``factors.speed_rpm.high``).
"""

from __future__ import annotations

import hashlib
import itertools
import math
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from geometry import validate
from geometry.errors import InputError
from studies.sweeps import schema
from studies.sweeps.schema import META_COLUMNS, Key

SAMPLERS = ("grid", "lhs", "sobol", "random")
#: most designs one sweep may hold (its design table alone is ~100 MB per 1e6 designs)
MAX_DESIGNS = 10_000_000
#: the plain keys of ``[sweep]``; ``model`` and ``samples`` (needed or not by the sampler) are read on their own
SWEEP_KEYS = {"sampler": Key("choice", schema.REQUIRED, choices=SAMPLERS), "seed": Key("int", 0, bounds=(0, 2**63 - 1)),
              "scramble": Key("bool", True)}
FACTOR_KEYS = {"low", "high", "scale", "levels", "values", "integer"}


@dataclass(frozen=True)
class Factor:
    """One swept input: a continuous range [low, high] (linear or log) or a list of values.

    Parameters
    ----------
    name : str
        The input (a pump input or model-file key path, or a module model's input).
    low, high : float, optional
        The range, in the input's unit (None for a list of values).
    scale : str
        ``linear`` or ``log`` (a range).
    levels : int, optional
        Grid points of a range (the grid sampler only).
    values : tuple, optional
        Explicit levels: categorical, or the grid of a number.
    integer : bool
        Round sampled values of a range to integers.
    """

    name: str
    low: float | None = None
    high: float | None = None
    scale: str = "linear"
    levels: int | None = None
    values: tuple | None = None
    integer: bool = False

    @property
    def is_range(self) -> bool:
        """Whether the factor is a continuous range (not a list of values)."""
        return self.values is None

    def grid(self) -> list:
        """The grid levels of this factor.

        Returns
        -------
        list
            Its values, or ``levels`` points evenly spaced over the range (geometrically on a log scale).
        """
        if not self.is_range:
            return list(self.values)
        pts = (np.geomspace if self.scale == "log" else np.linspace)(self.low, self.high, self.levels)
        return [int(round(v)) for v in pts] if self.integer else [float(v) for v in pts]

    def from_unit(self, u: np.ndarray) -> list:
        """Map uniform samples onto the factor (stratification is preserved).

        Parameters
        ----------
        u : numpy.ndarray
            Samples in [0, 1).

        Returns
        -------
        list
            One value per sample (:func:`studies.sweeps.schema.from_unit_range` or ``from_unit_levels``).
        """
        if not self.is_range:
            return schema.from_unit_levels(u, self.values)
        x = schema.from_unit_range(u, self.low, self.high, self.scale)
        return [int(round(v)) for v in x] if self.integer else [float(v) for v in x]


@dataclass(frozen=True)
class SweepSpec:
    """A parsed sweep file: which model, how to sample, what to vary and what to hold.

    Parameters
    ----------
    model : str
        ``pump`` or an importable sweep-model module.
    sampler : str
        ``grid``, ``lhs``, ``sobol``, ``random`` (``given``: explicit designs, see
        :func:`studies.sweeps.design.runner.sweep_spec_of`).
    factors : tuple of Factor
        The swept inputs.
    fixed : tuple of (str, object)
        The inputs every design shares.
    samples : int, optional
        Designs of a sampler other than the grid.
    seed : int
        The sampler's seed.
    scramble : bool
        Scramble the Sobol sequence.
    text : str
        The TOML, kept in the output folder.
    """

    model: str
    sampler: str
    factors: tuple[Factor, ...]
    fixed: tuple[tuple[str, object], ...] = ()
    samples: int | None = None
    seed: int = 0
    scramble: bool = True
    text: str = field(default="", compare=False, repr=False)

    @property
    def fixed_dict(self) -> dict:
        """The fixed inputs as a dict."""
        return dict(self.fixed)

    @property
    def digest(self) -> str:
        """A hash of what determines the designs and their results (resume safety)."""
        key = repr((self.model, self.sampler, self.factors, self.fixed, self.samples, self.seed, self.scramble))
        return hashlib.sha256(key.encode()).hexdigest()[:16]

    @property
    def n_designs(self) -> int:
        """How many designs the sweep holds (the product of the levels for the grid)."""
        if self.sampler == "grid":
            return math.prod(len(f.grid()) for f in self.factors)
        return int(self.samples)


# --------------------------------------------------------------------------- parsing
def _parse_factor(name: str, d, sampler: str) -> Factor:
    """One ``[factors.NAME]`` table: a range (low, high, scale, levels, integer) or a list (values)."""
    where = f"factors.{name}"
    schema.table(d, where, "a table with low/high (a range) or values (a list)")
    schema.check_keys(d, FACTOR_KEYS, where)
    if "values" in d:
        if set(d) & {"low", "high", "scale", "levels"}:
            raise InputError(where, "give either values = [...] or low/high, not both")
        return Factor(name, values=schema.levels(d["values"], f"{where}.values"))
    low, high, scale = schema.parse_range(d, where)
    integer = schema.boolean(d.get("integer", False), f"{where}.integer")
    levels = d.get("levels")
    if sampler == "grid":
        if levels is None:
            raise InputError(f"{where}.levels", "the grid sampler needs levels (>= 2) for a range")
        schema.integer(levels, f"{where}.levels", 2, MAX_DESIGNS)
    elif levels is not None:
        raise InputError(f"{where}.levels", f"only the grid sampler uses levels (sampler is {sampler!r})")
    return Factor(name, low=low, high=high, scale=scale, levels=levels, integer=integer)


def _sweep_table(doc: dict) -> dict:
    """The checked ``[sweep]`` table (model, sampler, samples, seed, scramble)."""
    sw = doc.get("sweep")
    if not isinstance(sw, dict):
        raise InputError("sweep", "missing [sweep] table (model, sampler, samples, seed)")
    schema.check_keys(sw, {*SWEEP_KEYS, "model", "samples"}, "sweep")
    model = sw.get("model", "pump")
    if not isinstance(model, str) or not model:
        raise InputError("sweep.model", f"must be a model name ('pump' or a module), got {model!r}")
    out = schema.read_keys(sw, SWEEP_KEYS, "sweep")
    if out["sampler"] == "grid":
        if "samples" in sw:
            raise InputError("sweep.samples",
                             "the grid sampler takes its size from the factors' levels; remove samples")
        out["samples"] = None
    else:
        out["samples"] = validate.number(sw.get("samples"), "sweep.samples", integer=True, bounds=(1, MAX_DESIGNS))
    return {**out, "model": model}


def _pump_model(model: str, base_dir: Path | None) -> str | None:
    """The pump model ``[sweep] model`` names (a shipped name, or a model file made absolute and read), or None
    (``pump``, or a sweep-model module: read when the sweep runs)."""
    if model == "pump":
        return None
    name, kind = schema.model_reference(model, base_dir, "sweep.model")
    if kind == "module":
        return None
    if Path(name).is_file():
        from lumped.model.model_file import load_model as load_pump_model

        load_pump_model(name, field="sweep.model")     # a bad file (a base cycle, a key) is named here
    return name


def parse_spec(doc: dict, text: str = "", base_dir: Path | None = None) -> SweepSpec:
    """Check a parsed sweep TOML and make its :class:`SweepSpec` (schema: CONTRACT.md, "Sweep file").

    Parameters
    ----------
    doc : dict
        The parsed TOML.
    text : str
        Its text (kept in the output folder).
    base_dir : pathlib.Path, optional
        The folder model files in the spec are relative to.

    Returns
    -------
    SweepSpec
        ``[sweep] model`` is ``pump`` (the base model then comes from a ``model`` or ``valve``
        input), a pump model (a shipped name or a model file: the pump sweep with that base
        model, a fixed ``model`` input) or an importable sweep-model module.

    Raises
    ------
    InputError
        Naming the first bad field, before anything runs.
    """
    schema.table(doc, "sweep file", "a TOML table")
    schema.check_keys(doc, ("sweep", "factors", "fixed"), "")
    sw = _sweep_table(doc)
    fdoc = doc.get("factors")
    if not isinstance(fdoc, dict) or not fdoc:
        raise InputError("factors", "need at least one [factors.NAME] table")
    factors = tuple(_parse_factor(n, d, sw["sampler"])
                    for n, d in schema.flat_table(doc, "factors", "", leaf_keys=FACTOR_KEYS).items())
    fixed_doc = schema.flat_table(doc, "fixed", "a table of name = value")
    fixed = tuple((k, schema.scalar(v, f"fixed.{k}")) for k, v in fixed_doc.items())
    model = sw["model"]
    pump_model = _pump_model(model, base_dir)
    if pump_model is not None:
        if "model" in fixed_doc or any(f.name == "model" for f in factors):
            raise InputError("sweep.model", "names the pump model; the factors and [fixed] then must not")
        fixed, model = fixed + (("model", pump_model),), "pump"
        fixed_doc["model"] = pump_model
    _check_names(factors, fixed_doc)
    spec = SweepSpec(model, sw["sampler"], factors, fixed, sw["samples"], sw["seed"], sw["scramble"], text)
    if spec.sampler == "grid":        # the product of the levels, before any array is made
        validate.size(spec.n_designs, "factors", limit=MAX_DESIGNS, unit="grid designs",
                      how="fewer levels, or the sobol sampler")
    return spec


def _check_names(factors, fixed_doc: dict) -> None:
    """A name swept and fixed, or a factor named like a reserved column, is refused."""
    both = {f.name for f in factors} & set(fixed_doc)
    if both:
        raise InputError(f"fixed.{sorted(both)[0]}", "is also a factor; keep it in one place")
    reserved = {f.name for f in factors} & set(META_COLUMNS)
    if reserved:
        raise InputError(f"factors.{sorted(reserved)[0]}", "is a reserved column name")


def load_spec(path: str | Path) -> SweepSpec:
    """Read and check a sweep TOML file.

    Parameters
    ----------
    path : str or os.PathLike
        The sweep file; model files in it are relative to its folder.

    Returns
    -------
    SweepSpec
    """
    doc, text, folder = schema.read_spec(path)
    return parse_spec(doc, text, base_dir=folder)


def with_base_model(spec: SweepSpec, model: str) -> SweepSpec:
    """The spec with its pump model replaced (``--model``).

    Parameters
    ----------
    spec : SweepSpec
        A pump sweep that does not vary the model.
    model : str
        A shipped pump model or a model file (relative to the working folder).

    Returns
    -------
    SweepSpec
        The pump sweep whose fixed ``model`` is ``model``.
    """
    from lumped.model.model_file import load_model as load_pump_model

    if spec.model != "pump":
        raise InputError("--model", f"the sweep's model is the module {spec.model!r}, not the pump")
    if any(f.name in ("model", "valve") for f in spec.factors):
        raise InputError("--model", "the sweep varies the pump model (a model or valve factor); drop --model")
    name = model if load_pump_model(model, field="--model") and (Path(model).suffix != ".toml") else \
        str(Path(model).resolve())
    fixed = tuple((k, v) for k, v in spec.fixed if k not in ("model", "valve")) + (("model", name),)
    return replace(spec, fixed=fixed)


def spec_to_toml(spec: SweepSpec) -> str:
    """The sweep file of a spec made in Python (kept in the output folder).

    Parameters
    ----------
    spec : SweepSpec

    Returns
    -------
    str
        TOML that :func:`parse_spec` reads back to the same spec.
    """
    import tomli_w

    doc = {"sweep": {"model": spec.model, "sampler": spec.sampler, "seed": spec.seed, "scramble": spec.scramble}}
    if spec.samples is not None:
        doc["sweep"]["samples"] = spec.samples
    doc["factors"] = {}
    for f in spec.factors:
        if f.is_range:
            d = {"low": f.low, "high": f.high, "scale": f.scale, "integer": f.integer}
            if f.levels is not None:
                d["levels"] = f.levels
        else:
            d = {"values": list(f.values)}
        doc["factors"][f.name] = d
    if spec.fixed:
        doc["fixed"] = dict(spec.fixed)
    return tomli_w.dumps(doc)


# --------------------------------------------------------------------------- sampling
def sample_designs(spec: SweepSpec) -> list[dict]:
    """The designs of a sweep, in order.

    Parameters
    ----------
    spec : SweepSpec

    Returns
    -------
    list of dict
        {factor: value} per design (fixed inputs not included): the full factorial of the
        grid, or ``samples`` points of ``scipy.stats.qmc`` (Latin hypercube, Sobol) or of
        ``numpy.random.default_rng`` (random), seeded by ``spec.seed``.
    """
    names = [f.name for f in spec.factors]
    if spec.sampler == "grid":
        return [dict(zip(names, combo)) for combo in itertools.product(*(f.grid() for f in spec.factors))]
    from scipy.stats import qmc

    d, n = len(spec.factors), spec.samples
    if spec.sampler == "lhs":
        u = qmc.LatinHypercube(d=d, seed=spec.seed).random(n)
    elif spec.sampler == "sobol":
        sob = qmc.Sobol(d=d, scramble=spec.scramble, seed=spec.seed)
        m = int(round(math.log2(n)))
        if 2**m == n:
            u = sob.random_base2(m)
        else:
            # Sobol's balance holds for powers of two; other sizes still fill space well
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                u = sob.random(n)
    else:  # random
        u = np.random.default_rng(spec.seed).random((n, d))
    cols = [f.from_unit(u[:, j]) for j, f in enumerate(spec.factors)]
    return [dict(zip(names, row)) for row in zip(*cols)]


def load_model(name: str):
    """The model module of a sweep.

    Parameters
    ----------
    name : str
        ``pump`` (:mod:`studies.sweeps.pump`) or an importable sweep-model module.

    Returns
    -------
    module
        With ``OUTPUTS`` and ``evaluate`` (the protocol of :mod:`studies.sweeps.sweep`).
    """
    if name == "pump":  # the built-in model; anything else is a user's module (the one plugin loader)
        from studies.sweeps import pump as mod

        return mod
    return schema.sweep_model(name, "sweep.model")


def check_spec(spec: SweepSpec, model) -> None:
    """Ask the model to vet every input name and the ends of every range, before anything runs.

    Parameters
    ----------
    spec : SweepSpec
    model : module
        Its sweep model: ``REQUIRED`` inputs must be given, ``check(name, value)`` vets each
        factor's levels or range ends and each fixed input, ``check_inputs(fixed, ranges)`` the
        whole (a pump model file and its keys).
    """
    clash = ({f.name for f in spec.factors} | set(spec.fixed_dict)) & set(model.OUTPUTS)
    if clash:
        raise InputError(sorted(clash)[0], "is an output column of the model, not an input")
    given = {f.name for f in spec.factors} | set(spec.fixed_dict)
    for name in getattr(model, "REQUIRED", ()):
        if name not in given:
            raise InputError("fixed", f"model {spec.model} needs {name!r}: give it as a factor or in [fixed]")
    check = getattr(model, "check", None)
    if check is not None:
        for f in spec.factors:
            for v in (f.values if not f.is_range else (f.low, f.high)):
                _relabel(check, f.name, v, f"factors.{f.name}")
        for k, v in spec.fixed:
            _relabel(check, k, v, f"fixed.{k}")
    check_inputs = getattr(model, "check_inputs", None)
    if check_inputs is not None:
        ranges = {f.name: (list(f.values) if not f.is_range else [f.low, f.high]) for f in spec.factors}
        try:
            check_inputs(spec.fixed_dict, ranges)
        except InputError as exc:
            where = "factors" if exc.field in ranges else "fixed"
            raise InputError(f"{where}.{exc.field}" if "." not in exc.field or exc.field in ranges
                             or exc.field in spec.fixed_dict else exc.field, exc.message) from None


def _relabel(check, name, value, where):
    """``check(name, value)`` with its refusal named ``where`` (a field inside the value, a model file's key,
    stays named)."""
    try:
        check(name, value)
    except InputError as exc:
        inner = "" if exc.field in ("", name, where) else f"{exc.field}: "
        raise InputError(where, inner + exc.message) from None
