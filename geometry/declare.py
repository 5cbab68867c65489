"""Parameter declarations: each model parameter is declared once, as a dataclass field.

A field made with :func:`param` carries everything the rest of valvelab needs to know
about that parameter: its key in an input file (``"spring.stiffness"``), its SI unit,
where its value comes from, the physically plausible range, and whether the numerical
model reads it from the flat parameter array. From these declarations the input-file
reader (:func:`read_table`), the validation (:func:`check_value`), the flat array
layout (``lumped.solver.layout``), the model printout (``valvelab model show``) and the sweep
variables (key paths) are all derived, so adding a parameter is one declaration plus
its value in a data file.

This module lives in the bottom layer (``geometry``) because every layer declares
parameters and reports bad ones with :class:`~geometry.errors.InputError`.

Example
-------
>>> from dataclasses import dataclass
>>> @dataclass(frozen=True)
... class Spring:
...     stiffness: float = param("stiffness", "N/m", "measured", bounds=(1e-3, 1e9), positive=True)
>>> Spring(**read_table(Spring, {"stiffness": 213}, "spring"))
Spring(stiffness=213.0)
>>> read_table(Spring, {"stiffnes": 213}, "spring")
Traceback (most recent call last):
...
geometry.errors.InputError: spring.stiffnes: unknown key (did you mean stiffness?); expected one of stiffness
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import MISSING, dataclass
from typing import Any

from . import validate as _v
from .errors import InputError

#: metadata key under which a field's :class:`Spec` is stored
META = "valvelab"


@dataclass(frozen=True)
class Spec:
    """What a declared parameter is: file key, unit, source, plausible range, role.

    ``key``: dotted path inside its component's table of an input file (None: not read
    from files, e.g. a quantity an effect sets); ``unit``: SI unit ("-" for none);
    ``source``: where the value comes from (thesis table or equation, datasheet, a
    documented assumption); ``bounds``: inclusive plausible range (None: any finite
    number); ``positive``: strictly greater than zero; ``packed``: the numerical model
    reads it from the flat parameter array; ``choices``: allowed strings; ``effect``:
    the candidate effect that sets it (None for a baseline parameter); ``doc``: one line;
    ``typical``: the range real designs fall in (inclusive; None: within :data:`TYPICAL_FACTOR` of the
    shipped value): a value inside ``bounds`` but outside it is accepted with a warning (:func:`atypical`).
    """

    key: str | None
    unit: str
    source: str
    bounds: tuple[float, float] | None = None
    positive: bool = False
    packed: bool = False
    choices: tuple[str, ...] | None = None
    effect: str | None = None
    doc: str = ""
    optional: bool = False
    typical: tuple[float, float] | None = None


def param(key: str | None, unit: str, source: str, *, default: Any = MISSING, **spec):
    """A dataclass field declaring one model parameter.

    Parameters
    ----------
    key : str or None
        Its dotted key in its component's table of an input file (None: not read from files).
    unit : str
        SI unit ("-" for none).
    source : str
        Where its value comes from.
    default
        The field's default (left out: required; None for an ``optional`` one).
    **spec
        The rest of its :class:`Spec`: ``bounds`` (inclusive plausible range), ``positive``, ``packed`` (the
        numerical model reads it from the flat array), ``choices``, ``effect``, ``doc``, ``optional`` (the key
        may be left out of a file; the component then derives the value and the field holds None).

    Returns
    -------
    dataclasses.Field
        The field, its Spec in ``metadata["valvelab"]``.
    """
    unknown = set(spec) - {f.name for f in dataclasses.fields(Spec)} or {"key", "unit", "source"} & set(spec)
    if unknown:
        raise TypeError(f"param() got an unexpected keyword argument {sorted(unknown)[0]!r}")
    bounds, choices, typical = spec.pop("bounds", None), spec.pop("choices", None), spec.pop("typical", None)
    if bounds is not None:
        bounds = (float(bounds[0]), float(bounds[1]))
    if typical is not None:
        typical = (float(typical[0]), float(typical[1]))
    made = Spec(key=key, unit=unit, source=source, bounds=bounds, choices=None if choices is None else tuple(choices),
                typical=typical, **spec)
    if made.optional and default is MISSING:
        default = None
    return dataclasses.field(default=default, metadata={META: made})


def specs(cls_or_obj) -> list[tuple[str, Spec]]:
    """(field name, Spec) of every declared field of a dataclass, in declaration order."""
    return list(_specs(cls_or_obj if isinstance(cls_or_obj, type) else type(cls_or_obj)))


@functools.lru_cache(maxsize=None)
def _specs(cls: type) -> tuple[tuple[str, Spec], ...]:
    # a class's fields never change: read once (the pump driver packs a model per simulation)
    return tuple((f.name, f.metadata[META]) for f in dataclasses.fields(cls) if META in f.metadata)


def spec_of(cls_or_obj, name: str) -> Spec:
    """The Spec of field ``name``."""
    for f in dataclasses.fields(cls_or_obj):
        if f.name == name and META in f.metadata:
            return f.metadata[META]
    raise KeyError(name)


def field_for_key(cls_or_obj, key: str) -> str | None:
    """The field name declared with file key ``key`` (None if there is none)."""
    for name, s in specs(cls_or_obj):
        if s.key == key:
            return name
    return None


def file_keys(cls_or_obj) -> list[str]:
    """Every file key a component declares, in declaration order."""
    return [s.key for _, s in specs(cls_or_obj) if s.key is not None]


# --------------------------------------------------------------------------- values
def _kind_of(cls, name: str) -> str:
    """'bool', 'str', 'int' or 'float' from the field's annotation."""
    ann = {f.name: f.type for f in dataclasses.fields(cls)}[name]
    ann = ann if isinstance(ann, str) else getattr(ann, "__name__", str(ann))
    for k in ("bool", "str", "int"):
        if ann.replace(" ", "").split("|")[0] == k:
            return k
    return "float"


