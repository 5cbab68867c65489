"""Model files: a user's pump, oil and valves in one TOML file (CONTRACT.md, "Model file").

Sections (SI units): ``[pump]``, ``[oil]``, ``[valves]`` (keys shared by both valves)
with ``[valves.inlet]`` and ``[valves.delivery]`` (each ``kind = "disc"`` or ``"reed"``
plus that kind's keys), optional ``[circuit]``, ``[operating]`` (a default speed and
load pressure) and ``[effects.NAME]`` / ``[effects.NAME.TARGET]`` (candidate effects
switched on, parameters defaulting to their priors). A key left out takes its value
from ``base = "NAME|FILE"`` when the file names one, else from the shipped thesis
model: ``thesis-disc`` for the pump, oil and circuit, and the thesis model of the
valve's kind for each valve. Every key is read through its declaration
(:mod:`geometry.declare`): a wrong type, a value outside its plausible range or an
unknown key is an :class:`~geometry.errors.InputError` naming the key path
(``valves.delivery.spring.stiffness``).

Shipped models: :data:`SHIPPED` (``lumped/data/models/``). :func:`load_model` reads a
name or a file, :func:`model_table` gives the complete resolved table of a model,
:func:`to_toml` prints it with units and sources (``valvelab model show``),
:func:`with_values` changes any key by its path (sweeps, sensitivity, optimisation) and
:func:`describe` gives the derived quantities of ``valvelab model check``.
"""

from __future__ import annotations

import copy
import math
import threading
import tomllib
from dataclasses import replace
from functools import lru_cache
from pathlib import Path

import tomli_w

from geometry.data_files import package_names, package_toml
from geometry.declare import check_field, flatten, specs
from geometry.errors import InputError
from geometry.validate import read_toml
from lumped.model import effect_library
from lumped.model import uncertainty as _uncertainty
from lumped.model.effect_library import LIBRARY
from lumped.model.effects import Applied
from lumped.model.pump_model import POSITIONS, Operating, PumpModel
from lumped.fluid.oil import Oil
from lumped.model.pump import Circuit, Pump
from lumped.valves import fluid_forms as _fluid_forms
from lumped.valves.kind import KINDS, kind_of

#: shipped model name -> file in lumped/data/models (every TOML file there)
SHIPPED = {name: f"{name}.toml" for name in package_names("lumped", "models")}
#: valve kind -> shipped model whose valves give that kind's defaults, where it is not the kind's
#: own ``default_model`` (lumped.valves.kind.ValveKind)
KIND_DEFAULTS: dict = {}


def kind_default_model(kind: str) -> str:
    """The shipped model whose valves give a kind's defaults."""
    return KIND_DEFAULTS.get(kind) or KINDS[kind].default_model
#: the model whose pump, oil and circuit are the defaults of every model file
DEFAULT_BASE = "thesis-disc"
TOP_KEYS = ("name", "base", "description", "pump", "oil", "circuit", "operating", "valves", "effects",
            "uncertainty")
COMPONENTS = {"pump": Pump, "oil": Oil, "circuit": Circuit, "operating": Operating}


# --------------------------------------------------------------------------- reading
def load_model(spec, field: str | None = None) -> PumpModel:
    """A model from a shipped name (``thesis-disc``, ``thesis-reed``), a model file, or a PumpModel.

    The legacy valve names ``disc`` and ``reed`` stand for the thesis models.

    Parameters
    ----------
    spec : str, Path or PumpModel
        A shipped name, a model TOML file (CONTRACT.md, "Model file"), or a model (returned as is).
    field : str, optional
        The name a bad ``spec`` is reported under (InputError, exit 2 at the command line; the command line
        gives its flag, ``--model``); default ``spec``.

    Returns
    -------
    PumpModel
        Frozen and validated, SI units.

    References
    ----------
    Knutson (2016), Table 5.1 (pump and oil), Table 2.2 (disc valves), Table 3.1 (reeds).

    Examples
    --------
    >>> m = load_model("thesis-disc")
    >>> round(m.pump.piston_diameter * 1e3, 2), m.kind_at("inlet")    # Table 5.1: 15.88 mm bore
    (15.88, 'disc')
    """
    if isinstance(spec, PumpModel):
        return spec
    field = "spec" if field is None else field
    if not isinstance(spec, (str, Path)) or not str(spec).strip():
        raise InputError(field,
                         f"expected a shipped model name ({', '.join(SHIPPED)}), a model file path or a PumpModel, "
                         f"got {spec!r}")
    name = str(spec)
    if name in KINDS and name not in SHIPPED:
        name = kind_default_model(name)        # a kind's name stands for its shipped model
    if name in SHIPPED:
        return _shipped(name)
    path = Path(name)
    if not path.is_file():
        raise InputError(field, f"{name!r}: no such model; expected a shipped model ({', '.join(SHIPPED)}) "
                                f"or a model TOML file")
    resolved = str(path.resolve())
    loading = _LOADING.__dict__.setdefault("files", [])
    if resolved in loading:      # a base chain that comes back to a file being read: a cycle, not a recursion
        chain = [Path(f).name for f in loading[loading.index(resolved):]] + [path.name]
        raise InputError("base", f"the model files name each other as base in a cycle: {' -> '.join(chain)}")
    loading.append(resolved)
    try:
        return _load_file(resolved, path.stat().st_mtime_ns, field)
    finally:
        loading.pop()


