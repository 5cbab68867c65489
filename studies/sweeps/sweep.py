"""Design sweeps: a TOML design-of-experiments run on dask, streamed to a resumable table.

The pieces, each usable alone:

- :func:`load_spec` / :func:`parse_spec`: the sweep file (schema in CONTRACT.md), checked
  field by field (:class:`~geometry.errors.InputError` names the field);
- :func:`sample_designs`: full-factorial grid, Latin hypercube, Sobol or plain random
  samples (``scipy.stats.qmc``, seeded), one dict of inputs per design;
- :func:`run_sweep`: evaluates the designs on a dask cluster (a ``LocalCluster`` by default,
  or an existing scheduler) in batches, writing each finished batch at once as a Parquet
  part file (or appended CSV rows) keyed by ``design_id``. A rerun on the same folder skips
  every design already recorded, so a killed sweep resumes where it stopped. A design
  whose evaluation raises is recorded with ``status = "error"`` and the message; it never
  stops the sweep;
- :func:`main_effects` / :func:`plot_main_effects`: the mean response against each factor.

A *model* is a module with ``OUTPUTS`` (output column -> "float64" | "int64" | "bool" |
"string") and ``evaluate(design: dict) -> dict``; optionally ``check(name, value)`` (raise
InputError for an unknown input or a bad value, before anything runs), ``REQUIRED``
(inputs every design needs) and ``MAIN_RESPONSES`` (what sweep-plot shows by default).
``evaluate`` may return a ``status`` (default ``"ok"``); an exception is recorded as
``"error"``. ``model = "pump"``
is the piston pump (:mod:`studies.sweeps.pump`); any importable module name works.
"""

from __future__ import annotations

import hashlib
import itertools
import math
import os
import shutil
import sys
import time
import tomllib
import uuid
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from geometry import validate
from geometry.declare import flatten
from geometry.errors import InputError

SAMPLERS = ("grid", "lhs", "sobol", "random")
FORMATS = ("parquet", "csv")
#: most designs one sweep may hold (its design table alone is ~100 MB per 1e6 designs)
MAX_DESIGNS = 10_000_000
#: columns every results table has besides the inputs and the model outputs
META_COLUMNS = {"design_id": "int64", "status": "string", "error": "string", "eval_seconds": "float64"}

CONNECT_TIMEOUT = "10s"  # to reach --scheduler
SPEC_FILE = "spec.toml"
DESIGNS_FILE = "designs.parquet"
PARTS_DIR = "parts"


# --------------------------------------------------------------------------- spec


@dataclass(frozen=True)
class Factor:
    """One swept input: a continuous range [low, high] (linear or log) or a list of values."""

    name: str
    low: float | None = None
    high: float | None = None
    scale: str = "linear"
    levels: int | None = None  # grid points of a range (grid sampler only)
    values: tuple | None = None  # explicit levels: categorical, or the grid of a number
    integer: bool = False  # round sampled values of a range to integers

    @property
    def is_range(self) -> bool:
        return self.values is None

    def grid(self) -> list:
        """The grid levels of this factor."""
        if not self.is_range:
            return list(self.values)
        pts = (np.geomspace if self.scale == "log" else np.linspace)(self.low, self.high, self.levels)
        return [int(round(v)) for v in pts] if self.integer else [float(v) for v in pts]

    def from_unit(self, u: np.ndarray) -> list:
        """Map uniform samples u in [0, 1) onto the factor (stratification is preserved)."""
        if not self.is_range:
            idx = np.minimum((u * len(self.values)).astype(int), len(self.values) - 1)
            return [self.values[i] for i in idx]
        if self.scale == "log":
            x = np.exp(np.log(self.low) + u * (np.log(self.high) - np.log(self.low)))
        else:
            x = self.low + u * (self.high - self.low)
        return [int(round(v)) for v in x] if self.integer else [float(v) for v in x]


