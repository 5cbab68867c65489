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

Everything is checked here, before any computation, through :mod:`studies.sweeps.schema` (the
machinery of the sweep file too); a bad field raises :class:`~geometry.errors.InputError`
naming it (``variables."oil.air_content".high``). The variables are
:mod:`studies.sweeps.design.variables`, the ``[run]``, ``[stress]``, ``[recheck]`` and
``[constraints]`` tables :mod:`studies.sweeps.design.run_spec`, the ``[derived]`` expressions
:mod:`studies.sweeps.design.expressions`.
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from geometry import validate
from geometry.errors import InputError
from studies.sweeps import schema
from studies.sweeps.design import run_spec
from studies.sweeps.design.expressions import evaluate_expression, expression_names
from studies.sweeps.design.run_spec import RUN_KEYS, SHARED_RUN_KEYS  # noqa: F401  (the spec's schema, here too)
from studies.sweeps.design.variables import (  # noqa: F401  (defined there, used as spec.Variable too)
    CHECK_QUANTILES, DISTRIBUTIONS, VARIABLE_KEYS, Constraint, Objective, Variable, parse_variable)
from studies.sweeps.schema import model_reference, quoted as _q  # noqa: F401  (used as spec.model_reference, spec._q)

COMMANDS = ("sensitivity", "optimize")
OPERATING_VARIABLES = {"speed_rpm": "rpm", "load_pressure_mpa": "MPa"}
#: at most this many evaluation rows (designs x operating points) in one study
MAX_ROWS = 20_000_000
#: bytes per evaluation row: in memory (the designs and results tables) and on disk (Parquet)
ROW_BYTES_MEMORY = 1200
ROW_BYTES_DISK = 400
TOP_KEYS = {
    "sensitivity": {"model", "description", "fixed", "operating", "variables", "derived", "run", "stress"},
    "optimize": {"model", "description", "fixed", "operating", "variables", "derived", "run", "constraints",
                 "stress", "recheck"},
}
#: the model-file sections a key-path variable of a pump model starts with
KEY_SECTIONS = ("pump.", "oil.", "circuit.", "operating.", "valves.", "effects.")


@dataclass(frozen=True)
class DesignSpec:
    """A parsed sensitivity or optimisation spec.

    Parameters
    ----------
    command : str
        ``sensitivity`` or ``optimize``.
    model : str
        A shipped pump model, a model file (absolute) or a sweep-model module.
    model_kind : str
        ``pump`` or ``module``.
    fixed : tuple of (str, object)
        Key paths set on the base model.
    points : tuple of dict
        The operating points, ``{"speed_rpm": rpm, "load_pressure": Pa}`` each (``({},)`` for a module).
    variables : tuple of Variable
    derived : tuple of (str, str)
        Key paths and their expressions.
    run : tuple of (str, object)
        ``[run]`` with defaults filled in (:func:`studies.sweeps.design.run_spec.parse_run`).
    outputs : tuple of str
        The outputs analysed (sensitivity).
    objectives, constraints : tuple
        Of an optimisation (:class:`~studies.sweeps.design.variables.Objective`, ``Constraint``).
    stress, recheck : tuple of (str, object)
        ``[stress]`` and ``[recheck]`` with defaults filled in.
    description : str
    text : str
        The spec's TOML, kept in the study folder.
    model_digest : str
        A hash of the model file's bytes (resume safety).
    """

    command: str
    model: str
    model_kind: str
    fixed: tuple = ()
    points: tuple = ()
    variables: tuple = ()
    derived: tuple = ()
    run: tuple = ()
    outputs: tuple = ()
    objectives: tuple = ()
    constraints: tuple = ()
    stress: tuple = ()
    recheck: tuple = ()
    description: str = ""
    text: str = field(default="", compare=False, repr=False)
    model_digest: str = field(default="", compare=True, repr=False)

    @property
    def run_dict(self) -> dict:
        """``[run]`` as a dict."""
        return dict(self.run)

    @property
    def stress_dict(self) -> dict:
        """``[stress]`` as a dict."""
        return dict(self.stress)

    @property
    def recheck_dict(self) -> dict:
        """``[recheck]`` as a dict."""
        return dict(self.recheck)

    @property
    def digest(self) -> str:
        """A hash of everything that determines the study's results (resume safety)."""
        key = repr((self.command, self.model, self.model_kind, self.fixed, self.points, self.variables, self.derived,
                    self.run, self.outputs, self.objectives, self.constraints, self.stress, self.recheck,
                    self.model_digest))
        return hashlib.sha256(key.encode()).hexdigest()[:16]

    def variable(self, name: str) -> Variable:
        """A variable by its name.

        Parameters
        ----------
        name : str

        Returns
        -------
        Variable
        """
        return next(v for v in self.variables if v.name == name)

    @property
    def point_labels(self) -> list[str]:
        """The operating points as text (:func:`point_label`)."""
        return [point_label(p) for p in self.points]


