"""What a sensitivity and an optimisation study share: the study's context, the base model, the checks of the
variables against it, the evaluation rows (designs x operating points), the aggregation of outputs.

The reed stress calibration both use is :mod:`studies.sweeps.design.calibration`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geometry.errors import InputError
from studies.outputs import finite_or_none  # noqa: F401  (used as study.finite_or_none)
from studies.sweeps.design.spec import DesignSpec, _q, catalogue_of, design_inputs

#: the inputs of an evaluation row that set the operating point, not a model-file key
OPERATING_INPUTS = ("speed_rpm", "load_pressure")
EVALUATE = "studies.sweeps.design.evaluate"
FEA_TASKS = "studies.sweeps.design.fea_tasks"
BASE_MODEL_FILE = "base_model.toml"


@dataclass(frozen=True)
class Study:
    """What every stage of a running study reads.

    Parameters
    ----------
    spec : DesignSpec
        The study's spec.
    model : lumped.model.pump_model.PumpModel or None
        The base model with the spec's ``[fixed]`` keys (:func:`base_model`; None for a module model).
    base_path : str or None
        The base model's file in the study folder (:func:`write_base_model`), which the workers read.
    cluster : studies.sweeps.cluster.Cluster
        Where the evaluations run.
    out : pathlib.Path
        The study folder.
    catalogue : dict
        The outputs the spec may name (:func:`outputs_catalogue`).
    progress : bool
        Progress on stderr.
    calibration : dict, optional
        The reed stress calibration (:func:`studies.sweeps.design.calibration.calibrate`).
    """

    spec: DesignSpec
    model: object
    base_path: str | None
    cluster: object
    out: Path
    catalogue: dict
    progress: bool = True
    calibration: dict | None = None

    @property
    def positions(self) -> list[str]:
        """The base model's valves that are reeds with a geometry (``inlet``, ``delivery``)."""
        return reed_positions(self.model) if self.model is not None else []


# --------------------------------------------------------------------------- base model and checks
def base_model(spec: DesignSpec):
    """The base model of a study: the spec's model with its ``[fixed]`` keys applied.

    Parameters
    ----------
    spec : DesignSpec

    Returns
    -------
    lumped.model.pump_model.PumpModel or None
        None for a module model.
    """
    if spec.model_kind != "pump":
        return None
    from lumped.model.model_file import load_model, with_values

    model = load_model(spec.model, field="model")
    for k, v in spec.fixed:
        try:
            model = with_values(model, {k: list(v) if isinstance(v, tuple) else v})
        except InputError as exc:
            raise InputError(f"fixed.{_q(k)}", exc.message if exc.field.endswith(k) else
                             f"{exc.field}: {exc.message}") from None
    return model


def outputs_catalogue(spec: DesignSpec) -> dict:
    """The outputs a study's spec may name.

    Parameters
    ----------
    spec : DesignSpec

    Returns
    -------
    dict of str to Output
        The pump's (:data:`studies.sweeps.design.outputs.PUMP_OUTPUTS`) or the module's.
    """
    return catalogue_of(spec.model, spec.model_kind)


def design_values_inputs(spec: DesignSpec, values: dict) -> dict:
    """The evaluation inputs of a design: :func:`~studies.sweeps.design.spec.design_inputs` for a pump model, the
    variables themselves for a module model.

    Parameters
    ----------
    spec : DesignSpec
    values : dict
        {variable: value} in each variable's unit.

    Returns
    -------
    dict
    """
    return design_inputs(spec, values) if spec.model_kind == "pump" else dict(values)


def model_keys(inputs: dict) -> dict:
    """The model-file keys among a design's inputs (not its operating point), a tuple as a list (a TOML array).

    Parameters
    ----------
    inputs : dict
        A design's evaluation inputs.

    Returns
    -------
    dict
    """
    return {k: (list(x) if isinstance(x, tuple) else x) for k, x in inputs.items() if k not in OPERATING_INPUTS}


def apply_design(model, spec: DesignSpec, values: dict):
    """The base model with a design's key paths and derived keys set.

    Parameters
    ----------
    model : lumped.model.pump_model.PumpModel
    spec : DesignSpec
    values : dict
        {variable: value} in each variable's unit.

    Returns
    -------
    lumped.model.pump_model.PumpModel
    """
    from lumped.model.model_file import with_values

    inputs = design_inputs(spec, values)
    return with_values(model, {k: v for k, v in inputs.items() if k not in OPERATING_INPUTS})