#: per thread, the model files being read (outermost first), to refuse a ``base`` cycle
_LOADING = threading.local()


@lru_cache(maxsize=64)
def _load_file(path: str, mtime: int, field: str) -> PumpModel:
    p = Path(path)
    data = read_toml(p, field)
    return parse_model(data, source=str(p), base_dir=p.parent, name=p.stem)


@lru_cache(maxsize=None)
def _shipped(name: str) -> PumpModel:
    return parse_model(shipped_table(name), source=f"lumped/data/models/{SHIPPED[name]}", name=name,
                       defaults_from=None)


def shipped_table(name: str) -> dict:
    """The shipped model file ``name`` as written (a nested dict)."""
    return package_toml("lumped", f"models/{SHIPPED[name]}")


def _merge(base: dict, over: dict) -> dict:
    """Deep merge of two nested tables (``over`` wins)."""
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _drop(table: dict, dotted: tuple[str, ...]) -> dict:
    """``table`` without the dotted keys."""
    flat = {k: v for k, v in flatten(table).items() if k not in dotted}
    from geometry.declare import nest
    return nest(flat)


def _table(data: dict, key: str, where: str) -> dict:
    v = data.get(key, {})
    if not isinstance(v, dict):
        raise InputError(f"{where}{key}", "expected a table")
    return v


def parse_model(data: dict, source: str = "", base_dir: Path | None = None, name: str = "custom",
                defaults_from: str | None = DEFAULT_BASE) -> PumpModel:
    """A :class:`~lumped.model.pump_model.PumpModel` from a model-file table (see the module docstring)."""
    if not isinstance(data, dict):
        raise InputError("model", "expected a TOML table")
    for k in data:
        if k not in TOP_KEYS:
            raise InputError(k, f"unknown section or key; expected some of {', '.join(TOP_KEYS)}")
        if isinstance(data[k], dict):       # "spring.stiffness" and spring.stiffness: one would be dropped
            flatten(data[k], where=k)
    name = data.get("name", name)
    if not isinstance(name, str):
        raise InputError("name", f"expected a string, got {name!r}")
    if not isinstance(data.get("description", ""), str):
        raise InputError("description", f"expected a string, got {data['description']!r}")
    base_name = data.get("base")
    if base_name is not None:
        if not isinstance(base_name, str):
            raise InputError("base", f"expected a model name or file, got {base_name!r}")
        base = load_model(model_ref(base_name, base_dir), field="base")
        defaults = model_table(base)
    elif defaults_from is not None:
        base = _shipped(defaults_from)
        defaults = {k: v for k, v in model_table(base).items() if k in ("pump", "oil", "circuit")}
    else:
        base, defaults = None, {}

    comps = {}
    for sec, cls in COMPONENTS.items():
        table = _merge(defaults.get(sec, {}), _table(data, sec, ""))
        from geometry.declare import read_table
        values = read_table(cls, table, sec, require=sec != "operating")
        comps[sec] = cls(**values)

    valves_tbl = _table(data, "valves", "")
    shared = {k: v for k, v in valves_tbl.items() if k not in POSITIONS}
    _check_shared(shared)
    valves = {}
    for pos in POSITIONS:
        own = valves_tbl.get(pos, {})
        if not isinstance(own, dict):
            raise InputError(f"valves.{pos}", "expected a table")
        user = _merge(shared, own)
        valves[pos] = _load_valve(user, pos, base if base_name is not None else None, defaults, base_dir,
                                  complete=defaults_from is None and base_name is None, shipped=defaults_from is None,
                                  source=source)

    model = PumpModel(pump=comps["pump"], oil=comps["oil"], inlet=valves["inlet"], delivery=valves["delivery"],
                      circuit=comps["circuit"], operating=comps["operating"], name=name, source=source)
    _check_pump(model)
    model = _fluid_forms.apply(model)          # fluid = "predicted": the fluid references' compact forms
    effects = list(base.effects) if (base is not None and base_name is not None) else []
    effects = _parse_effects(_table(data, "effects", ""), model, effects, data, base_name)
    model = replace(model, effects=tuple(effects))
    # declared input uncertainties (lumped/model/uncertainty.py), a base's inherited
    return replace(model, uncertainties=_uncertainty.parse_uncertainties(
        data.get("uncertainty"), model, base.uncertainties if (base is not None and base_name is not None) else ()))