def point_label(p: dict) -> str:
    """An operating point as text.

    Parameters
    ----------
    p : dict
        ``{"speed_rpm": rpm, "load_pressure": Pa}`` (either may be absent).

    Returns
    -------
    str
        ``593 rpm, 2.76 MPa`` style text; ``default`` for an empty point.

    Examples
    --------
    >>> point_label({"speed_rpm": 593.0, "load_pressure": 2.76e6})
    '593 rpm, 2.76 MPa'
    """
    if not p:
        return "default"
    parts = []
    if "speed_rpm" in p:
        parts.append(f"{p['speed_rpm']:g} rpm")
    if "load_pressure" in p:
        parts.append(f"{p['load_pressure'] / 1e6:g} MPa")
    return ", ".join(parts)


# --------------------------------------------------------------------------- parsing
def _model(doc: dict, base_dir: Path | None, model_override) -> tuple[str, str]:
    """The spec's model and its kind (``--model`` replaces it)."""
    if model_override is not None:
        return model_reference(model_override, Path.cwd(), "--model")
    if "model" not in doc:
        raise InputError("model", "missing: the base model (thesis-disc, thesis-reed, a model file or a module)")
    return model_reference(doc["model"], base_dir)


def _fixed(doc: dict) -> list:
    """``[fixed]``: (key path, value) pairs; a list becomes a tuple (the spec is hashable)."""
    fixed = []
    for k, v in schema.flat_table(doc, "fixed", "a table of key path = value").items():
        if isinstance(v, float) and not math.isfinite(v):
            raise InputError(f"fixed.{_q(k)}", f"must be finite, got {v}")
        fixed.append((k, tuple(v) if isinstance(v, list) else v))
    return fixed


def _derived(der_doc: dict, var_doc: dict) -> tuple[list, set]:
    """``[derived]``: (key path, expression) pairs, each reading variables or keys derived above it; and the
    names they read."""
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
    return derived, used


def _role(name: str, kind: str, used: set) -> str:
    """What a variable is: a model key path (``key``), the operating point, or a name only [derived] reads."""
    if name in OPERATING_VARIABLES:
        if kind == "module":
            raise InputError(f"variables.{name}", "a module model has no operating point")
        return "operating"
    if kind == "module" or name.startswith(KEY_SECTIONS):
        return "key"
    if "." not in name and name in used:
        return "auxiliary"
    raise InputError(f"variables.{_q(name)}", "not a model key path (pump.*, oil.*, circuit.*, valves.*, effects.*), "
                                              "speed_rpm or load_pressure_mpa, nor a name used by [derived]")


def _variables(var_doc: dict, command: str, model: str, kind: str, model_obj, used: set) -> list:
    """Every ``[variables]`` entry with its role and unit (a pump model's declarations, a module's ``UNITS``)."""
    variables = []
    for name, d in var_doc.items():
        role = _role(name, kind, used)
        if kind == "module":
            unit = getattr(__import__(model, fromlist=["x"]), "UNITS", {}).get(name, "-")
        else:
            unit = _unit_of(model_obj, name) if role != "auxiliary" else "-"
        variables.append(parse_variable(name, d, command, role, unit))
    if len(variables) > 1000:
        raise InputError("variables", f"{len(variables)} variables; at most 1000")
    return variables


def _outputs(run: dict, command: str, catalogue: dict) -> tuple:
    """(outputs, objectives) of ``[run]``, each an output of the model; the optimisation's size within its cap."""
    if command == "sensitivity":
        for i, o in enumerate(run["outputs"]):
            known_output(catalogue, o, f"run.outputs[{i}]")
        return run.pop("outputs"), ()
    for i, o in enumerate(run["objectives"]):
        known_output(catalogue, o.output, f"run.objectives[{i}]")
    n_eval = run["population"] * (run["generations"] + 1)
    if n_eval > run["max_evaluations"]:
        raise InputError("run.generations", f"population x (generations + 1) = {n_eval} designs exceeds "
                                            f"run.max_evaluations = {run['max_evaluations']}")
    return (), run.pop("objectives")


def known_output(catalogue: dict, name: str, where: str) -> None:
    """Refuse an output the model does not have, naming a few close ones.

    Parameters
    ----------
    catalogue : dict
        The model's outputs (:mod:`studies.sweeps.design.outputs`).
    name : str
        The output the spec names.
    where : str
        Its field name.
    """
    if name not in catalogue:
        close = [n for n in catalogue if name.split("_")[0] in n][:6]
        raise InputError(where, f"unknown output {name!r}; expected one of {', '.join(close or list(catalogue)[:12])}"
                                f" ... (CONTRACT.md lists them all)")


