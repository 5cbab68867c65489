"""The optimiser's evaluations: populations of designs run at every operating point on dask, cached by vector.

Each batch of new designs is one sweep folder (``generations/gen-NNNN/``,
:func:`studies.sweeps.design.runner.evaluate_rows`), so a rerun of the optimisation reads back
every batch already computed instead of running it again. A design's record aggregates its
outputs over the operating points (:func:`design_records`): objectives by their ``mean`` or
``worst``, constraints at their worst.
"""

from __future__ import annotations

import time

import numpy as np

from geometry.errors import InputError
from studies.sweeps.design import runner, study
from studies.sweeps.design.front import constraint_vector, objective_vector
from studies.sweeps.design.spec import DesignSpec, design_inputs
from studies.sweeps.design.study import Study
from studies.sweeps.pump import parse_warnings


class Evaluator:
    """Evaluate populations (points of the optimiser's space) on dask; cache each design's record by its vector.

    Parameters
    ----------
    ctx : Study
        The study (spec, cluster, folder, outputs catalogue, stress calibration).
    fixed : dict
        The inputs every evaluation row shares (:func:`studies.sweeps.design.study.fixed_inputs`).
    module : str
        The sweep model that evaluates a row.
    batch_size : int, optional
        Evaluations per dask task (default: automatic).
    """

    def __init__(self, ctx: Study, fixed: dict, module: str, batch_size: int | None = None):
        self.ctx, self.spec, self.fixed, self.module, self.batch_size = ctx, ctx.spec, fixed, module, batch_size
        self.cache: dict = {}
        self.batches = 0
        self.computed = self.skipped = 0
        self.eval_seconds = 0.0
        self.objectives = ctx.spec.objectives
        self.constraints = ctx.spec.constraints
        self.n_g = len(self.constraints) + 1

    def values_of(self, z) -> dict:
        """The variables' values at a point of the optimiser's space.

        Parameters
        ----------
        z : sequence of float

        Returns
        -------
        dict
            {variable: value in its unit}.
        """
        return {v.name: v.from_opt(float(x)) for v, x in zip(self.spec.variables, z)}

    def evaluate(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Objective and constraint vectors of a population.

        Parameters
        ----------
        Z : numpy.ndarray
            (designs, variables) in the optimiser's space.

        Returns
        -------
        F : numpy.ndarray
            (designs, objectives), minimised (:func:`~studies.sweeps.design.front.objective_vector`).
        G : numpy.ndarray
            (designs, constraints + 1), g <= 0 when met (:func:`~studies.sweeps.design.front.constraint_vector`).
        """
        Z = np.atleast_2d(np.asarray(Z, dtype=float))
        keys = [tuple(float(x) for x in z) for z in Z]
        new = [k for k in dict.fromkeys(keys) if k not in self.cache]
        if new:
            self._run(new)
        F = np.array([self.cache[k]["F"] for k in keys])
        G = np.array([self.cache[k]["G"] for k in keys])
        return F, G

    def _run(self, new: list[tuple]) -> None:
        """Evaluate new designs as one sweep folder; a design whose derived keys fail is recorded as failed."""
        spec = self.spec
        designs, invalid = [], {}
        for k in new:
            values = self.values_of(k)
            try:
                if spec.model_kind == "pump":
                    design_inputs(spec, values)
                designs.append((k, values))
            except InputError as exc:
                invalid[k] = str(exc)
        self.batches += 1
        folder = self.ctx.out / "generations" / f"gen-{self.batches:04d}"
        rows = study.rows_for(spec, [v for _, v in designs], self.ctx.calibration)
        t0 = time.perf_counter()
        try:
            df, summ = runner.evaluate_rows(self.ctx.cluster, folder, self.module, self.fixed, rows,
                                            group=len(spec.points), batch_size=self.batch_size, progress=False,
                                            desc=folder.name)
        except InputError as exc:
            if exc.field == "--out":
                raise InputError("--out", f"{self.ctx.out} holds an optimisation this spec does not replay "
                                          f"({folder.name} differs); pass --force to start over") from None
            raise
        self.eval_seconds += time.perf_counter() - t0
        self.computed += summ.get("computed", 0)
        self.skipped += summ.get("skipped", 0)
        for (k, values), rec in zip(designs, design_records(spec, self.ctx.catalogue, df, len(designs))):
            self.cache[k] = self._fg(dict(rec, values=values, generation_folder=folder.name))
        for k, msg in invalid.items():
            self.cache[k] = self._fg({"values": self.values_of(k), "ok": False, "error": msg, "objectives": {},
                                      "constraints": {}, "points": []})

    def _fg(self, rec: dict) -> dict:
        """The record with its F and G."""
        rec["F"], rec["G"] = objective_vector(self.objectives, rec), constraint_vector(self.constraints, rec)
        return rec

    @property
    def records(self) -> list[dict]:
        """Every design evaluated so far."""
        return list(self.cache.values())

    def feasible(self) -> int:
        """How many designs evaluated so far meet every constraint.

        Returns
        -------
        int
        """
        return sum(1 for r in self.cache.values() if all(x <= 0 for x in r["G"]))


def design_records(spec: DesignSpec, catalogue: dict, df, n_designs: int) -> list[dict]:
    """Per design: objectives aggregated over the operating points, constraints at their worst, per-point values.

    Parameters
    ----------
    spec : DesignSpec
    catalogue : dict
        The outputs (:mod:`studies.sweeps.design.outputs`).
    df : pandas.DataFrame
        The evaluation rows (design-major: row = design x points + point).
    n_designs : int

    Returns
    -------
    list of dict
        ``ok`` (every point ok and every output finite), ``status`` per point, ``objectives``
        {output: aggregate}, ``constraints`` {output: worst value, or (min, max) for a two-sided
        one}, ``points`` (each point's values), ``warnings`` and, for a failed design, ``error``.
    """
    npts = len(spec.points)
    names = list(dict.fromkeys([o.output for o in spec.objectives] + [c.output for c in spec.constraints]))
    mats = {n: runner.output_matrix(df, catalogue[n], n_designs, npts) for n in names}
    status = np.array(["missing"] * (n_designs * npts), dtype=object)
    errors = [None] * (n_designs * npts)
    warns = [[] for _ in range(n_designs * npts)]
    for r in df.to_dict("records"):
        status[int(r["row"])] = r["status"]
        errors[int(r["row"])] = r.get("error")
        warns[int(r["row"])] = parse_warnings(r.get("warnings"))
    status = status.reshape(n_designs, npts)
    labels = spec.point_labels
    return [_record(spec, (status[i], errors[i * npts:(i + 1) * npts], warns[i * npts:(i + 1) * npts]),
                    {n: m[i] for n, m in mats.items()}, labels) for i in range(n_designs)]


def _record(spec: DesignSpec, rows: tuple, vals: dict, labels: list) -> dict:
    """One design's record from its points' (status, errors, warnings) and its outputs' values per point."""
    status, errors, warns = rows
    npts = len(spec.points)
    ok = bool((status == "ok").all()) and all(np.isfinite(v).all() for v in vals.values())
    rec = {"ok": ok, "status": list(status), "objectives": {}, "constraints": {}, "points": [],
           "warnings": [{"code": w["code"], "message": (f"{labels[j]}: " if npts > 1 else "") + w["message"]}
                        for j in range(npts) for w in warns[j]]}
    if not ok:
        bad = [j for j in range(npts) if status[j] != "ok"]
        rec["error"] = (errors[bad[0]] or status[bad[0]]) if bad else \
            "missing output: " + ", ".join(n for n, v in vals.items() if not np.isfinite(v).all())
    for o in spec.objectives:
        rec["objectives"][o.output] = float(study.aggregate(vals[o.output][None, :], o.aggregate, o.sense)[0])
    for c in spec.constraints:
        v = vals[c.output]
        if c.low is not None and c.high is not None:
            rec["constraints"][c.output] = (float(v.min()), float(v.max()))
        else:
            rec["constraints"][c.output] = float(v.max() if c.high is not None else v.min())
    for j, p in enumerate(spec.points):
        rec["points"].append({**point_json(p), **{n: study.finite_or_none(v[j]) for n, v in vals.items()}})
    return rec


def point_json(p: dict) -> dict:
    """An operating point as the JSON reports it.

    Parameters
    ----------
    p : dict
        ``{"speed_rpm": rpm, "load_pressure": Pa}`` (either may be absent).

    Returns
    -------
    dict
        ``{"speed_rpm": rpm, "load_pressure_mpa": MPa}``.
    """
    d = {}
    if "speed_rpm" in p:
        d["speed_rpm"] = p["speed_rpm"]
    if "load_pressure" in p:
        d["load_pressure_mpa"] = p["load_pressure"] / 1e6
    return d