def model_ref(name: str, folder: Path | None) -> str:
    """What a file's ``NAME|FILE`` reference to a model names (a model file's ``base``, a run.toml's ``model``): a
    shipped model's or kind's name as given, else the file's path (a relative one from ``folder``, the folder of
    the file that names it), for :func:`load_model`."""
    if name in SHIPPED or name in KINDS:
        return name
    path = Path(name)
    return str(folder / path if folder is not None and not path.is_absolute() else path)


def _check_shared(shared: dict) -> None:
    """InputError naming ``valves.<name>`` for a key of ``[valves]`` that is neither a position nor a key some
    kind declares (``[valves.middle]`` is a misplaced valve, not a key shared by both valves)."""
    from geometry.declare import specs

    known = {"kind", "geometry"} | {s.key.split(".")[0] for kind in KINDS.values()
                                    for _, s in specs(kind.params) if s.key is not None}
    for k in shared:
        if k not in known:
            raise InputError(f"valves.{k}", f"unknown valve position or shared key; expected [valves.inlet], "
                                            f"[valves.delivery] or keys both valves share ({', '.join(sorted(known))})")


def _load_valve(user: dict, pos: str, base: PumpModel | None, defaults: dict, base_dir: Path | None,
                complete: bool = False, shipped: bool = False, source: str = ""):
    """The valve at ``pos``: the user's table over the defaults of its kind (a shipped file: complete,
    also where it changes its base's kind: it is that kind's defaults; so is a kind's default model
    given as a file, ``ValveKind.default_model``)."""
    where = f"valves.{pos}"
    base_kind = kind_of(base.valve(pos)).name if base is not None else None
    kind_name = user.get("kind", base_kind or "disc")
    if not isinstance(kind_name, str) or kind_name not in KINDS:
        raise InputError(f"{where}.kind", f"expected one of {', '.join(KINDS)}, got {kind_name!r}")
    kind = KINDS[kind_name]
    default = kind_default_model(kind_name)
    is_default = source and default not in SHIPPED and Path(default).resolve() == Path(source).resolve()
    if complete or (shipped and base_kind != kind_name) or is_default:
        start = {}
    elif base_kind == kind_name:
        start = defaults["valves"][pos]
    else:
        start = model_table(load_model(kind_default_model(kind_name), field=f"{where}.kind"))["valves"][pos]
    if "geometry" in user:
        start = _drop(start, kind.params.FROM_GEOMETRY)
        start.pop("geometry", None)
        if "fidelity" not in user:
            start.pop("fidelity", None)
        geo = user["geometry"]
        if isinstance(geo, str) and base_dir is not None and not Path(geo).is_absolute() \
                and (base_dir / geo).is_file():
            user = dict(user, geometry=str(base_dir / geo))
    table = _merge(start, user)
    table["kind"] = kind_name
    return kind.params.load(table, where, pos)


def _check_pump(model: PumpModel) -> None:
    p = model.pump
    if not p.rod_length > p.crank_radius:
        raise InputError("pump.rod_length", f"must exceed the crank radius ({p.crank_radius:g} m), "
                                            f"got {p.rod_length:g} m")
    if p.compression_ratio < 1.001:
        raise InputError("pump.dead_volume", f"{p.dead_volume:g} m^3 is {p.dead_volume / p.displacement:.3g} times the "
                                             f"swept volume {p.displacement:.3g} m^3: the compression ratio "
                                             f"{p.compression_ratio:.6g} < 1.001 leaves nothing to pump")
    c = model.circuit
    if c.complete and c.accumulator_precharge <= p.tank_pressure:
        raise InputError("circuit.accumulator_precharge", f"must exceed the tank pressure ({p.tank_pressure:g} Pa)")