@dataclass(frozen=True)
class SweepSpec:
    """A parsed sweep file: which model, how to sample, what to vary and what to hold."""

    model: str
    sampler: str
    factors: tuple[Factor, ...]
    fixed: tuple[tuple[str, object], ...] = ()
    samples: int | None = None
    seed: int = 0
    scramble: bool = True
    text: str = field(default="", compare=False, repr=False)  # the TOML, kept in the output folder

    @property
    def fixed_dict(self) -> dict:
        return dict(self.fixed)

    @property
    def digest(self) -> str:
        """A hash of what determines the designs and their results (resume safety)."""
        key = repr((self.model, self.sampler, self.factors, self.fixed, self.samples, self.seed, self.scramble))
        return hashlib.sha256(key.encode()).hexdigest()[:16]

    @property
    def n_designs(self) -> int:
        if self.sampler == "grid":
            return math.prod(len(f.grid()) for f in self.factors)
        return int(self.samples)


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _scalar(v, where: str):
    if isinstance(v, bool) or isinstance(v, str):
        return v
    if isinstance(v, (int, float)):
        if not math.isfinite(v):
            raise InputError(where, f"must be a finite number, got {v}")
        return v
    raise InputError(where, f"must be a number, string or boolean, got {type(v).__name__}")


def _parse_factor(name: str, d, sampler: str) -> Factor:
    where = f"factors.{name}"
    if not isinstance(d, dict):
        raise InputError(where, "must be a table with low/high (a range) or values (a list)")
    known = {"low", "high", "scale", "levels", "values", "integer"}
    extra = set(d) - known
    if extra:
        raise InputError(f"{where}.{sorted(extra)[0]}", f"unknown key; expected some of {', '.join(sorted(known))}")
    if "values" in d:
        if set(d) & {"low", "high", "scale", "levels"}:
            raise InputError(where, "give either values = [...] or low/high, not both")
        vals = d["values"]
        if not isinstance(vals, list) or not vals:
            raise InputError(f"{where}.values", "must be a non-empty list")
        vals = tuple(_scalar(v, f"{where}.values[{i}]") for i, v in enumerate(vals))
        kinds = {_value_kind(v) for v in vals}
        if len(kinds) > 1 and not kinds <= {"int64", "float64"}:
            raise InputError(f"{where}.values", "must all be numbers, all strings or all booleans")
        if len(set(vals)) != len(vals):
            raise InputError(f"{where}.values", "has repeated values")
        return Factor(name, values=vals)
    for k in ("low", "high"):
        if k not in d:
            raise InputError(f"{where}.{k}", "missing (a range needs low and high; a list needs values)")
        if not _is_number(d[k]):
            raise InputError(f"{where}.{k}", f"must be a finite number, got {d[k]!r}")
    low, high = float(d["low"]), float(d["high"])
    if not high > low:
        raise InputError(f"{where}.high", f"must be greater than low ({low}), got {high}")
    scale = d.get("scale", "linear")
    if scale not in ("linear", "log"):
        raise InputError(f"{where}.scale", f"expected 'linear' or 'log', got {scale!r}")
    if scale == "log" and not low > 0:
        raise InputError(f"{where}.low", f"a log scale needs low > 0, got {low}")
    integer = d.get("integer", False)
    if not isinstance(integer, bool):
        raise InputError(f"{where}.integer", f"must be true or false, got {integer!r}")
    levels = d.get("levels")
    if sampler == "grid":
        if levels is None:
            raise InputError(f"{where}.levels", "the grid sampler needs levels (>= 2) for a range")
        validate.number(levels, f"{where}.levels", integer=True, bounds=(2, MAX_DESIGNS))
    elif levels is not None:
        raise InputError(f"{where}.levels", f"only the grid sampler uses levels (sampler is {sampler!r})")
    return Factor(name, low=low, high=high, scale=scale, levels=levels, integer=integer)


_FACTOR_KEYS = {"low", "high", "scale", "levels", "values", "integer"}


def _pump_model_name(model: str, base_dir: Path | None) -> str | None:
    """The pump model a ``[sweep] model`` names (a shipped name, or a model file made absolute), or None."""
    from lumped.model.model_file import SHIPPED

    if model in SHIPPED:
        return model
    if model.endswith(".toml") or "/" in model:
        p = Path(model)
        if base_dir is not None and not p.is_absolute():
            p = base_dir / p
        if not p.is_file():
            raise InputError("sweep.model", f"{model!r}: no such model file")
        from lumped.model.model_file import load_model as load_pump_model

        load_pump_model(str(p), field="sweep.model")     # a bad file (a base cycle, a key) is named here
        return str(p.resolve())
    return None


