"""The one machinery of the study spec files: tables, keys, numbers, ranges, levels and model references.

The sweep file (:mod:`studies.sweeps.sweep_spec`) and the sensitivity and optimisation spec
(:mod:`studies.sweeps.design.spec`) are read through these functions only, so that both check
a value the same way and say the same thing when it is wrong. Each function takes ``where``,
the field's name as the user writes it (``factors.speed_rpm.high``,
``variables."oil.air_content".low``), and raises :class:`~geometry.errors.InputError`
naming it; the command line turns that into exit status 2 and one line on stderr.

A table's plain keys are declared once as :class:`Key` entries (kind, default, bounds) and
read by :func:`read_keys`; the checks themselves are :mod:`geometry.validate`'s.

Example
-------
>>> read_keys({"seed": 3}, {"seed": Key("int", 0, bounds=(0, 2**32 - 1)), "scramble": Key("bool", True)}, "sweep")
{'seed': 3, 'scramble': True}
>>> parse_range({"low": 2.0, "high": 1.0}, "factors.x")
Traceback (most recent call last):
...
geometry.errors.InputError: factors.x.high: must be greater than low (2), got 1
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geometry import validate
from geometry.declare import flatten
from geometry.errors import InputError

#: columns every results table has besides the inputs and the model outputs (names a model may not use)
META_COLUMNS = {"design_id": "int64", "status": "string", "error": "string", "eval_seconds": "float64"}
SCALES = ("linear", "log")
#: a key without a default: :func:`read_keys` refuses its absence
REQUIRED = object()


# --------------------------------------------------------------------------- files and tables
def read_spec(path) -> tuple[dict, str, Path]:
    """Read a spec file as TOML.

    Parameters
    ----------
    path : str or os.PathLike
        The spec file.

    Returns
    -------
    doc : dict
        The parsed TOML.
    text : str
        The file's text (kept in the output folder).
    folder : pathlib.Path
        The file's folder (model files in the spec are relative to it).

    Raises
    ------
    InputError
        Naming ``path``: missing, a folder, binary, or not valid TOML.
    """
    p = validate.path(path, "path")
    text = validate.read_text(p, str(path))
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(str(path), f"not valid TOML ({exc})") from None
    return doc, text, p.parent


def table(value, where: str, expect: str = "a table") -> dict:
    """Check that a spec value is a TOML table.

    Parameters
    ----------
    value : object
        The value read from the spec.
    where : str
        Its field name.
    expect : str
        What the table holds, for the message (``"a table of key path = value"``).

    Returns
    -------
    dict
        ``value`` itself.
    """
    if not isinstance(value, dict):
        raise InputError(where, f"expected {expect}")
    return value


def check_keys(d: dict, allowed, where: str, hint=None) -> None:
    """Refuse the first (alphabetically) key of a table that is not allowed, suggesting the closest.

    Parameters
    ----------
    d : dict
        The table.
    allowed : iterable of str
        The keys it may hold.
    where : str
        The table's field name; the refusal names ``where.key`` (or ``key`` at the top level, ``where = ""``).
    hint : callable, optional
        ``hint(key) -> str`` appended to the message (e.g. " (an optimize key)").
    """
    allowed = sorted(allowed)
    extra = sorted(set(d) - set(allowed))
    if extra:
        k = extra[0]
        near = validate.closest(k, allowed)
        what = "unknown key" if where else "unknown section or key"
        raise InputError(f"{where}.{k}" if where else k,
                         f"{what}{hint(k) if hint else ''}{f' (did you mean {near}?)' if near else ''}; "
                         f"expected some of {', '.join(allowed)}")


def flat_table(doc: dict, name: str, expect: str, leaf_keys=None) -> dict:
    """A section of a spec as dotted keys (``[fixed.valves.spring] stiffness`` -> ``valves.spring.stiffness``).

    Parameters
    ----------
    doc : dict
        The whole spec.
    name : str
        The section (``fixed``, ``variables``, ``derived``, ``factors``); absent means empty.
    expect : str
        What the section holds, for the message.
    leaf_keys : set of str, optional
        Keys that make a table a value rather than a namespace (:func:`geometry.declare.flatten`).

    Returns
    -------
    dict
        {dotted key: value}.
    """
    return flatten(table(doc.get(name, {}), name, expect), leaf_keys=leaf_keys, where=name)


def quoted(name: str) -> str:
    """A key as the user writes it inside a dotted field name (quoted if it holds dots).

    Parameters
    ----------
    name : str
        A key, e.g. ``oil.air_content``.

    Returns
    -------
    str
        ``"oil.air_content"`` (with the quotes) or the plain name.

    Examples
    --------
    >>> quoted("oil.air_content"), quoted("speed_rpm")
    ('"oil.air_content"', 'speed_rpm')
    """
    return f'"{name}"' if "." in name else name


# --------------------------------------------------------------------------- plain keys
@dataclass(frozen=True)
class Key:
    """How one plain key of a spec table is checked, and its default.

    Parameters
    ----------
    kind : str
        ``int``, ``number``, ``bool`` or ``choice``.
    default : object
        Its value when absent; None leaves an absent key out of the result; :data:`REQUIRED`
        refuses its absence.
    bounds : tuple of float, optional
        Inclusive (low, high) of an ``int`` or ``number``.
    positive : bool
        A ``number`` must be above zero.
    minimum : float, optional
        A ``number`` must be at least this.
    below : float, optional
        A ``number`` must be below this (exclusive).
    choices : tuple of str
        The values of a ``choice``.
    """

    kind: str
    default: object = None
    bounds: tuple | None = None
    positive: bool = False
    minimum: float | None = None
    below: float | None = None
    choices: tuple = ()


def read_key(value, key: Key, where: str):
    """Check one value against its :class:`Key`.

    Parameters
    ----------
    value : object
        The value in the spec.
    key : Key
        Its declaration.
    where : str
        Its field name.

    Returns
    -------
    int, float, bool or str
        The value (an int as an int, a number as a float).
    """
    if key.kind == "bool":
        return boolean(value, where)
    if key.kind == "choice":
        return validate.choice(value, where, key.choices)
    x = validate.number(value, where, bounds=key.bounds, positive=key.positive, integer=key.kind == "int")
    if key.minimum is not None and not x >= key.minimum:
        raise InputError(where, f"must be at least {key.minimum:g}, got {x:g}")
    if key.below is not None and not x < key.below:
        raise InputError(where, f"must be below {key.below:g}, got {x:g}")
    return x


def read_keys(d: dict, keys: dict, where: str) -> dict:
    """Read the declared keys of a table (others are left to the caller).

    Parameters
    ----------
    d : dict
        The table.
    keys : dict of str to Key
        The declarations.
    where : str
        The table's field name; each value is named ``where.key``.

    Returns
    -------
    dict
        {key: checked value or default}; a key absent with default None is left out.
    """
    out = {}
    for name, key in keys.items():
        if name in d:
            out[name] = read_key(d[name], key, f"{where}.{name}")
        elif key.default is REQUIRED:
            raise InputError(f"{where}.{name}", "missing")
        elif key.default is not None:
            out[name] = key.default
    return out


def boolean(value, where: str) -> bool:
    """A TOML switch: ``true`` or ``false`` (1, ``"yes"`` or a missing value are not switches).

    Parameters
    ----------
    value : object
        The value in the spec.
    where : str
        Its field name.

    Returns
    -------
    bool
    """
    if not isinstance(value, bool):
        raise InputError(where, f"expected true or false, got {value!r}")
    return value


def number(value, where: str, positive: bool = False) -> float:
    """A finite number (a float), or InputError naming ``where`` (:func:`geometry.validate.number`).

    Parameters
    ----------
    value : object
        The value in the spec.
    where : str
        Its field name.
    positive : bool
        Refuse zero and below.

    Returns
    -------
    float
    """
    return validate.number(value, where, positive=positive)


def integer(value, where: str, low: int, high: int) -> int:
    """An integer in [low, high], or InputError naming ``where``.

    Parameters
    ----------
    value : object
        The value in the spec.
    where : str
        Its field name.
    low, high : int
        Inclusive bounds.

    Returns
    -------
    int
    """
    return validate.number(value, where, bounds=(low, high), integer=True)


# --------------------------------------------------------------------------- values, levels, ranges
def value_kind(v) -> str:
    """The results-table column type of one input value.

    Parameters
    ----------
    v : bool, str, int or float
        A value of a factor, a fixed input or a level.

    Returns
    -------
    str
        ``bool``, ``string``, ``int64`` or ``float64``.
    """
    if isinstance(v, bool):
        return "bool"
    if isinstance(v, str):
        return "string"
    if isinstance(v, int):
        return "int64"
    return "float64"


def scalar(v, where: str):
    """A value a results-table cell can hold: a finite number, a string or a boolean.

    Parameters
    ----------
    v : object
        The value in the spec.
    where : str
        Its field name.

    Returns
    -------
    bool, str, int or float
        ``v`` itself.
    """
    if isinstance(v, (bool, str)):
        return v
    if isinstance(v, (int, float)):
        if not math.isfinite(v):
            raise InputError(where, f"must be a finite number, got {v}")
        return v
    raise InputError(where, f"must be a number, string or boolean, got {type(v).__name__} {v!r}")


def levels(values, where: str, minimum: int = 1) -> tuple:
    """The levels of a categorical input: a list of numbers, of strings or of booleans, none repeated.

    Parameters
    ----------
    values : object
        The list in the spec (``values = [...]``).
    where : str
        Its field name; a bad entry is named ``where[i]``.
    minimum : int
        Fewest levels.

    Returns
    -------
    tuple
        The levels, in order.
    """
    if not isinstance(values, list) or len(values) < minimum:
        raise InputError(where, "must be a non-empty list" if minimum <= 1 else
                         f"must list at least {minimum} values")
    vals = tuple(scalar(v, f"{where}[{i}]") for i, v in enumerate(values))
    kinds = {value_kind(v) for v in vals}
    if len(kinds) > 1 and not kinds <= {"int64", "float64"}:
        raise InputError(where, "must all be numbers, all strings or all booleans")
    if len(set(vals)) != len(vals):
        raise InputError(where, "has repeated values")
    return vals


def parse_range(d: dict, where: str, scales: tuple = SCALES, default_scale: str = "linear") -> tuple:
    """A continuous range ``low``, ``high`` [, ``scale``] of a spec table.

    Parameters
    ----------
    d : dict
        The table (``{low = 1.0, high = 2.0, scale = "log"}``).
    where : str
        Its field name; a bad entry is named ``where.low``, ``where.high`` or ``where.scale``.
    scales : tuple of str
        The scales allowed.
    default_scale : str
        The scale when ``scale`` is absent.

    Returns
    -------
    tuple
        (low, high, scale) with low < high (and low > 0 on a log scale).
    """
    for k in ("low", "high"):
        if k not in d:
            raise InputError(f"{where}.{k}", "missing (a range needs low and high; a list needs values)")
        number(d[k], f"{where}.{k}")
    low, high = float(d["low"]), float(d["high"])
    if not high > low:
        raise InputError(f"{where}.high", f"must be greater than low ({low:g}), got {high:g}")
    scale = validate.choice(d.get("scale", default_scale), f"{where}.scale", scales)
    if scale == "log" and not low > 0:
        raise InputError(f"{where}.low", f"a log scale needs low > 0, got {low:g}")
    return low, high, scale


def from_unit_range(u: np.ndarray, low: float, high: float, scale: str) -> np.ndarray:
    """Map uniform samples onto a range, linearly or logarithmically (stratification is preserved).

    Parameters
    ----------
    u : numpy.ndarray
        Samples in [0, 1].
    low, high : float
        The range, in the input's unit.
    scale : str
        ``linear`` (x = low + u (high - low)) or ``log`` (ln x = ln low + u (ln high - ln low)).

    Returns
    -------
    numpy.ndarray
        The values, in the input's unit.

    Examples
    --------
    >>> from_unit_range(np.array([0.0, 0.5, 1.0]), 1.0, 100.0, "log").round(9).tolist()
    [1.0, 10.0, 100.0]
    """
    if scale == "log":
        return np.exp(np.log(low) + u * (np.log(high) - np.log(low)))
    return low + u * (high - low)


def from_unit_levels(u: np.ndarray, values: tuple) -> list:
    """Map uniform samples onto equally likely levels (``u`` in [k/n, (k+1)/n) gives level k).

    Parameters
    ----------
    u : numpy.ndarray
        Samples in [0, 1].
    values : tuple
        The levels.

    Returns
    -------
    list
        One level per sample.
    """
    idx = np.minimum((u * len(values)).astype(int), len(values) - 1)
    return [values[i] for i in idx]


# --------------------------------------------------------------------------- models
def model_reference(model, base_dir: Path | None, where: str = "model") -> tuple[str, str]:
    """What model a spec names: a shipped pump model, a pump model file, or a sweep-model module.

    Parameters
    ----------
    model : str
        The name in the spec: ``thesis-disc`` (``disc``, ``reed`` for short), a model file
        (``*.toml`` or a path, relative to ``base_dir``) or an importable module.
    base_dir : pathlib.Path, optional
        The spec file's folder.
    where : str
        The field name (``model``, ``sweep.model``, ``--model``).

    Returns
    -------
    name : str
        The shipped name, the model file made absolute, or the module name.
    kind : str
        ``pump`` or ``module``.
    """
    from lumped.model.model_file import SHIPPED

    if not isinstance(model, str) or not model:
        raise InputError(where, f"expected a model name, model file or module, got {model!r}")
    if model in SHIPPED or model in ("disc", "reed"):
        return (f"thesis-{model}" if model in ("disc", "reed") else model), "pump"
    if model.endswith(".toml") or "/" in model or os.sep in model:
        p = Path(model)
        if base_dir is not None and not p.is_absolute():
            p = base_dir / p
        if not p.is_file():
            raise InputError(where, f"{model!r}: no such model file")
        return str(p.resolve()), "pump"
    try:
        sweep_model(model, where)
    except InputError as exc:
        raise InputError(where, f"{model!r} is not a shipped model ({', '.join(SHIPPED)}), a model file or a "
                                f"sweep-model module ({exc.message})") from None
    return model, "module"


def sweep_model(name: str, where: str):
    """Import a sweep-model module and check that it follows the protocol of :mod:`studies.sweeps.sweep`.

    Parameters
    ----------
    name : str
        An importable module name.
    where : str
        The field that named it.

    Returns
    -------
    module
        With ``OUTPUTS`` and ``evaluate``, no output named like a reserved column.
    """
    from lumped.plugins import import_object

    mod = import_object(name, where)
    for attr in ("OUTPUTS", "evaluate"):
        if not hasattr(mod, attr):
            raise InputError(where, f"module {mod.__name__} has no {attr} (a sweep model, see studies/sweeps/sweep.py)")
    clash = set(mod.OUTPUTS) & set(META_COLUMNS)
    if clash:
        raise InputError(where, f"output {sorted(clash)[0]} of {mod.__name__} clashes with a reserved column")
    return mod