def _parse_effects(table: dict, model: PumpModel, inherited: list, data: dict, base_name: str | None = None) -> list:
    """Applied effects from ``[effects]``: {name: {params}} or {name: {target: {params}}}; ``NAME = false``
    or ``[effects.NAME] TARGET = false`` switches an inherited effect off. Inherited effects are checked
    for the valves of this model like named ones."""
    out = {(a.name, a.target): a for a in inherited}
    named = set()
    for name, body in table.items():
        where = f"effects.{name}"
        if name not in LIBRARY:
            raise InputError(where, f"unknown effect; expected one of {', '.join(LIBRARY.names())}")
        if body is False:
            out = {k: a for k, a in out.items() if a.name != name}
            continue
        if not isinstance(body, dict):
            raise InputError(where, "expected a table of the effect's parameters (or false: off)")
        off = [k for k, v in body.items() if k in POSITIONS and v is False]
        for t in off:
            out.pop((name, t), None)
        body = {k: v for k, v in body.items() if k not in off}
        if off and not body:
            continue
        for target, values, w in _effect_jobs(LIBRARY[name], body, where):
            if not isinstance(values, dict):
                raise InputError(w, "expected a table of the effect's parameters")
            if not LIBRARY[name].applies_to(model, target):
                raise InputError(w, f"{name} does not apply to the {model.kind_at(target)} valve")
            vals = effect_library.check_values(LIBRARY[name], values, model, target, w)
            out[(name, target)] = Applied.of(name, target, vals)
            named.add((name, target))
    for key, a in list(out.items()):
        if key not in named:
            out[key] = _inherited_effect(a, model, base_name)
    applied = list(out.values())
    air = [a for a in applied if a.name == "entrained_air"]
    if air and "air_content" in data.get("oil", {}) and \
            not math.isclose(air[0].value_dict["R"], model.oil.air_content, rel_tol=1e-12):
        raise InputError("effects.entrained_air.R", f"contradicts oil.air_content = {model.oil.air_content:g}; "
                                                    "give one of them")
    return applied


def _effect_jobs(eff, body: dict, where: str) -> list:
    """(target, values, key path) of an effect's table: per valve (``[effects.NAME.inlet]``) or for the effect
    itself (its first target); InputError for a mix, or for the form the effect's targets do not take."""
    per_target = {k: v for k, v in body.items() if k in POSITIONS}
    direct = {k: v for k, v in body.items() if k not in POSITIONS}
    if per_target and direct:
        raise InputError(f"{where}.{next(iter(direct))}", "give the parameters per valve "
                         f"([{where}.inlet], [{where}.delivery]) or for the effect, not both")
    if per_target:
        if eff.targets == ("pump",):
            raise InputError(f"{where}.{next(iter(per_target))}", "acts on the whole pump: give its "
                             f"parameters in [{where}] itself")
        return [(t, v, f"{where}.{t}") for t, v in per_target.items()]
    if eff.targets == ("inlet", "delivery"):
        raise InputError(where, f"acts on one valve: give [{where}.inlet] or [{where}.delivery]")
    return [(eff.targets[0], direct, where)]


def _inherited_effect(a: Applied, model: PumpModel, base_name: str | None) -> Applied:
    """An effect inherited from the base, checked for this model's valves like a named one (the error says how
    to switch it off)."""
    eff = LIBRARY[a.name]
    w = f"effects.{a.name}" + ("" if a.target in ("both", "pump") else f".{a.target}")
    off = f"[effects.{a.name}] {a.target} = false" if a.target in POSITIONS else f"[effects] {a.name} = false"
    why = f" (inherited from base {base_name!r}; switch it off with {off})"
    if not eff.applies_to(model, a.target):
        raise InputError(w, f"{a.name} does not apply to the {model.kind_at(a.target)} valve{why}")
    try:
        vals = effect_library.check_values(eff, a.value_dict, model, a.target, w)
    except InputError as exc:
        raise InputError(exc.field, exc.message + why) from None
    return Applied.of(a.name, a.target, vals)


# --------------------------------------------------------------------------- writing
def _valve_table(v) -> dict:
    """{dotted key: value} of a valve's declared keys, as a model file gives them."""
    kind = kind_of(v)
    out = {"kind": kind.name}
    skip = kind.params.FROM_GEOMETRY if getattr(v, "reed", None) is not None else ()
    for n, s in specs(v):
        if s.key is None or s.key in skip:
            continue
        val = getattr(v, n)
        if n == "geometry" and getattr(v, "reed", None) is not None and val == "inline":
            from geometry.reed_io import reed_to_toml
            val = tomllib.loads(reed_to_toml(v.reed))["reed"]
        if val is not None:
            out[s.key] = val
    return out