def check_variables(spec: DesignSpec, model) -> None:
    """Check every variable against the base model before anything runs.

    Each end of each range (the 0.1 % and 99.9 % quantiles of a distribution, each level) with
    the other variables at their centre, and the centre design itself; operating variables
    against their declared bounds.

    Parameters
    ----------
    spec : DesignSpec
    model : lumped.model.pump_model.PumpModel or None
        The base model (None for a module model, whose ``check(name, value)`` vets the values).

    Raises
    ------
    InputError
        Naming the variable and the end (``variables."valves.geometry.thickness".low``).
    """
    if spec.model_kind == "module":
        _check_module_variables(spec)
        return
    centre = {v.name: v.centre() for v in spec.variables}
    _check_centre(spec, model, centre)
    for v in spec.variables:
        _check_ends(spec, model, v, centre)


def _check_module_variables(spec: DesignSpec) -> None:
    """A module model's ``check(name, value)`` on each variable's check points."""
    chk = getattr(__import__(spec.model, fromlist=["x"]), "check", None)
    for v in spec.variables if chk is not None else ():
        for x in v.check_points():
            try:
                chk(v.name, x)
            except InputError as exc:
                raise InputError(f"variables.{_q(v.name)}", exc.message) from None


def _check_centre(spec: DesignSpec, model, centre: dict) -> None:
    """The centre design on the base model; when it fails, each key path alone names its variable."""
    from lumped.model.model_file import with_values

    try:
        apply_design(model, spec, centre)
    except InputError as exc:
        if exc.field.startswith("derived."):     # the expression itself, not a key path: it names itself
            raise InputError(exc.field, f"at the centre of the ranges: {exc.message}") from None
        # each key path on its own (at its centre value): an unknown key names its variable. Only when the
        # centre design fails: alone, a key may break a constraint its [derived] partners restore.
        for v in spec.variables:
            if v.role == "key":
                try:
                    with_values(model, {v.name: centre[v.name]})
                except InputError as exc1:
                    raise InputError(f"variables.{_q(v.name)}", exc1.message if exc1.field.endswith(v.name) else
                                     f"{exc1.field}: {exc1.message}") from None
        raise InputError("variables", f"the design at the centre of the ranges is invalid: {exc}") from None


def _check_ends(spec: DesignSpec, model, v, centre: dict) -> None:
    """One variable's check points on the base model, the others at their centre (operating ones against their
    declared bounds)."""
    from geometry.declare import check_value
    from lumped.model.pump_model import LOAD_MPA, SPEED

    pts = v.check_points()
    names = ["low", "high"] if (v.values is None and len(pts) == 2) else [f"values[{i}]" for i in range(len(pts))]
    if v.values is None and not v.is_range:
        names = ["quantile 0.001", "quantile 0.999"]
    for end, x in zip(names, pts):
        where = f"variables.{_q(v.name)}" + (f".{end}" if end in ("low", "high") or end.startswith("values")
                                            else "")
        if v.role == "operating":
            check_value(float(x), SPEED if v.name == "speed_rpm" else LOAD_MPA, where)
            if v.name == "load_pressure_mpa" and hasattr(model, "pump"):
                from studies.sweeps.design.spec import _above_tank
                _above_tank(float(x), model, where)
            continue
        try:
            apply_design(model, spec, dict(centre, **{v.name: x}))
        except InputError as exc:
            via = "" if exc.field.endswith(v.name) or exc.field == v.name else f" ({exc.field})"
            raise InputError(where, f"{x!r} with the other variables at their centre: {exc.message}{via}") from None


def write_base_model(out: Path, model) -> str:
    """Write the base model as a complete model file in the study folder (the workers read it).

    Parameters
    ----------
    out : pathlib.Path
        The study folder.
    model : lumped.model.pump_model.PumpModel

    Returns
    -------
    str
        The file's absolute path (rewritten only when it changed).
    """
    from lumped.model.model_file import to_toml

    path = Path(out) / BASE_MODEL_FILE
    text = to_toml(model)
    if not path.is_file() or path.read_text() != text:
        tmp = path.with_suffix(".tmp")
        tmp.write_text(text)
        tmp.replace(path)
    return str(path.resolve())


