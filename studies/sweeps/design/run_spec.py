"""How a design study runs and what it asks for: the ``[run]``, ``[stress]``, ``[recheck]`` and ``[constraints]``
tables of a sensitivity or optimisation spec (CONTRACT.md), checked through :mod:`studies.sweeps.schema`.

Defaults worth knowing (each evaluation is one fast-path pump run to cyclic steady state):

- ``revolutions = 2``, then until the steady-state test passes (:class:`lumped.run.revolutions.StopRule`),
  at most ``max_revolutions`` (default max(20, 4 revolutions));
- ``rtol = 1e-4``, ``atol = 1e-6`` on the fast path (1e-6 on the reference): valve losses need a
  tighter rtol than the fast path's own 1e-3 (CONTRACT.md, the ``[run]`` table);
- sensitivity: Sobol with 256 samples (a power of two) or Morris with 20 trajectories;
- optimize: NSGA-II for several objectives, differential evolution for one, 40 x 40.
"""

from __future__ import annotations

import re

from geometry.errors import InputError
from studies.sweeps import schema
from studies.sweeps.design.variables import Constraint, Objective
from studies.sweeps.schema import Key

#: the [run] keys both commands read
COMMON_RUN = {"seed": Key("int", 0, bounds=(0, 2**32 - 1)), "revolutions": Key("int", 2, bounds=(2, 10_000)),
              "integrator": Key("choice", "fast", choices=("fast", "reference")),
              # a result with a validity warning (lumped.validity): kept and flagged, or excluded
              "on_warning": Key("choice", None, choices=("flag", "exclude"))}
SENSITIVITY_RUN = {"method": Key("choice", "sobol", choices=("sobol", "morris")),
                   "num_levels": Key("int", 4, bounds=(2, 100)),
                   "num_resamples": Key("int", 200, bounds=(10, 100_000)),
                   "conf_level": Key("number", 0.95, bounds=(0.5, 1.0), below=1.0)}
OPTIMIZE_RUN = {"aggregate": Key("choice", "mean", choices=("mean", "worst")),
                "population": Key("int", 40, bounds=(4, 100_000)), "generations": Key("int", 40, bounds=(1, 100_000)),
                "max_evaluations": Key("int", 5_000_000, bounds=(1, 10**9))}
#: keys read with a default that depends on another key
_DEPENDENT = {"max_revolutions", "steady_tol", "rtol", "atol"}
RUN_KEYS = {"sensitivity": {*COMMON_RUN, *SENSITIVITY_RUN, *_DEPENDENT, "samples", "outputs"},
            "optimize": {*COMMON_RUN, *OPTIMIZE_RUN, *_DEPENDENT, "objectives", "algorithm"}}
#: one spec may serve both commands (CONTRACT's minimal spec lists outputs, objectives and samples): the other
#: command's keys of that example are accepted and ignored
SHARED_RUN_KEYS = {"sensitivity": {"objectives"}, "optimize": {"outputs", "samples"}}
RECHECK_KEYS = {"enabled": Key("bool", True), "tolerance_pct": Key("number", positive=True),
                "stress_tolerance_pct": Key("number", 10.0, positive=True), "mesh_size": Key("number", positive=True),
                "max_designs": Key("int", 1000, bounds=(1, 100_000))}
REED_STRESS_KEYS = {"safety_factor": Key("number", 1.5, positive=True, minimum=1.0),
                    "yield_stress_mpa": Key("number", positive=True),
                    "loop_margin": Key("number", 1.0, positive=True, minimum=1.0)}
_OBJECTIVE = re.compile(r"\s*(max|min)\s+(?:(mean|worst)\(\s*([A-Za-z0-9_]+)\s*\)|([A-Za-z0-9_]+))\s*")


def parse_run(run, command: str) -> dict:
    """Check the ``[run]`` table of a spec.

    Parameters
    ----------
    run : dict
        The table.
    command : str
        ``sensitivity`` or ``optimize``.

    Returns
    -------
    dict
        Every key of the command with its default filled in; ``outputs`` (sensitivity) or
        ``objectives`` (optimize, :class:`~studies.sweeps.design.variables.Objective`) as tuples.
    """
    schema.table(run, "run")

    def hint(k):
        return " (an optimize key)" if k in RUN_KEYS["optimize"] else (
            " (a sensitivity key)" if k in RUN_KEYS["sensitivity"] else "")

    schema.check_keys({k: v for k, v in run.items() if k not in SHARED_RUN_KEYS[command]}, RUN_KEYS[command],
                      "run", hint)
    out = _run_common(run)
    out.update(_run_sensitivity(run) if command == "sensitivity" else _run_optimize(run))
    return out