def model_table(model: PumpModel) -> dict:
    """The complete resolved model as a nested model-file table (every key, effects with their values)."""
    from geometry.declare import nest, to_table

    out = {"name": model.name}
    for sec in ("pump", "oil", "circuit"):
        out[sec] = nest(to_table(getattr(model, sec)))
    op = to_table(model.operating)
    if op:
        out["operating"] = op
    out["valves"] = {pos: nest(_valve_table(model.valve(pos))) for pos in POSITIONS}
    eff: dict = {}
    for a in model.effects:
        e = LIBRARY[a.name]
        if a.target in POSITIONS and e.targets != ("pump",) and not (e.targets == ("both",) and a.target == "both"):
            eff.setdefault(a.name, {})[a.target] = dict(a.values)
        else:
            eff[a.name] = dict(a.values)
    if eff:
        out["effects"] = eff
    if model.uncertainties:
        out["uncertainty"] = _uncertainty.uncertainty_table(model.uncertainties)
    return out


def _fmt(key: str, value) -> str:
    return tomli_w.dumps({key: value}).strip() if "." not in key else \
        tomli_w.dumps({"x": value}).strip().replace("x = ", f"{key} = ", 1)


def _comment(spec, extra: str = "", origin: str | None = None) -> str:
    unit = "" if spec.unit in ("-", "") else spec.unit + ", "
    return f"  # {unit}{_labelled(spec.source, origin)}{extra}"


def to_toml(model: PumpModel, comments: bool = True, origins: dict | None = None) -> str:
    """The complete resolved model as a model file, each key with its unit and source (model show).

    With ``origins`` (:func:`file_keys`), a key a model file sets is labelled as that file's.

    Examples
    --------
    >>> text = to_toml(load_model("thesis-reed"))
    >>> load_model("thesis-reed") == parse_model(__import__("tomllib").loads(text), name="thesis-reed",
    ...                                          source=load_model("thesis-reed").source)
    True
    """
    origins = origins or {}
    lines = [f"# valvelab model {model.name!r}" + (f" (from {model.source})" if model.source else ""),
             "# complete and resolved: every key with its unit and source; copy it and edit", ""]
    lines.append(_fmt("name", model.name))
    for sec in ("pump", "oil", "circuit", "operating"):
        comp = getattr(model, sec)
        rows = [(s, getattr(comp, n)) for n, s in specs(comp) if s.key is not None and getattr(comp, n) is not None]
        if not rows:
            continue
        lines += ["", f"[{sec}]"]
        for s, v in rows:
            lines.append(_fmt(s.key, v) + (_comment(s, origin=origins.get(f"{sec}.{s.key}")) if comments else ""))
    for pos in POSITIONS:
        lines += _valve_lines(model.valve(pos), pos, comments, origins)
    for a in model.effects:
        lines += _effect_lines(model, a, comments, origins)
    if model.uncertainties:                     # declared input uncertainties (lumped/model/uncertainty.py)
        lines += ["", tomli_w.dumps({"uncertainty": _uncertainty.uncertainty_table(model.uncertainties)}).strip()]
    return "\n".join(lines) + "\n"


def _valve_lines(v, pos: str, comments: bool, origins: dict) -> list[str]:
    """The ``[valves.<pos>]`` table of :func:`to_toml`: what the geometry supplies or derives as comments."""
    kind = kind_of(v)
    lines = ["", f"[valves.{pos}]", _fmt("kind", kind.name) + (f"  # {kind.summary}" if comments else "")]
    geo_keys = v.geometry_supplied()
    for n, s in specs(v):
        if s.key is None:
            continue
        val = getattr(v, n)
        if n == "geometry" and getattr(v, "reed", None) is not None and val == "inline":
            from geometry.reed_io import reed_to_toml
            val = tomllib.loads(reed_to_toml(v.reed))["reed"]
        if s.key in kind.params.FROM_GEOMETRY and getattr(v, "reed", None) is not None:
            if comments:
                lines.append(f"# {_fmt(s.key, val)}  ({s.unit}, derived from the geometry by {v.fidelity})")
            continue
        if val is None:
            continue
        if s.key in geo_keys:
            if comments:
                lines.append(f"# {_fmt(s.key, val)}  ({s.unit}, from geometry {v.geometry!r})")
            continue
        c = _comment(s, origin=origins.get(f"valves.{pos}.{s.key}")) if comments else ""
        lines.append((f"{s.key} = {_inline(val)}" if isinstance(val, dict) else _fmt(s.key, val)) + c)
    if comments:
        for k, (n, s) in _derived_rows(v):
            lines.append(f"# {k} = {n:.6g}  ({s})")
    return lines