def parse_spec(doc: dict, text: str = "", base_dir: Path | None = None) -> SweepSpec:
    """A :class:`SweepSpec` from a parsed sweep TOML (schema: CONTRACT.md, "Sweep file").

    ``[sweep] model`` is ``pump`` (the base model then comes from a ``model`` or ``valve``
    input), a pump model (a shipped name or a model file, relative to ``base_dir``: the pump
    sweep with that base model), or an importable sweep-model module.
    """
    if not isinstance(doc, dict):
        raise InputError("sweep file", "must be a TOML table")
    extra = set(doc) - {"sweep", "factors", "fixed"}
    if extra:
        raise InputError(sorted(extra)[0], "unknown section; expected [sweep], [factors.NAME], [fixed]")
    sw = doc.get("sweep")
    if not isinstance(sw, dict):
        raise InputError("sweep", "missing [sweep] table (model, sampler, samples, seed)")
    known = {"model", "sampler", "samples", "seed", "scramble"}
    extra = set(sw) - known
    if extra:
        raise InputError(f"sweep.{sorted(extra)[0]}", f"unknown key; expected some of {', '.join(sorted(known))}")
    model = sw.get("model", "pump")
    if not isinstance(model, str) or not model:
        raise InputError("sweep.model", f"must be a model name ('pump' or a module), got {model!r}")
    sampler = sw.get("sampler")
    if sampler not in SAMPLERS:
        raise InputError("sweep.sampler", f"expected one of {', '.join(SAMPLERS)}, got {sampler!r}")
    samples = sw.get("samples")
    if sampler == "grid":
        if samples is not None:
            raise InputError("sweep.samples", "the grid sampler takes its size from the factors' levels; remove samples")
    else:
        validate.number(samples, "sweep.samples", integer=True, bounds=(1, MAX_DESIGNS))
    seed = sw.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError("sweep.seed", f"must be a non-negative integer, got {seed!r}")
    scramble = sw.get("scramble", True)
    if not isinstance(scramble, bool):
        raise InputError("sweep.scramble", f"must be true or false, got {scramble!r}")

    fdoc = doc.get("factors")
    if not isinstance(fdoc, dict) or not fdoc:
        raise InputError("factors", "need at least one [factors.NAME] table")
    factors = tuple(_parse_factor(n, d, sampler) for n, d in flatten(fdoc, leaf_keys=_FACTOR_KEYS, where="factors").items())
    fixed_doc = doc.get("fixed", {})
    if not isinstance(fixed_doc, dict):
        raise InputError("fixed", "must be a table of name = value")
    fixed_doc = flatten(fixed_doc, where="fixed")
    fixed = tuple((k, _scalar(v, f"fixed.{k}")) for k, v in fixed_doc.items())
    pump_model = _pump_model_name(model, base_dir)
    if pump_model is not None:
        if "model" in fixed_doc or any(f.name == "model" for f in factors):
            raise InputError("sweep.model", "names the pump model; the factors and [fixed] then must not")
        fixed = fixed + (("model", pump_model),)
        fixed_doc["model"] = pump_model
        model = "pump"
    both = {f.name for f in factors} & set(fixed_doc)
    if both:
        raise InputError(f"fixed.{sorted(both)[0]}", "is also a factor; keep it in one place")
    reserved = {f.name for f in factors} & set(META_COLUMNS)
    if reserved:
        raise InputError(f"factors.{sorted(reserved)[0]}", "is a reserved column name")
    spec = SweepSpec(model, sampler, factors, fixed, samples, seed, scramble, text)
    if sampler == "grid":        # the product of the levels, before any array is made
        validate.size(spec.n_designs, "factors", limit=MAX_DESIGNS, unit="grid designs",
                      how="fewer levels, or the sobol sampler")
    return spec


def with_base_model(spec: SweepSpec, model: str) -> SweepSpec:
    """``spec`` with its pump model replaced (``--model``): a pump sweep whose fixed ``model`` is ``model``."""
    from dataclasses import replace as _replace

    from lumped.model.model_file import load_model as load_pump_model

    if spec.model != "pump":
        raise InputError("--model", f"the sweep's model is the module {spec.model!r}, not the pump")
    if any(f.name in ("model", "valve") for f in spec.factors):
        raise InputError("--model", "the sweep varies the pump model (a model or valve factor); drop --model")
    name = model if load_pump_model(model, field="--model") and (Path(model).suffix != ".toml") else \
        str(Path(model).resolve())
    fixed = tuple((k, v) for k, v in spec.fixed if k not in ("model", "valve")) + (("model", name),)
    return _replace(spec, fixed=fixed)


def load_spec(path: str | Path) -> SweepSpec:
    """Read and check a sweep TOML file."""
    p = validate.path(path, "path")
    if not p.exists():
        raise InputError(str(path), "sweep file not found")
    text = validate.read_text(p, str(path))
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(str(path), f"not valid TOML ({exc})") from None
    return parse_spec(doc, text, base_dir=p.parent)