def describe_range(spec: Spec) -> str:
    """'a number in N/m from 1 to 1e+08' style text for messages."""
    return _v.describe(spec.unit, spec.bounds, spec.positive)


def check_value(value, spec: Spec, where: str, kind: str = "float"):
    """``value`` converted to its declared type (``kind``), or InputError naming ``where``."""
    if kind == "bool":
        if not isinstance(value, bool):
            raise InputError(where, f"expected true or false, got {value!r}")
        return value
    if kind == "str":
        if not isinstance(value, str):
            raise InputError(where, f"expected a string, got {value!r}")
        if spec.choices is not None:
            _v.choice(value, where, spec.choices)
        return value
    return _v.number(value, where, unit=spec.unit, bounds=spec.bounds, positive=spec.positive,
                     integer=kind == "int")


#: a declared number without a ``typical`` range is atypical more than this factor away from its shipped value
TYPICAL_FACTOR = 100.0


def atypical(obj, where: str, reference=None) -> list[tuple[str, str]]:
    """The declared numbers of ``obj`` outside the range real designs fall in: accepted (they are inside the
    declared ``bounds``) but likely a unit slip or a typo, so each is reported for a warning.

    A field's range is its ``typical`` declaration, else a factor of :data:`TYPICAL_FACTOR` either side of the
    same field of ``reference`` (the shipped component of its kind; nothing without one, or where it is 0).

    Parameters
    ----------
    obj : dataclass instance
        A component (pump, oil, a valve, a reed).
    where : str
        Its key prefix in messages (``valves.delivery``).
    reference : dataclass instance, optional
        The shipped component of the same class.

    Returns
    -------
    list of (str, str)
        (the field's key path, a message with the value, its unit and the range).

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Oil:
    ...     density: float = param("density", "kg/m^3", "Table 5.1", bounds=(100, 3000), typical=(600, 1300))
    >>> atypical(Oil(150.0), "oil")
    [('oil.density', '150 kg/m^3 is outside the 600-1300 kg/m^3 of real designs (a unit slip?)')]
    """
    out = []
    for name, s in specs(obj):
        v = getattr(obj, name)
        if s.key is None or isinstance(v, bool) or not isinstance(v, (int, float)):
            continue
        u = "" if s.unit == "-" else f" {s.unit}"
        lo_hi = s.typical
        ref = getattr(reference, name, None) if reference is not None and type(reference) is type(obj) else None
        if lo_hi is None and isinstance(ref, (int, float)) and not isinstance(ref, bool) and ref > 0 and v > 0:
            lo_hi = (ref / TYPICAL_FACTOR, ref * TYPICAL_FACTOR)
            if lo_hi[0] <= v <= lo_hi[1]:
                continue
            out.append((f"{where}.{s.key}", f"{v:g}{u} is {max(v / ref, ref / v):.3g} times the shipped "
                                            f"{ref:g}{u} (a unit slip?)"))
            continue
        if lo_hi is not None and not lo_hi[0] <= v <= lo_hi[1]:
            out.append((f"{where}.{s.key}", f"{v:g}{u} is outside the {lo_hi[0]:g}-{lo_hi[1]:g}{u} of "
                                            "real designs (a unit slip?)"))
    return out