def _effect_lines(model: PumpModel, a: Applied, comments: bool, origins: dict) -> list[str]:
    """The ``[effects.NAME(.TARGET)]`` table of :func:`to_toml`: each value with its unit and prior (or its file)."""
    e = LIBRARY[a.name]
    params = {p.name: p for p in e.parameters_for(model, a.target)}
    head = f"effects.{a.name}" if a.target in ("both", "pump") else f"effects.{a.name}.{a.target}"
    lines = ["", f"[{head}]" + (f"  # {e.summary}" if comments else "")]
    for k, val in a.values:
        p = params.get(k)
        f = origins.get(f"{head}.{k}")
        c = "" if not (comments and p) else (f"  # {p.unit}, model file {f}" if f else
                                             f"  # {p.unit}, prior {p.prior:.4g}: {p.source}")
        lines.append(_fmt(k, val) + c)
    return lines


def _inline(d) -> str:
    """A TOML inline value (tables and arrays of tables inline too)."""
    if isinstance(d, dict):
        return "{ " + ", ".join(f"{k} = {_inline(v)}" for k, v in d.items()) + " }"
    if isinstance(d, list):
        return "[" + ", ".join(_inline(v) for v in d) + "]"
    return tomli_w.dumps({"x": d}).strip()[4:]


def _derived_rows(v):
    rows = []
    for name, key in (("seat.damping", "seat_damping_value"), ("stop.damping", "stop_damping_value")):
        if getattr(v, name.replace(".", "_"), "x") is None:
            rows.append((name, (getattr(v, key), "derived: critical damping, eq 2.23")))
    return rows


# --------------------------------------------------------------------------- key paths
def with_values(model: PumpModel, values: dict, field_prefix: str = "") -> PumpModel:
    """A model with some of its keys changed, each named by its path in a model file.

    Paths: ``pump.dead_volume``, ``valves.inlet.spring.stiffness``, ``valves.spring.stiffness`` for both
    valves, ``valves.delivery.geometry.thickness``, ``effects.seat_compliance.delivery.k_seat``; an
    InputError names the path of a bad key or value.

    Parameters
    ----------
    model : PumpModel
        The model to start from.
    values : dict
        {key path: value} (SI units; an effect's switch true/false).
    field_prefix : str
        Put before a path in an error (e.g. the sweep's ``factors.``).

    Returns
    -------
    PumpModel
        A new model (``model`` is not changed).

    Examples
    --------
    >>> m = with_values(load_model("thesis-disc"), {"pump.dead_volume": 2e-6})
    >>> m.pump.dead_volume
    2e-06
    >>> with_values(m, {"pump.dead_volum": 1e-6})
    Traceback (most recent call last):
    ...
    geometry.errors.InputError: pump.dead_volum: unknown key (did you mean dead_volume?); expected one of ...
    """
    if not isinstance(model, PumpModel):
        raise InputError("model", f"expected a PumpModel (lumped.load_model(...)), got {type(model).__name__}")
    if not isinstance(values, dict):
        raise InputError("values", f"expected a dict {{key path: value}}, got {type(values).__name__}")
    if not values:
        return model
    table = model_table(model)
    table.pop("uncertainty", None)          # carried over below, as inherited declarations
    for path, value in values.items():
        _set_path(table, model, str(path), value, field_prefix)
    try:
        out = parse_model(table, source=model.source, name=model.name, defaults_from=None)
    except InputError as exc:
        raise InputError(field_prefix + exc.field, exc.message) from None
    if not model.uncertainties:
        return out
    return replace(out, uncertainties=_uncertainty.parse_uncertainties(None, out, model.uncertainties))


def _set_path(table: dict, model: PumpModel, path: str, value, prefix: str) -> None:
    """Set ``path`` to ``value`` in a model table (:func:`model_table`); InputError naming ``prefix + path``."""
    if not path.strip():
        raise InputError(f"{prefix}values", "holds an empty key path; expected pump.*, oil.*, circuit.*, operating.*, "
                                            "valves.<inlet|delivery>.* or effects.<name>[.<target>].*")
    parts = path.split(".")
    if len(parts) < 2 or parts[0] not in ("pump", "oil", "circuit", "operating", "valves", "effects"):
        raise InputError(prefix + path, "not a model key path; expected pump.*, oil.*, circuit.*, operating.*, "
                                        "valves.<inlet|delivery>.*, valves.* (both) or effects.<name>[.<target>].*")
    if parts[0] == "valves":
        _set_valve_path(table, model, parts, value, prefix + path)
    elif parts[0] == "effects":
        _set_effect_path(table, model, parts, value, prefix + path)
    else:
        _set_nested(table.setdefault(parts[0], {}), parts[1:], value)