def fixed_inputs(spec: DesignSpec, base_path: str | None) -> dict:
    """The inputs every evaluation row of a study shares.

    Parameters
    ----------
    spec : DesignSpec
    base_path : str or None
        The base model's file.

    Returns
    -------
    dict
        The base model file and the run settings (revolutions, stop rule, integrator and its
        tolerances, ``on_warning``); a module model's ``[fixed]`` inputs.
    """
    if spec.model_kind == "module":
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in spec.fixed}
    r = spec.run_dict
    out = {"model": base_path, "revolutions": r["revolutions"], "max_revolutions": r["max_revolutions"],
           "steady_tol": r["steady_tol"], "method": r["integrator"], "rtol": r["rtol"], "atol": r["atol"]}
    if "on_warning" in r:
        out["on_warning"] = r["on_warning"]
    return out


def evaluation_warnings(df) -> list[dict]:
    """The validity warnings of an evaluation table (:mod:`lumped.validity`), one entry per code.

    Parameters
    ----------
    df : pandas.DataFrame
        The evaluation rows (a ``row`` and a ``warnings`` column).

    Returns
    -------
    list of dict
        Per code how many evaluations carry it and the first one's message ([] for a module model:
        no ``warnings`` column).
    """
    from studies.sweeps.pump import summarize_warnings

    if "warnings" not in getattr(df, "columns", ()) or not len(df):
        return []
    return summarize_warnings(zip((f"evaluation {int(i)}" for i in df["row"]), df["warnings"]), "evaluations")


def rows_for(spec: DesignSpec, designs: list[dict], calibration: dict | None = None) -> list[dict]:
    """The evaluation rows of designs: design-major, one row per operating point.

    Parameters
    ----------
    spec : DesignSpec
    designs : list of dict
        {variable: value} per design.
    calibration : dict, optional
        The stress calibration: each row then carries the calibration factors.

    Returns
    -------
    list of dict
        The operating point (``speed_rpm`` [rpm], ``load_pressure`` [Pa]) and the design's inputs.
    """
    rows = []
    for values in designs:
        inputs = design_values_inputs(spec, values)
        inputs.update(calibration_inputs(calibration))
        for p in spec.points:
            rows.append({**p, **inputs})
    return rows


def needs_stress(spec: DesignSpec) -> bool:
    """Whether a study asks for the reed's bending stress (and so for the stress calibration).

    Parameters
    ----------
    spec : DesignSpec

    Returns
    -------
    bool
    """
    from studies.sweeps.design.outputs import STRESS_OUTPUTS

    names = set(spec.outputs) | {o.output for o in spec.objectives} | {c.output for c in spec.constraints}
    return spec.model_kind == "pump" and bool(names & set(STRESS_OUTPUTS))


def reed_positions(model) -> list[str]:
    """The valves of a model that are reeds with a geometry.

    Parameters
    ----------
    model : lumped.model.pump_model.PumpModel

    Returns
    -------
    list of str
        Among ``inlet``, ``delivery``.
    """
    return [pos for pos in ("inlet", "delivery") if getattr(model.valve(pos), "reed", None) is not None]


def calibration_inputs(cal: dict | None) -> dict:
    """The evaluation inputs that carry the stress calibration factors (the same for every design).

    Parameters
    ----------
    cal : dict or None
        :func:`studies.sweeps.design.calibration.calibrate`'s result (None: no stress is computed).

    Returns
    -------
    dict
        ``{"stress_calibration_<valve>": C}`` per reed valve ({} without a calibration).
    """
    return {f"stress_calibration_{pos}": float(m["factor"]) for pos, m in cal["models"].items()} if cal else {}


# --------------------------------------------------------------------------- aggregation
def aggregate(values: np.ndarray, how: str, sense: str = "min") -> np.ndarray:
    """Aggregate an output over the operating points.

    Parameters
    ----------
    values : numpy.ndarray
        (designs, points), in the output's unit.
    how : str
        ``mean``, or ``worst``: the largest for a minimised output (or an upper limit), the smallest
        for a maximised one (or a lower limit).
    sense : str
        ``min`` or ``max``.

    Returns
    -------
    numpy.ndarray
        (designs,); NaN if any point is missing.

    Examples
    --------
    >>> aggregate(np.array([[1.0, 3.0], [2.0, 2.0]]), "worst", "max").tolist()
    [1.0, 2.0]
    """
    if values.shape[1] == 1:
        return values[:, 0]
    if how == "mean":
        return values.mean(axis=1)
    return values.max(axis=1) if sense == "min" else values.min(axis=1)

