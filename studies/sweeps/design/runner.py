"""Designs x operating points on dask, through the sweep machinery (:func:`studies.sweeps.sweep.run_sweep`).

A study folder (``--out``) holds the spec (``spec.toml``), its digest and one sweep folder per
batch of evaluations (``runs/`` for a sensitivity study, ``generations/gen-NNNN/`` for an
optimisation, ``calibration/``, ``recheck-fea/``, ``recheck-reference/``). Each is a regular
resumable sweep store: a rerun of the same command skips every evaluation already recorded,
and a failed evaluation is recorded with its status and message.
"""

from __future__ import annotations

import math
import shutil
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from geometry.errors import InputError
from studies.sweeps import sweep
from studies.sweeps.cluster import Cluster  # noqa: F401  (runner.Cluster: the studies' cluster)

STAMP = ".design-digest"
SPEC_COPY = "spec.toml"


def check_study_arguments(spec, command: str, out, *, scheduler=None, workers=None, batch_size=None, force=False,
                          progress=True) -> None:
    """InputError naming the first bad argument of a study entry point (run_sensitivity, run_optimize)."""
    from geometry import validate
    from studies.sweeps.design.spec import DesignSpec

    if not isinstance(spec, DesignSpec) or spec.command != command:
        raise InputError("spec", f"expected a {command} DesignSpec (studies.sweeps.design.spec.load_spec(path, "
                                 f"{command!r})), got {getattr(spec, 'command', type(spec).__name__)!r}")
    validate.path(out, "out")
    if scheduler is not None:
        validate.address(scheduler, "scheduler")
    if workers is not None:
        validate.number(workers, "workers", integer=True, bounds=(1, 1024))
    if batch_size is not None:
        validate.number(batch_size, "batch_size", integer=True, bounds=(1, 1_000_000))
    validate.boolean(force, "force")
    validate.boolean(progress, "progress")


# --------------------------------------------------------------------------- the study folder
def prepare_study(out: Path, spec, force: bool, subfolders: tuple[str, ...]) -> Path:
    """Create the study folder, or check that it holds this very study (else refuse, or start over with force)."""
    from studies.outputs import MARKER, check_output_dir, prepare_output_dir

    out = Path(out)
    check_output_dir(out, "--out", force, kind=spec.command)
    stamp = out / STAMP
    if out.is_dir() and (out / MARKER).exists() and stamp.is_file():
        old = stamp.read_text().split()
        computed = any((out / name).exists() for name in subfolders)
        if old and old[0] != spec.digest:
            if not force and computed:      # a study with nothing computed yet (refused, stopped) is replaced
                raise InputError("--out", f"{out} holds a different {spec.command} study (its spec differs); choose "
                                          "another folder or pass --force to start over")
            for name in subfolders:
                if (out / name).is_dir():
                    shutil.rmtree(out / name)
    elif out.is_dir() and any(out.iterdir()) and (out / MARKER).exists() and not stamp.is_file():
        # a valvelab folder of another kind (a sweep...): refuse unless forced
        if not force:
            raise InputError("--out", f"{out} holds other valvelab results; choose another folder or pass --force")
    prepare_output_dir(out, "--out", force, kind=spec.command)
    stamp.write_text(f"{spec.digest} {spec.command}\n")
    if spec.text:
        (out / SPEC_COPY).write_text(spec.text)
    return out


def _factor_of(name: str, values: list):
    nums = [v for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)]
    if len(nums) == len(values):
        if all(isinstance(v, int) for v in values):
            return sweep.Factor(name, low=float(min(values)), high=float(max(values)), integer=True)
        return sweep.Factor(name, low=float(min(nums)), high=float(max(nums)))
    uniq = []
    for v in values:
        if v not in uniq:
            uniq.append(v)
    return sweep.Factor(name, values=tuple(uniq))


def sweep_spec_of(model_module: str, rows: list[dict], fixed: dict) -> sweep.SweepSpec:
    """A SweepSpec describing explicit rows (their columns) with fixed inputs ``fixed``."""
    names: list[str] = []
    for r in rows:
        for k in r:
            if k not in names:
                names.append(k)
    factors = tuple(_factor_of(n, [r[n] for r in rows if n in r]) for n in names)
    return sweep.SweepSpec(model=model_module, sampler="given", factors=factors,
                           fixed=tuple(fixed.items()), samples=len(rows))


def evaluate_rows(cluster: Cluster, folder: Path, model_module: str, fixed: dict, rows: list[dict],
                  **options):
    """Evaluate explicit rows into a sweep folder (resumable).

    Parameters
    ----------
    cluster : Cluster
        Started only if something is left to compute.
    folder : pathlib.Path
        The sweep folder of these rows.
    model_module : str
        The sweep model.
    fixed : dict
        The inputs every row shares.
    rows : list of dict
        The rows' other inputs (the same keys in each).
    **options
        ``group`` (consecutive rows that belong together, a design's operating points, stay in one
        batch), ``batch_size``, ``progress``, ``desc``: as :class:`studies.sweeps.sweep.SweepRun`.

    Returns
    -------
    results : pandas.DataFrame
        Every row in order, with a ``row`` column (its index in ``rows``).
    summary : dict
        :func:`studies.sweeps.sweep.run_sweep`'s.
    """
    import pandas as pd

    if not rows:
        return pd.DataFrame(), {"computed": 0, "skipped": 0, "failed": 0}
    for r in rows:
        missing = [k for k in rows[0] if k not in r]
        if missing or len(r) != len(rows[0]):
            raise ValueError("evaluate_rows: every row needs the same inputs")
    spec = sweep_spec_of(model_module, rows, fixed)
    folder = Path(folder)
    done = (folder / "results.parquet").is_file() and not (folder / sweep.PARTS_DIR).exists()
    client = None if done else cluster.get()      # started first: the batch size counts its workers
    run = sweep.SweepRun(**{"desc": "designs", **options})
    group, batch_size = run.group, run.batch_size
    if batch_size is None:
        n_groups = math.ceil(len(rows) / group)
        # a few tasks per worker balance the load; small batches (an optimiser generation) are not split finer
        per = max(1, min(max(1, sweep.MAX_BATCH // group), math.ceil(n_groups / (4 * cluster.workers))))
        batch_size = per * group
    else:
        batch_size = max(group, (batch_size // group) * group)
    summary = sweep.run_sweep(spec, folder, replace(run, client=client, designs=rows, batch_size=batch_size))
    mod = sweep.load_model(model_module)
    df = sweep.open_store(folder, spec, mod, "parquet").read()
    df = df.rename(columns={"design_id": "row"})
    if len(df) != len(rows):
        raise RuntimeError(f"{folder}: {len(df)} of {len(rows)} evaluations recorded (interrupted?)")
    return df, summary


def output_matrix(df, output, n_designs: int, n_points: int, ok_only: bool = True) -> np.ndarray:
    """The values of ``output`` (an :class:`~studies.sweeps.design.outputs.Output`) as (designs, points); NaN where the
    evaluation failed or the value is missing. Rows are design-major (row = design * n_points + point)."""
    vals = np.full(n_designs * n_points, np.nan)
    recs = df.to_dict("records")
    for r in recs:
        if ok_only and r.get("status") != "ok":
            continue
        v = output.value(r)
        if v is not None:
            vals[int(r["row"])] = v
    return vals.reshape(n_designs, n_points)


def status_counts(df) -> dict:
    if df is None or not len(df):
        return {}
    return {str(k): int(v) for k, v in df["status"].value_counts().items()}


def progress_note(msg: str, progress: bool = True) -> None:
    if progress:
        print(msg, file=sys.stderr, flush=True)