def load_model(name: str):
    """The model module of a sweep (``pump`` or an importable module name)."""
    from lumped.plugins import import_object

    if name == "pump":  # the built-in model; anything else is a user's module (the one plugin loader)
        from studies.sweeps import pump as mod
    else:
        mod = import_object(name, "sweep.model")
    modname = mod.__name__
    for attr in ("OUTPUTS", "evaluate"):
        if not hasattr(mod, attr):
            raise InputError("sweep.model", f"module {modname} has no {attr} (see studies/sweeps/sweep.py)")
    clash = set(mod.OUTPUTS) & set(META_COLUMNS)
    if clash:
        raise InputError("sweep.model", f"output {sorted(clash)[0]} of {modname} clashes with a reserved column")
    return mod


def check_spec(spec: SweepSpec, model) -> None:
    """Ask the model to vet every input name and the ends of every range before running."""
    check = getattr(model, "check", None)
    clash = ({f.name for f in spec.factors} | set(spec.fixed_dict)) & set(model.OUTPUTS)
    if clash:
        raise InputError(sorted(clash)[0], "is an output column of the model, not an input")
    given = {f.name for f in spec.factors} | set(spec.fixed_dict)
    for name in getattr(model, "REQUIRED", ()):
        if name not in given:
            raise InputError("fixed", f"model {spec.model} needs {name!r}: give it as a factor or in [fixed]")
    if check is not None:
        for f in spec.factors:
            vals = f.values if not f.is_range else (f.low, f.high)
            for v in vals:
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
    try:
        check(name, value)
    except InputError as exc:       # a field inside the value (a model file's key) stays named
        inner = "" if exc.field in ("", name, where) else f"{exc.field}: "
        raise InputError(where, inner + exc.message) from None


# --------------------------------------------------------------------------- sampling


def sample_designs(spec: SweepSpec) -> list[dict]:
    """The designs of a sweep, in order: a list of {factor: value} (fixed inputs not included)."""
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