def catalogue_of(model: str, kind: str) -> dict:
    """The outputs a spec on a model may name.

    Parameters
    ----------
    model : str
        The spec's model (a pump model, or a sweep-model module's name).
    kind : str
        ``pump`` or ``module``.

    Returns
    -------
    dict of str to Output
        :data:`studies.sweeps.design.outputs.PUMP_OUTPUTS`, or the module's numeric outputs.
    """
    from studies.sweeps.design.outputs import PUMP_OUTPUTS, module_outputs

    return PUMP_OUTPUTS if kind == "pump" else module_outputs(__import__(model, fromlist=["x"]))


def _check_arguments(doc, command: str, model_override) -> None:
    """The command, ``--model`` and the spec's top-level keys and description."""
    validate.choice(command, "command", COMMANDS)
    if model_override is not None and not isinstance(model_override, str):
        raise InputError("model_override", f"expected a model name or file, got {model_override!r}")
    schema.table(doc, "spec", "a TOML table")
    schema.check_keys(doc, TOP_KEYS[command], "", lambda k: " (an optimize section)" if k in TOP_KEYS["optimize"]
                      else "")
    if not isinstance(doc.get("description", ""), str):
        raise InputError("description", "expected a string")


def parse_spec(doc: dict, command: str, text: str = "", base_dir: Path | None = None,
               model_override: str | None = None) -> DesignSpec:
    """Check a parsed spec TOML and make its :class:`DesignSpec` (see the module docstring and CONTRACT.md).

    Parameters
    ----------
    doc : dict
        The parsed TOML.
    command : str
        ``sensitivity`` or ``optimize``.
    text : str
        Its text (kept in the study folder).
    base_dir : pathlib.Path, optional
        The folder a model file in the spec is relative to.
    model_override : str, optional
        ``--model``: a base model replacing the spec's (relative to the working folder).

    Returns
    -------
    DesignSpec

    Raises
    ------
    InputError
        Naming the first bad field, before any computation.
    """
    _check_arguments(doc, command, model_override)
    model, kind = _model(doc, base_dir, model_override)
    fixed = _fixed(doc)
    if not isinstance(doc.get("variables"), dict) or not doc["variables"]:
        raise InputError("variables", "need at least one variable: \"key.path\" = [low, high]")
    var_doc = schema.flat_table(doc, "variables", "", leaf_keys=VARIABLE_KEYS)
    der_doc = schema.flat_table(doc, "derived", "a table of key path = \"expression\"")
    from lumped.model.model_file import load_model

    model_obj = load_model(model, field="model") if kind == "pump" else None
    derived, used = _derived(der_doc, var_doc)
    variables = _variables(var_doc, command, model, kind, model_obj, used)
    for k, _ in fixed:
        if k in var_doc or k in der_doc:
            raise InputError(f"fixed.{_q(k)}", "is also varied; keep it in one place")
    run = run_spec.parse_run(doc.get("run", {}), command)
    points = _parse_operating(doc.get("operating", {}), model, kind, set(var_doc))
    catalogue = catalogue_of(model, kind)
    outputs, objectives = _outputs(run, command, catalogue)
    constraints, stress = run_spec.parse_constraints(doc.get("constraints", {}), kind,
                                                     run_spec.parse_stress(doc.get("stress", {})),
                                                     lambda name, where: known_output(catalogue, name, where))
    recheck = run_spec.parse_recheck(doc.get("recheck", {})) if command == "optimize" else {}
    return DesignSpec(command=command, model=model, model_kind=kind, fixed=tuple(fixed), points=points,
                      variables=tuple(variables), derived=tuple(derived), run=tuple(sorted(run.items())),
                      outputs=tuple(outputs), objectives=tuple(objectives), constraints=tuple(constraints),
                      stress=tuple(sorted(stress.items())), recheck=tuple(sorted(recheck.items())),
                      description=doc.get("description", ""), text=text, model_digest=_model_digest(model, kind))


def _model_digest(name: str, kind: str) -> str:
    """A hash of a model file's bytes ('' for a shipped model or a module)."""
    if kind == "pump" and Path(name).is_file():
        return hashlib.sha256(Path(name).read_bytes()).hexdigest()[:16]
    return ""


