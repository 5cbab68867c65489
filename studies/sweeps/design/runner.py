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
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from geometry.errors import InputError
from studies.sweeps import sweep
from studies.sweeps.cluster import Cluster, check_options

STAMP = ".design-digest"
SPEC_COPY = "spec.toml"


@dataclass(frozen=True)
class StudyRun:
    """How a sensitivity or optimisation study runs (the keyword arguments of its entry point).

    Parameters
    ----------
    scheduler : str, optional
        A dask scheduler's address; default a LocalCluster of ``workers`` processes.
    workers : int, optional
        Local worker processes (default: one per core).
    client : distributed.Client, optional
        An existing client to use.
    batch_size : int, optional
        Evaluations per dask task (default: automatic).
    force : bool
        Start over in a folder that holds another study.
    progress : bool
        Progress on stderr.
    """

    scheduler: str | None = None
    workers: int | None = None
    client: object = None
    batch_size: int | None = None
    force: bool = False
    progress: bool = True


def check_study_arguments(spec, command: str, out, run: StudyRun) -> None:
    """Refuse the first bad argument of a study's entry point (run_sensitivity, run_optimize), before any work.

    Parameters
    ----------
    spec : DesignSpec
        Must be a spec of ``command``.
    command : str
        ``sensitivity`` or ``optimize``.
    out : str or os.PathLike
        The study folder.
    run : StudyRun
    """
    from geometry import validate
    from studies.sweeps.design.spec import DesignSpec

    if not isinstance(spec, DesignSpec) or spec.command != command:
        raise InputError("spec", f"expected a {command} DesignSpec (studies.sweeps.design.spec.load_spec(path, "
                                 f"{command!r})), got {getattr(spec, 'command', type(spec).__name__)!r}")
    validate.path(out, "out")
    check_options(run, "workers", ("force", "progress"))


@contextmanager
def open_study(spec, out: Path, model, run: StudyRun, subfolders: tuple[str, ...]):
    """A running study: the cluster reachable, the folder prepared (:func:`prepare_study`), the base model written.

    Parameters
    ----------
    spec : DesignSpec
    out : pathlib.Path
        The study folder.
    model : lumped.model.pump_model.PumpModel or None
        The base model (None for a module model).
    run : StudyRun
    subfolders : tuple of str
        The folders the study computes into (a different spec in the folder clears them).

    Yields
    ------
    Study
        The study's context; the cluster is closed when the block ends.
    """
    from studies.sweeps.design import study

    with Cluster(run.scheduler, run.workers, run.client) as cluster:
        cluster.check_reachable()
        prepare_study(out, spec, run.force, subfolders)
        base_path = study.write_base_model(out, model) if model is not None else None
        yield study.Study(spec, model, base_path, cluster, out, study.outputs_catalogue(spec), run.progress)


# --------------------------------------------------------------------------- the study folder
def prepare_study(out: Path, spec, force: bool, subfolders: tuple[str, ...]) -> Path:
    """Create a study folder, or check that it holds this very study.

    Parameters
    ----------
    out : pathlib.Path
        The study folder.
    spec : DesignSpec
    force : bool
        Start over when it holds another study (its computed subfolders are removed).
    subfolders : tuple of str
        The folders the study computes into.

    Returns
    -------
    pathlib.Path
        ``out``, marked, with the spec's digest and a copy of its TOML.

    Raises
    ------
    InputError
        ``--out``: the folder holds a different study (or other valvelab results) and ``force`` is off.
    """
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
    """A SweepSpec describing explicit rows (the sweep runner's record of what was run).

    Parameters
    ----------
    model_module : str
        The sweep model.
    rows : list of dict
        The rows' inputs.
    fixed : dict
        The inputs every row shares.

    Returns
    -------
    SweepSpec
        Sampler ``given``, one factor per column: a range (integers or numbers) or the levels seen.
    """
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
    """An output's values over the evaluation rows of a study, as (designs, points).

    Parameters
    ----------
    df : pandas.DataFrame
        The evaluation rows, design-major (row = design x n_points + point).
    output : Output
        (:mod:`studies.sweeps.design.outputs`).
    n_designs, n_points : int
    ok_only : bool
        Only rows with status ``ok``.

    Returns
    -------
    numpy.ndarray
        In the output's unit; NaN where the evaluation failed or the value is missing.
    """
    vals = np.full(n_designs * n_points, np.nan)
    recs = df.to_dict("records")
    for r in recs:
        if ok_only and r.get("status") != "ok":
            continue
        v = output.value(r)
        if v is not None:
            vals[int(r["row"])] = v
    return vals.reshape(n_designs, n_points)