def check_field(obj_or_cls, name: str, value, where: str):
    """``value`` checked against field ``name``'s declaration (InputError naming ``where``)."""
    cls = obj_or_cls if isinstance(obj_or_cls, type) else type(obj_or_cls)
    spec = spec_of(cls, name)
    if value is None and spec.optional:
        return None
    return check_value(value, spec, where, _kind_of(cls, name))


# --------------------------------------------------------------------------- tables
def flatten(table: dict, prefix: str = "", leaf_keys: frozenset | set | None = None,
            where: str | None = None) -> dict:
    """Nested TOML tables to dotted keys: {"spring": {"stiffness": 1}} -> {"spring.stiffness": 1}.

    With ``leaf_keys``, a table holding any of them (or empty) is a value, not a namespace:
    ``[factors.inlet.f1] low = 0.5`` stays ``{"inlet.f1": {"low": 0.5}}``.

    With ``where`` (the table's name in messages), one key spelt twice, as a quoted dotted
    name and as nested keys or tables (``"a.b" = 1`` and ``a.b = 2``), is an InputError naming
    both spellings instead of one value silently replacing the other.

    >>> flatten({"a.b": 1, "a": {"b": 2}}, where="variables")
    Traceback (most recent call last):
    ...
    geometry.errors.InputError: variables."a.b": is the same key as variables.a.b (a quoted dotted name and nested keys); keep one
    """
    out: dict = {}
    spelt: dict = {}

    def walk(t: dict, parts: tuple):
        for k, v in t.items():
            here = parts + (str(k),)
            if isinstance(v, dict) and (leaf_keys is None or (v and not set(v) & set(leaf_keys))):
                walk(v, here)
                continue
            key = prefix + ".".join(here)
            spelling = ".".join(f'"{p}"' if "." in p else p for p in here)
            if where is not None and key in spelt:
                first, second = sorted((spelt[key], spelling), key=lambda x: -x.count('"'))
                raise InputError(f"{where}.{first}", f"is the same key as {where}.{second} (a quoted dotted name "
                                                     "and nested keys); keep one")
            spelt[key] = spelling
            out[key] = v

    walk(table, ())
    return out


def nest(flat: dict) -> dict:
    """Inverse of :func:`flatten`."""
    out: dict = {}
    for k, v in flat.items():
        parts = k.split(".")
        d = out
        for p in parts[:-1]:
            d = d.setdefault(p, {})
        d[parts[-1]] = v
    return out


def read_table(cls, table: dict, where: str, *, extra_keys=(), require=False) -> dict:
    """Field values of dataclass ``cls`` from a (nested) input table, each checked.

    Returns {field name: value} for the declared keys present in ``table`` (all of
    them with ``require``, except optional ones). A key that is not declared (and not
    in ``extra_keys``) is an error naming it: a misspelt key is never ignored.
    """
    if not isinstance(table, dict):
        raise InputError(where, "expected a table")
    flat = flatten(table)
    keys = {s.key: n for n, s in specs(cls) if s.key is not None}
    extra = set(extra_keys)
    out = {}
    for k, v in flat.items():
        top = k.split(".")[0]
        if k in keys:
            out[keys[k]] = check_field(cls, keys[k], v, f"{where}.{k}")
        elif k in extra or top in extra:
            continue
        else:
            _v.keys({k: v}, sorted(keys) + sorted(extra), where)
    if require:
        for k, n in keys.items():
            if n not in out and not spec_of(cls, n).optional:
                raise InputError(f"{where}.{k}", f"missing; expected {describe_range(spec_of(cls, n))}")
    return out


def to_table(obj) -> dict:
    """{file key: value} of every declared key of a component (None values left out)."""
    out = {}
    for name, s in specs(obj):
        if s.key is None:
            continue
        v = getattr(obj, name)
        if v is not None:
            out[s.key] = v
    return out