def _operating_list(op: dict, k: str, spec, var_names: set):
    """One ``[operating]`` list (a number is a list of one), each value checked against its declaration."""
    from geometry.declare import check_value

    if k in op and k in var_names:
        raise InputError(f"operating.{k}", "is also a variable; keep it in one place")
    v = op.get(k)
    if v is None:
        return None
    v = v if isinstance(v, list) else [v]
    if not v:
        raise InputError(f"operating.{k}", "is an empty list")
    for i, x in enumerate(v):
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise InputError(f"operating.{k}[{i}]", f"expected a number, got {x!r}")
        check_value(float(x), spec, f"operating.{k}[{i}]")
    if len(set(v)) != len(v):
        raise InputError(f"operating.{k}", "has repeated values")
    return [float(x) for x in v]


def _parse_operating(op, model_name: str, kind: str, var_names: set) -> tuple:
    """The operating points: every combination of the speeds and load pressures (the model's own by default)."""
    if kind == "module":
        if op:
            raise InputError("operating", "a module model has no operating points; drop [operating]")
        return ({},)
    schema.table(op, "operating", "a table with speed_rpm and load_pressure_mpa lists")
    extra = set(op) - {"speed_rpm", "load_pressure_mpa"}
    if extra:
        k = sorted(extra)[0]
        raise InputError(f"operating.{k}", "unknown key; expected speed_rpm (rpm) and load_pressure_mpa (MPa, "
                                           "absolute) lists" + (" (load pressure in MPa: load_pressure_mpa)"
                                                                if k == "load_pressure" else ""))
    from lumped.model.model_file import load_model
    from lumped.model.pump_model import LOAD_MPA, SPEED

    lists = {k: _operating_list(op, k, spec, var_names) for k, spec in (("speed_rpm", SPEED),
                                                                        ("load_pressure_mpa", LOAD_MPA))}
    model = load_model(model_name, field="model")
    for k, attr, scale in (("speed_rpm", "speed_rpm", 1.0), ("load_pressure_mpa", "load_pressure", 1e-6)):
        if lists[k] is None and k not in var_names:
            dv = getattr(model.operating, attr)
            if dv is None:
                raise InputError(f"operating.{k}", f"missing, and the model {model.name!r} has no [operating] {attr}")
            lists[k] = [dv * scale]
    for i, p in enumerate(lists["load_pressure_mpa"] or ()):
        _above_tank(p, model, f"operating.load_pressure_mpa[{i}]")
    return tuple({**({} if s is None else {"speed_rpm": s}), **({} if p is None else {"load_pressure": p * 1e6})}
                 for s in lists["speed_rpm"] or [None] for p in lists["load_pressure_mpa"] or [None])


def _above_tank(load_mpa: float, model, where: str) -> None:
    """InputError naming ``where`` for a load [MPa, absolute] below the model's tank pressure: every evaluation
    would be refused (lumped.simulate), so the study is refused before any."""
    tank = model.pump.tank_pressure
    if load_mpa * 1e6 < tank:
        raise InputError(where, f"{load_mpa:g} MPa is below the tank pressure {tank / 1e6:g} MPa (absolute): a "
                                "pump delivers into a load above its inlet")


def _unit_of(model, path: str) -> str:
    """The unit of a variable of a pump model: an operating variable's, or its key path's declared one."""
    from studies.sweeps.pump import key_unit

    if path in OPERATING_VARIABLES:
        return OPERATING_VARIABLES[path]
    return key_unit(model, path)


def load_spec(path, command: str, model_override: str | None = None) -> DesignSpec:
    """Read and check a spec file.

    Parameters
    ----------
    path : str or os.PathLike
        The spec file; a model file in it is relative to its folder.
    command : str
        ``sensitivity`` or ``optimize``.
    model_override : str, optional
        ``--model``: a base model replacing the spec's.

    Returns
    -------
    DesignSpec
    """
    validate.path(path, "path")
    validate.choice(command, "command", COMMANDS)
    doc, text, folder = schema.read_spec(path)
    return parse_spec(doc, command, text, base_dir=folder, model_override=model_override)


# --------------------------------------------------------------------------- designs
def design_inputs(spec: DesignSpec, values: dict) -> dict:
    """The evaluation inputs of one design.

    Parameters
    ----------
    spec : DesignSpec
    values : dict
        {variable name: value} in each variable's unit.

    Returns
    -------
    dict
        Key paths (variables, then derived keys), ``speed_rpm`` [rpm] and ``load_pressure`` [Pa];
        auxiliary variables only feed the derived keys.
    """
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
    """Refuse a study whose evaluations would not fit (row cap, memory, disk), before anything runs.

    Parameters
    ----------
    n_rows : int
        Evaluations (designs x operating points).
    field : str
        The spec field that sets their number (named by the InputError).
    out_dir : pathlib.Path
        The study folder (its disk's free space counts).
    what : str
        How the number came about, for the message.
    """
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