# --------------------------------------------------------------------------- evaluation
def _local_order(todo: list, group: int) -> list:
    """``todo`` ((id, inputs) pairs) reordered so that consecutive designs are near each other (runs of
    ``group`` consecutive ones kept together, placed by their first)."""
    from studies.sweeps.locality import features, locality_order

    runs: dict = {}
    for i, d in todo:                         # design ids i // group belong together (whatever is left of them)
        runs.setdefault(i // group, []).append((i, d))
    runs = list(runs.values())
    X, groups = features([run[0][1] for run in runs])
    return [pair for j in locality_order(X, groups) for pair in runs[j]]




def evaluate_batch(model_name: str, fixed: dict, batch: list[tuple[int, dict]]) -> list[dict]:
    """Evaluate (design_id, inputs) pairs with one model; runs on a dask worker.

    Each row holds the inputs, the model outputs, ``status`` and ``error``; an exception
    becomes ``status = "error"`` with its message, so one bad design never stops a sweep.
    """
    model = load_model(model_name)
    rows = []
    order, slots = range(len(batch)), None
    if accepts_warm(model):
        # each design starts from the nearest one already solved in this batch (lumped.run.warmstart), visited
        # in a nearest-neighbour chain
        from lumped.run.warmstart import WarmStarts, chain_order
        from studies.sweeps.locality import WarmSlot, features

        X, groups = features([inputs for _, inputs in batch])
        order = chain_order(X, groups)
        pool = WarmStarts()
        slots = [WarmSlot(pool, X[i], groups[i]) for i in range(len(batch))]
    for i in order:
        design_id, inputs = batch[i]
        design = {**fixed, **inputs}
        row = {"design_id": int(design_id), **design}
        t0 = time.process_time()
        try:
            out = dict(model.evaluate(design) if slots is None else model.evaluate(design, warm=slots[i]))
            row.update({k: out.get(k) for k in model.OUTPUTS})
            row["status"] = str(out.get("status", "ok"))
            row["error"] = out.get("error")
        except Exception as exc:  # noqa: BLE001 - recorded per design, by design
            row.update({k: None for k in model.OUTPUTS})
            row["status"] = "error"
            row["error"] = f"{type(exc).__name__}: {exc}"
        row["eval_seconds"] = time.process_time() - t0
        rows.append(row)
    return rows


# --------------------------------------------------------------------------- storage


def _arrow_type(kind: str):
    import pyarrow as pa

    return {"float64": pa.float64(), "int64": pa.int64(), "bool": pa.bool_(), "string": pa.string()}[kind]


def _value_kind(v) -> str:
    if isinstance(v, bool):
        return "bool"
    if isinstance(v, str):
        return "string"
    if isinstance(v, int):
        return "int64"
    return "float64"


def table_schema(spec: SweepSpec, model):
    """The arrow schema of a sweep's results: id, inputs (factors then fixed), outputs, status."""
    import pyarrow as pa

    cols = [("design_id", "int64")]
    for f in spec.factors:
        if f.is_range:
            kind = "int64" if f.integer else "float64"
        else:
            kinds = {_value_kind(v) for v in f.values}
            kind = "float64" if kinds == {"int64", "float64"} else kinds.pop()
        cols.append((f.name, kind))
    cols += [(k, _value_kind(v)) for k, v in spec.fixed]
    cols += list(model.OUTPUTS.items())
    cols += [(k, META_COLUMNS[k]) for k in ("status", "error", "eval_seconds")]
    return pa.schema([(n, _arrow_type(k)) for n, k in cols])


class ParquetStore:
    """Results as Parquet part files (one per finished batch), compacted into one file at the end."""

    def __init__(self, folder: Path, schema):
        self.folder, self.schema = folder, schema
        self.final = folder / "results.parquet"
        self.parts = folder / PARTS_DIR

    def _tables(self):
        import pyarrow.parquet as pq

        files = sorted(self.parts.glob("*.parquet")) if self.parts.is_dir() else []
        if self.final.is_file():
            files = [self.final, *files]
        return [pq.read_table(f, schema=self.schema) for f in files]

    def read(self):
        """All rows recorded so far (a pandas DataFrame, one row per design_id, sorted)."""
        import pyarrow as pa

        tables = self._tables()
        df = (pa.concat_tables(tables) if tables else self.schema.empty_table()).to_pandas()
        return df.drop_duplicates("design_id").sort_values("design_id").reset_index(drop=True)

    def append(self, rows: list[dict]) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.parts.mkdir(exist_ok=True)
        table = pa.Table.from_pylist(rows, schema=self.schema)
        name = f"part-{time.time_ns():020d}-{uuid.uuid4().hex[:8]}"
        # hidden while written: a kill leaves at most a dot-file, which pyarrow's folder reading
        # (pd.read_parquet("parts")) skips, and the rename makes the part appear whole
        tmp = self.parts / f".{name}.tmp"
        pq.write_table(table, tmp)
        os.replace(tmp, self.parts / f"{name}.parquet")

    def finish(self) -> Path:
        """Merge the parts into ``results.parquet`` (atomically) and remove them."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        df = self.read()
        tmp = self.folder / "results.parquet.tmp"
        pq.write_table(pa.Table.from_pandas(df, schema=self.schema, preserve_index=False), tmp)
        os.replace(tmp, self.final)
        if self.parts.is_dir():
            shutil.rmtree(self.parts)
        return self.final

    def clear(self) -> None:
        self.final.unlink(missing_ok=True)
        if self.parts.is_dir():
            shutil.rmtree(self.parts)
        for tmp in self.folder.glob("*.tmp"):
            tmp.unlink()


class CsvStore:
    """Results appended to ``results.csv`` row by row (flushed after each batch)."""

    def __init__(self, folder: Path, schema):
        self.folder, self.schema = folder, schema
        self.final = folder / "results.csv"

    def _repair(self) -> None:
        # a kill during a write can leave a partial last line: cut it off
        if not self.final.is_file():
            return
        data = self.final.read_bytes()
        if data and not data.endswith(b"\n"):
            with open(self.final, "r+b") as fh:
                fh.truncate(data.rfind(b"\n") + 1)

    def read(self):
        import pandas as pd

        self._repair()
        names = self.schema.names
        if not self.final.is_file() or self.final.stat().st_size == 0:
            return pd.DataFrame({n: pd.Series(dtype=object) for n in names})
        dtypes = {}
        for fld in self.schema:
            dtypes[fld.name] = {"int64": "Int64", "double": "float64", "bool": "boolean"}.get(str(fld.type), "string")
        df = pd.read_csv(self.final, dtype=dtypes, keep_default_na=False, na_values=[""])
        return df.drop_duplicates("design_id").sort_values("design_id").reset_index(drop=True)

    def append(self, rows: list[dict]) -> None:
        import csv

        self._repair()
        new = not self.final.is_file() or self.final.stat().st_size == 0
        with open(self.final, "a", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=self.schema.names, extrasaction="ignore")
            if new:
                w.writeheader()
            w.writerows([{k: ("" if v is None else v) for k, v in r.items()} for r in rows])
            fh.flush()
            os.fsync(fh.fileno())

    def finish(self) -> Path:
        return self.final

    def clear(self) -> None:
        self.final.unlink(missing_ok=True)


def open_store(folder: Path, spec: SweepSpec, model, fmt: str):
    """The results store of a sweep folder in the given format."""
    if fmt not in FORMATS:
        raise InputError("--format", f"expected one of {', '.join(FORMATS)}, got {fmt!r}")
    schema = table_schema(spec, model)
    return (ParquetStore if fmt == "parquet" else CsvStore)(folder, schema)


def read_results(folder: str | Path):
    """The results table of a sweep folder (finished or not) as a pandas DataFrame, and its spec."""
    folder = Path(folder)
    if not (folder / SPEC_FILE).is_file():
        raise InputError(str(folder), f"not a sweep folder (no {SPEC_FILE})")
    spec = load_spec(folder / SPEC_FILE)
    model = load_model(spec.model)
    fmt = "csv" if (folder / "results.csv").is_file() else "parquet"
    return open_store(folder, spec, model, fmt).read(), spec


# --------------------------------------------------------------------------- running


def default_workers() -> int:
    """One single-threaded worker process per core (the simulations are CPU bound)."""
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)


#: most designs per dask task (a task of pump designs then takes a second or two: a kill loses little work)
MAX_BATCH = 400


def _default_batch(n_todo: int, n_workers: int, warm: bool = False) -> int:
    # ~20 tasks per worker balances the load; a model that warm-starts a design from its batch's
    # neighbours (:func:`accepts_warm`) gets ~8 larger tasks per worker, so that most designs have a
    # close neighbour in their batch and the per-task costs (scheduling, a Parquet part) stay small
    if warm:
        return max(1, min(MAX_BATCH, math.ceil(n_todo / (8 * n_workers))))
    return max(1, min(50, math.ceil(n_todo / (20 * n_workers))))


def accepts_warm(model) -> bool:
    """Whether a sweep model's ``evaluate`` takes ``warm`` (a :class:`studies.sweeps.locality.WarmSlot`)."""
    import inspect

    try:
        return "warm" in inspect.signature(model.evaluate).parameters
    except (TypeError, ValueError):
        return False


def _prepare_folder(out: Path, spec: SweepSpec, fmt: str, force: bool, digest: str | None = None):
    """Create the sweep folder, or check that an existing one holds this very sweep (``digest``: the spec's,
    or that of the spec and its given designs)."""
    from studies.outputs import MARKER, prepare_output_dir

    digest = digest or spec.digest
    stamp = out / ".sweep-digest"
    if out.exists() and (out / MARKER).exists() and stamp.is_file():
        old = stamp.read_text().split()
        computed = any((out / name).exists() for name in ("results.csv", "results.parquet", PARTS_DIR))
        if old[0] != digest and not force and computed:   # nothing computed yet: the new spec replaces it
            raise InputError(
                "--out", f"{out} holds a different sweep (its {SPEC_FILE} differs); choose another folder or --force"
            )
        if len(old) > 1 and old[1] != fmt and not force and computed:
            raise InputError("--format", f"{out} holds a {old[1]} sweep; resume it with --format {old[1]}")
        if old[0] != digest or (len(old) > 1 and old[1] != fmt):
            for name in ("results.csv", "results.parquet", DESIGNS_FILE, SPEC_FILE):
                (out / name).unlink(missing_ok=True)
            if (out / PARTS_DIR).is_dir():
                shutil.rmtree(out / PARTS_DIR)
    prepare_output_dir(out, "--out", force, kind="sweep")
    stamp.write_text(f"{digest} {fmt}\n")
    (out / SPEC_FILE).write_text(spec.text or _spec_to_toml(spec))


def _spec_to_toml(spec: SweepSpec) -> str:
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


def _designs(out: Path, spec: SweepSpec, given: list[dict] | None = None) -> list[dict]:
    """The designs, sampled once (or ``given``) and kept in the folder so a resume sees the very same list."""
    import pandas as pd

    path = out / DESIGNS_FILE
    if path.is_file():
        df = pd.read_parquet(path)
        return [{k: (v.item() if hasattr(v, "item") else v) for k, v in r.items()} for r in df.to_dict("records")]
    designs = sample_designs(spec) if given is None else [dict(d) for d in given]
    tmp = path.with_suffix(".tmp")
    pd.DataFrame(designs, columns=[f.name for f in spec.factors]).to_parquet(tmp, index=False)
    os.replace(tmp, path)
    return designs


def designs_digest(spec: SweepSpec, designs: list[dict]) -> str:
    """A hash of a spec and an explicit list of designs (resume safety of run_sweep(designs=...))."""
    h = hashlib.sha256(spec.digest.encode())
    for d in designs:
        h.update(repr(sorted(d.items())).encode())
    return h.hexdigest()[:16]


def check_run_arguments(spec, out, *, fmt="parquet", scheduler=None, n_workers=None, batch_size=None,
                        force=False, retry_failed=False, progress=True, designs=None) -> None:
    """InputError naming the first bad argument of :func:`run_sweep` (types and values), before any work."""
    if not isinstance(spec, SweepSpec):
        raise InputError("spec", f"expected a SweepSpec (studies.sweeps.load_spec(path)), got {type(spec).__name__}")
    validate.path(out, "out")
    validate.choice(fmt, "fmt", FORMATS)
    if scheduler is not None:
        validate.address(scheduler, "scheduler")
    if n_workers is not None:
        validate.number(n_workers, "n_workers", integer=True, bounds=(1, 1024))
    if batch_size is not None:
        validate.number(batch_size, "batch_size", integer=True, bounds=(1, 1_000_000))
    for name, v in (("force", force), ("retry_failed", retry_failed), ("progress", progress)):
        validate.boolean(v, name)
    if designs is not None:
        if not isinstance(designs, (list, tuple)) or not all(isinstance(d, dict) for d in designs):
            raise InputError("designs", "expected a list of {factor: value} dicts")
        validate.size(max(1, len(designs)), "designs", limit=MAX_DESIGNS, unit="designs")


def run_sweep(
    spec: SweepSpec,
    out: str | Path,
    *,
    fmt: str = "parquet",
    scheduler: str | None = None,
    client=None,
    n_workers: int | None = None,
    batch_size: int | None = None,
    force: bool = False,
    retry_failed: bool = False,
    progress: bool = True,
    designs: list[dict] | None = None,
    desc: str = "sweep",
    group: int = 1,
) -> dict:
    """Run (or resume) a sweep into folder ``out``; return a summary dict.

    ``client``: an existing ``distributed.Client`` to use; else ``scheduler`` (an address)
    to connect to; else a ``LocalCluster`` of ``n_workers`` single-threaded processes is
    started and closed again.

    ``designs``: run these designs ({factor: value}, in order) instead of sampling the spec's
    (the samplers of ``valvelab sensitivity`` and ``optimize``); the folder's digest then covers
    them, so a rerun resumes only with the very same list. ``desc``: the progress bar's label.
    ``group``: runs of that many consecutive designs belong together (a design's operating points) and
    stay together in a batch.

    A model whose ``evaluate`` takes ``warm`` (:func:`accepts_warm`, the pump) has its designs sent in
    batches of near designs (:func:`studies.sweeps.locality.locality_order`) and each design started
    from the nearest one solved before it in its batch (:func:`evaluate_batch`).
    """
    check_run_arguments(spec, out, fmt=fmt, scheduler=scheduler, n_workers=n_workers, batch_size=batch_size,
                        force=force, retry_failed=retry_failed, progress=progress, designs=designs)
    model = load_model(spec.model)
    check_spec(spec, model)
    out = Path(out)
    digest = None if designs is None else designs_digest(spec, designs)
    _prepare_folder(out, spec, fmt, force, digest)
    store = open_store(out, spec, model, fmt)
    designs = _designs(out, spec, designs)
    t_start = time.perf_counter()

    done = store.read()
    keep = done if not retry_failed else done[done["status"] != "error"]
    finished = set(int(i) for i in keep["design_id"])
    todo = [(i, d) for i, d in enumerate(designs) if i not in finished]
    warm = accepts_warm(model)
    if warm and len(todo) > 1:
        todo = _local_order(todo, max(1, group))
    summary = {
        "model": spec.model, "sampler": spec.sampler, "designs": len(designs), "out": str(out),
        "format": fmt, "skipped": len(designs) - len(todo), "computed": 0,
    }

    own_cluster = None
    if not todo:      # a rerun with every design recorded: no cluster, no rate to measure
        summary["workers"] = 0
        if progress:
            print(f"{desc}: all {len(designs)} designs are already recorded in {out}; nothing to compute",
                  file=sys.stderr, flush=True)
    else:
        from distributed import Client, LocalCluster, as_completed

        if client is None:
            if scheduler:
                try:
                    client = Client(scheduler, timeout=CONNECT_TIMEOUT)
                except OSError as exc:
                    raise InputError("--scheduler", f"cannot connect to {scheduler} ({exc})") from None
            else:
                n_workers = n_workers or default_workers()
                own_cluster = LocalCluster(
                    n_workers=n_workers, threads_per_worker=1, processes=True,
                    dashboard_address=None, silence_logs=40,
                )
                client = Client(own_cluster)
        workers = max(1, len(client.scheduler_info().get("workers", {})) or (n_workers or 1))
        summary["workers"] = workers
        bs = batch_size or _default_batch(len(todo), workers, warm) * max(1, group)
        batches = [todo[i : i + bs] for i in range(0, len(todo), bs)]
        fixed = spec.fixed_dict
        from tqdm import tqdm

        bar = tqdm(total=len(designs), initial=summary["skipped"], desc=desc, unit="design",
                   file=sys.stderr, disable=not progress, smoothing=0.05)
        try:
            futures = client.map(evaluate_batch, [spec.model] * len(batches), [fixed] * len(batches), batches,
                                 pure=False)
            for fut in as_completed(futures):
                rows = fut.result()
                store.append(rows)
                summary["computed"] += len(rows)
                bar.update(len(rows))
                fut.release()
        finally:
            bar.close()
            if own_cluster is not None:
                client.close()
                own_cluster.close()
    final = store.read()
    summary["failed"] = int((final["status"] == "error").sum())
    summary["status_counts"] = {str(k): int(v) for k, v in final["status"].value_counts().items()}
    if len(final) >= len(designs):
        summary["results"] = str(store.finish())
        summary["complete"] = True
    else:
        summary["complete"] = False
        summary["results"] = str(store.final)
    wall = time.perf_counter() - t_start
    summary["wall_seconds"] = wall
    # null when nothing was computed (a resume of a finished sweep): there is no rate to report
    summary["designs_per_hour"] = summary["computed"] / wall * 3600.0 if summary["computed"] else None
    return summary


# --------------------------------------------------------------------------- main effects


def main_effects(df, spec: SweepSpec, responses: list[str], bins: int = 8) -> dict:
    """Mean of each response against each factor (its levels, or quantile bins of a range).

    Returns {response: {factor: {"x": [...], "mean": [...], "count": [...], "span": max-min}}},
    from the designs with status "ok" only.
    """
    import pandas as pd

    ok = df[df["status"] == "ok"]
    effects: dict = {}
    for r in responses:
        y = pd.to_numeric(ok[r], errors="coerce")
        per: dict = {}
        for f in spec.factors:
            x = ok[f.name]
            if not f.is_range or spec.sampler == "grid" or x.nunique() <= bins:
                key = x
            else:
                key = pd.qcut(x.astype(float), q=bins, duplicates="drop")
            g = pd.DataFrame({"x": x, "y": y, "k": key}).dropna(subset=["y"]).groupby("k", observed=True)
            xs = g["x"].first() if (not f.is_range) else g["x"].mean()
            means = g["y"].mean()
            per[f.name] = {
                "x": [v.item() if hasattr(v, "item") else v for v in xs.tolist()],
                "mean": [float(v) for v in means.tolist()],
                "count": [int(v) for v in g["y"].count().tolist()],
                "span": float(means.max() - means.min()) if len(means) else 0.0,
            }
        effects[r] = per
    return effects


def plot_main_effects(effects: dict, path: Path, title: str = "") -> Path:
    """A grid of main-effect plots (rows: responses, columns: factors) saved as PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    responses = list(effects)
    factors = list(effects[responses[0]]) if responses else []
    fig, axes = plt.subplots(len(responses), len(factors), squeeze=False,
                             figsize=(2.8 * len(factors) + 0.8, 2.4 * len(responses) + 0.6), sharey="row")
    for i, r in enumerate(responses):
        for j, f in enumerate(factors):
            ax, e = axes[i][j], effects[r][f]
            xs = e["x"]
            if xs and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in xs):
                ax.plot(xs, e["mean"], "o-")
            else:
                ax.plot(range(len(xs)), e["mean"], "o-")
                ax.set_xticks(range(len(xs)), [str(v) for v in xs])
            if i == len(responses) - 1:
                ax.set_xlabel(f)
            if j == 0:
                ax.set_ylabel(r)
            ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    tmp = path.with_name(path.name + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)
    return path