def _run_common(run: dict) -> dict:
    """Seed, revolutions and stop rule, integrator and tolerances."""
    out = schema.read_keys(run, COMMON_RUN, "run")
    # at least `revolutions`, then until the cyclic steady-state test passes (lumped.run.revolutions.StopRule;
    # each row warm-started from a solved neighbour's state: two revolutions for most)
    rev = out["revolutions"]
    out["max_revolutions"] = schema.integer(run.get("max_revolutions", max(20, 4 * rev)), "run.max_revolutions",
                                            rev, 100_000)
    from lumped.run.revolutions import STEADY_TOL

    out["steady_tol"] = schema.read_key(run.get("steady_tol", STEADY_TOL), Key("number", positive=True, below=0.1),
                                        "run.steady_tol")
    # valve losses need a tighter rtol than the fast path's 1e-3 (CONTRACT.md, the [run] table)
    defaults = {"rtol": 1e-4, "atol": 1e-6} if out["integrator"] == "fast" else {"rtol": 1e-6, "atol": 1e-6}
    for k, d in defaults.items():
        out[k] = schema.read_key(run.get(k, d), Key("number", positive=True, below=0.1), f"run.{k}")
    return out


def _run_sensitivity(run: dict) -> dict:
    """Method, samples, Morris levels, bootstrap, outputs."""
    out = schema.read_keys(run, SENSITIVITY_RUN, "run")
    n = schema.integer(run.get("samples", 256 if out["method"] == "sobol" else 20), "run.samples", 2, 10**9)
    if out["method"] == "sobol" and n & (n - 1):
        lo = 1 << (n.bit_length() - 1)
        raise InputError("run.samples", f"Sobol sampling needs a power of 2 (its balance), got {n}; use {lo} or "
                                        f"{2 * lo}")
    out["samples"] = n
    if out["method"] == "morris" and out["num_levels"] % 2:
        raise InputError("run.num_levels", f"Morris screening needs an even number of levels, got {out['num_levels']}")
    outs = run.get("outputs")
    if not isinstance(outs, list) or not outs or not all(isinstance(o, str) for o in outs):
        raise InputError("run.outputs", "missing: list the outputs to analyse, e.g. [\"delivery_cc_per_rev\"]")
    if len(set(outs)) != len(outs):
        raise InputError("run.outputs", "has repeated outputs")
    out["outputs"] = tuple(outs)
    return out


def _run_optimize(run: dict) -> dict:
    """Objectives, their aggregation over the operating points, algorithm, population and generations."""
    objs = run.get("objectives")
    if not isinstance(objs, list) or not objs or not all(isinstance(o, str) for o in objs):
        raise InputError("run.objectives", "missing: list them, e.g. [\"max volumetric_efficiency\", "
                                           "\"min valve_loss_j\"]")
    out = schema.read_keys(run, OPTIMIZE_RUN, "run")
    parsed = []
    for i, o in enumerate(objs):
        m = _OBJECTIVE.fullmatch(o)
        if not m:
            raise InputError(f"run.objectives[{i}]", f"expected \"max NAME\", \"min NAME\" or "
                                                     f"\"max mean(NAME)\" / \"min worst(NAME)\", got {o!r}")
        parsed.append(Objective(m.group(1), m.group(3) or m.group(4), m.group(2) or out["aggregate"]))
    if len({o.output for o in parsed}) != len(parsed):
        raise InputError("run.objectives", "names an output twice")
    out["objectives"] = tuple(parsed)
    algo = schema.read_key(run.get("algorithm", "nsga2" if len(parsed) > 1 else "de"),
                           Key("choice", choices=("nsga2", "de")), "run.algorithm")
    if algo == "de" and len(parsed) > 1:
        raise InputError("run.algorithm", "differential evolution optimises one objective; use nsga2")
    out["algorithm"] = algo
    return out