def _set_valve_path(table: dict, model: PumpModel, parts: list, value, where: str) -> None:
    """``valves.<pos>.<key>`` (``valves.<key>``: both valves); a reed's ``geometry.<key>`` changes its geometry
    table; a new geometry or kind drops what the old geometry supplied."""
    targets = [parts[1]] if parts[1] in POSITIONS else list(POSITIONS)
    rest = parts[2:] if parts[1] in POSITIONS else parts[1:]
    if not rest:
        raise InputError(where, "names a valve, not a key")
    for pos in targets:
        vt = table["valves"][pos]
        v = model.valve(pos)
        if rest[0] == "geometry" and len(rest) > 1:
            geo = vt.get("geometry")
            if getattr(v, "reed", None) is None:
                raise InputError(where, f"the {pos} valve has no reed geometry to change")
            if not isinstance(geo, dict):
                from geometry.reed_io import reed_to_toml
                geo = tomllib.loads(reed_to_toml(v.reed))["reed"]
                vt["geometry"] = geo
            _set_nested(geo, rest[1:], value)
            continue
        if rest == ["kind"] and isinstance(value, str) and value in KINDS and value != kind_of(v).name:
            # another kind: its own keys, from its shipped model (as a model file's kind = ... does)
            vt.clear()
            vt.update(model_table(load_model(kind_default_model(value), field=where))["valves"][pos])
            continue
        if rest == ["geometry"] or rest == ["kind"]:
            for k in kind_of(v).params.FROM_GEOMETRY:
                _del_nested(vt, k.split("."))
        _set_nested(vt, rest, value)


def _set_effect_path(table: dict, model: PumpModel, parts: list, value, where: str) -> None:
    """``effects.<name>[.<target>].<parameter>``, or ``effects.<name>[.<target>]`` = true/false: a switch (on
    at the effect's priors, or off: every target, or the one named)."""
    name = parts[1]
    if name not in LIBRARY:
        raise InputError(where, f"unknown effect {name!r}; expected one of {', '.join(LIBRARY.names())}")
    effects = table.setdefault("effects", {})
    rest = parts[2:]
    if isinstance(value, bool) and (not rest or (len(rest) == 1 and rest[0] in POSITIONS)):
        if rest:
            if value:
                effects.setdefault(name, {}).setdefault(rest[0], {})
            elif isinstance(effects.get(name), dict):
                effects[name].pop(rest[0], None)
                if not effects[name]:
                    effects.pop(name)
        elif value:
            eff = LIBRARY[name]
            effects.setdefault(name, {})
            fits = [t for t in POSITIONS if eff.applies_to(model, t)]
            if eff.targets != ("pump",) and not fits:
                raise InputError(where, f"applies to {', '.join(eff.valve_types or ())} valves; this model's are "
                                        f"{model.label}")
            # a per-valve effect on a pump with one valve of its kinds: on that valve, not on "both"
            if eff.targets == ("inlet", "delivery") or (eff.targets != ("pump",) and len(fits) < 2):
                for t in fits:
                    effects[name].setdefault(t, {})
        else:
            effects.pop(name, None)
        return
    eff = effects.setdefault(name, {})
    if rest and rest[0] in POSITIONS:
        eff = eff.setdefault(rest[0], {})
        rest = rest[1:]
    if len(rest) != 1:
        raise InputError(where, "expected effects.<name>[.<target>].<parameter>")
    eff[rest[0]] = value


def _set_nested(d: dict, parts: list, value) -> None:
    for p in parts[:-1]:
        d = d.setdefault(p, {})
        if not isinstance(d, dict):
            raise InputError(".".join(parts), "is not a table")
    d[parts[-1]] = value


def _del_nested(d: dict, parts: list) -> None:
    for p in parts[:-1]:
        d = d.get(p)
        if not isinstance(d, dict):
            return
    d.pop(parts[-1], None)


def file_keys(model: PumpModel) -> dict:
    """{key path: model file name} of the keys ``model``'s own file (and each file of its ``base`` chain) sets; {}
    for a shipped model. The file nearest the model wins; a key inherited from a shipped model is not in it."""
    src = model.source
    if not src or not Path(src).is_file() or any(Path(src).name == f for f in SHIPPED.values()):
        return {}
    out: dict = {}
    chain = []
    path = Path(src)
    while path is not None and path.is_file() and str(path.resolve()) not in chain:
        chain.append(str(path.resolve()))
        data = read_toml(path, "model")
        own = {}
        for sec in ("pump", "oil", "circuit", "operating"):
            own.update({f"{sec}.{k}": path.name for k in flatten(data.get(sec) or {})})
        valves = data.get("valves") or {}
        for k in flatten({k: v for k, v in valves.items() if k not in POSITIONS}):
            own.update({f"valves.{pos}.{k}": path.name for pos in POSITIONS})
        for pos in POSITIONS:
            own.update({f"valves.{pos}.{k}": path.name for k in flatten(valves.get(pos) or {})})
        own.update({f"effects.{k}": path.name for k in flatten(data.get("effects") or {})})
        out = {**own, **out}                        # the nearer file's keys win
        base = data.get("base")
        ref = model_ref(base, Path(chain[-1]).parent) if isinstance(base, str) else None
        path = None if ref is None or ref in SHIPPED or ref in KINDS else Path(ref)
    return out