def parse_stress(d) -> dict:
    """Check the ``[stress]`` table: the reed's yield stress and the calibration of its bending-stress estimate.

    Parameters
    ----------
    d : dict
        The table.

    Returns
    -------
    dict
        ``yield_stress_mpa`` [MPa] (default: Delrin's, :data:`fea.reed_stress.YIELD_STRESS_DELRIN`),
        ``safety_factor`` (1 until a ``reed_stress`` constraint sets it), ``calibration``
        (``base``, ``conservative`` or the factor itself) and ``mesh_size`` [m] (None: the FEA's default).
    """
    schema.table(d, "stress")
    schema.check_keys(d, ("yield_stress_mpa", "calibration", "mesh_size"), "stress")
    from fea.reed_stress import YIELD_STRESS_DELRIN

    out = schema.read_keys(d, {"yield_stress_mpa": Key("number", YIELD_STRESS_DELRIN / 1e6, positive=True)}, "stress")
    out["safety_factor"] = 1.0
    cal = d.get("calibration", "base")
    if isinstance(cal, str):
        schema.read_key(cal, Key("choice", choices=("base", "conservative")), "stress.calibration")
    else:
        cal = schema.number(cal, "stress.calibration", positive=True)
    out["calibration"] = cal
    out["mesh_size"] = (None if "mesh_size" not in d else
                        schema.number(d["mesh_size"], "stress.mesh_size", positive=True))
    return out


def parse_recheck(d) -> dict:
    """Check the ``[recheck]`` table: the multi-fidelity re-check of an optimisation's front.

    Parameters
    ----------
    d : dict
        The table.

    Returns
    -------
    dict
        ``enabled``, ``tolerance_pct`` [%] (the solid FEA against the analytic reed,
        default :data:`studies.validation.reed_check.DEFAULT_TOLERANCE_PCT`),
        ``stress_tolerance_pct`` [%], ``mesh_size`` [m] (None: the FEA's default) and ``max_designs``.
    """
    from studies.validation.reed_check import DEFAULT_TOLERANCE_PCT

    schema.table(d, "recheck")
    schema.check_keys(d, RECHECK_KEYS, "recheck")
    out = schema.read_keys({"tolerance_pct": DEFAULT_TOLERANCE_PCT, **d}, RECHECK_KEYS, "recheck")
    return {"mesh_size": None, **out}


def parse_constraints(d, kind: str, stress: dict, known) -> tuple[list, dict]:
    """Check the ``[constraints]`` table of an optimisation.

    Parameters
    ----------
    d : dict
        The table: ``OUTPUT = { max = X }``, ``{ min = X }`` or both, and ``reed_stress = {...}``.
    kind : str
        The model's kind (``pump`` or ``module``; the reed stress needs a pump).
    stress : dict
        The ``[stress]`` table (:func:`parse_stress`); ``reed_stress`` sets its yield stress and safety factor.
    known : callable
        ``known(output, where)`` refuses an output the model does not have.

    Returns
    -------
    constraints : list of Constraint
    stress : dict
        ``stress`` updated by ``reed_stress``.
    """
    schema.table(d, "constraints", "a table: OUTPUT = { max = X } or { min = X }, reed_stress = {...}")
    constraints = []
    for name, c in d.items():
        where = f"constraints.{name}"
        if name == "reed_stress":
            con, stress = _reed_stress(c, where, kind, stress)
            constraints.append(con)
            continue
        known(name, where)
        if not isinstance(c, dict) or not c or set(c) - {"min", "max"}:
            raise InputError(where, "expected { max = X }, { min = X } or both")
        lo = schema.number(c["min"], f"{where}.min") if "min" in c else None
        hi = schema.number(c["max"], f"{where}.max") if "max" in c else None
        if lo is not None and hi is not None and not hi > lo:
            raise InputError(f"{where}.max", f"must exceed min ({lo:g})")
        constraints.append(Constraint(name, lo, hi, source=where))
    return constraints, stress


def _reed_stress(c, where: str, kind: str, stress: dict) -> tuple[Constraint, dict]:
    """The reed's bending stress below yield / safety factor (in the loop, tightened by ``loop_margin``)."""
    if kind != "pump":
        raise InputError(where, "needs a pump model with reed valves")
    schema.table(c, where, "a table: { safety_factor = 1.5, yield_stress_mpa = 63.0 }")
    schema.check_keys(c, REED_STRESS_KEYS, where)
    v = schema.read_keys({"yield_stress_mpa": stress["yield_stress_mpa"], **c}, REED_STRESS_KEYS, where)
    stress = dict(stress, yield_stress_mpa=v["yield_stress_mpa"], safety_factor=v["safety_factor"])
    con = Constraint("reed_stress_mpa", high=v["yield_stress_mpa"] / v["safety_factor"], source=where,
                     loop_margin=v["loop_margin"])
    return con, stress