def _labelled(source: str, file: str | None) -> str:
    """A key's declared ``source`` or, for a key a model file sets, its description with that file instead of the
    declared citation: "d_piston (Table 5.1)" -> "d_piston (model file mine.toml)"."""
    if file is None:
        return source
    head = source.rsplit(" (", 1)[0] if source.endswith(")") else source
    return f"{head} (model file {file})"


def key_paths(model: PumpModel, origins: dict | None = None) -> list[dict]:
    """Every numeric key of ``model`` by path with its unit, source and value (sweep variables); with ``origins``
    (:func:`file_keys`), a key a model file sets is labelled as that file's."""
    out = []
    for sec in ("pump", "oil", "circuit", "operating"):
        comp = getattr(model, sec)
        for n, s in specs(comp):
            v = getattr(comp, n)
            if s.key is not None and isinstance(v, (int, float)) and not isinstance(v, bool):
                out.append({"path": f"{sec}.{s.key}", "unit": s.unit, "source": s.source, "value": v})
    for pos in POSITIONS:
        v = model.valve(pos)
        skip = kind_of(v).params.FROM_GEOMETRY if getattr(v, "reed", None) is not None else ()
        for n, s in specs(v):
            val = getattr(v, n)
            if s.key is None or s.key in skip or isinstance(val, bool) or not isinstance(val, (int, float)):
                continue
            out.append({"path": f"valves.{pos}.{s.key}", "unit": s.unit, "source": s.source, "value": val})
    for a in model.effects:
        head = f"effects.{a.name}" + ("" if a.target in ("both", "pump") else f".{a.target}")
        for p in LIBRARY[a.name].parameters_for(model, a.target):
            out.append({"path": f"{head}.{p.name}", "unit": p.unit, "source": p.source, "value": a.value_dict[p.name]})
    for d in out:
        d["source"] = _labelled(d["source"], (origins or {}).get(d["path"]))
    return out


# --------------------------------------------------------------------------- derived quantities
def describe(model: PumpModel) -> dict:
    """What ``valvelab model check`` reports: swept volume, compression ratio, valve frequencies,
    damping ratios, reed parameters (SI units). Refuses (InputError) what can be decided before running:
    a valve resting beyond its stop, a pump that cannot deliver (lumped.validity.check_model)."""
    from lumped.validity import check_model

    check_model(effect_library.resolve(model))
    p = model.pump
    out = {
        "model": model.name, "source": model.source, "valves": {"inlet": model.kinds[0], "delivery": model.kinds[1]},
        "swept_volume_m3": p.displacement, "dead_volume_m3": p.dead_volume,
        "compression_ratio": p.compression_ratio, "piston_area_m2": p.piston_area,
        "oil_bulk_modulus_at_tank_pa": model.oil.bulk_modulus_at(p.tank_pressure),
        "circuit": model.circuit.kind,
        "effects": [a.name if a.target in ("both", "pump") else f"{a.name}@{a.target}" for a in model.effects],
    }
    resolved = effect_library.resolve(model)
    for pos in POSITIONS:
        v = resolved.valve(pos)
        d = {"kind": kind_of(v).name, "natural_frequency_rad_s": v.natural_frequency(),
             "damping_ratios": v.damping_ratios(), "stop_gap_m": v.common(resolved.oil).stop_gap}
        d.update(v.describe())
        out[pos] = d
    return out


# the effect library asks for the thesis model of a kind when a prior is wanted for a bare valve type
effect_library.REFERENCE["model"] = lambda kind: _shipped(kind_default_model(kind))
# the input-uncertainty declarations check their key paths against key_paths
_uncertainty.KEY_PATHS["key_paths"] = key_paths


def check_key(model: PumpModel, path: str, value) -> None:
    """Raise InputError if ``value`` is not acceptable for key ``path`` of ``model`` (without building it)."""
    with_values(model, {path: value})


__all__ = ["SHIPPED", "load_model", "parse_model", "model_table", "to_toml", "with_values", "key_paths", "model_ref",
           "describe", "check_key", "check_field"]
