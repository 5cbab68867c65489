"""Design sweeps: a TOML design-of-experiments run on dask, streamed to a resumable table.

The pieces, each usable alone:

- :func:`~studies.sweeps.sweep_spec.load_spec` / :func:`~studies.sweeps.sweep_spec.parse_spec`:
  the sweep file (schema in CONTRACT.md), checked field by field
  (:class:`~geometry.errors.InputError` names the field);
- :func:`~studies.sweeps.sweep_spec.sample_designs`: full-factorial grid, Latin hypercube,
  Sobol or plain random samples (``scipy.stats.qmc``, seeded), one dict of inputs per design;
- :func:`run_sweep` (here): evaluates the designs on a dask cluster (a ``LocalCluster`` by
  default, or an existing scheduler) in batches, writing each finished batch at once as a
  Parquet part file (or appended CSV rows) keyed by ``design_id``
  (:mod:`studies.sweeps.store`). A rerun on the same folder skips every design already
  recorded, so a killed sweep resumes where it stopped. A design whose evaluation raises is
  recorded with ``status = "error"`` and the message; it never stops the sweep;
- :func:`~studies.sweeps.main_effects.main_effects` /
  :func:`~studies.sweeps.main_effects.plot_main_effects`: the mean response against each factor.

A *model* is a module with ``OUTPUTS`` (output column -> "float64" | "int64" | "bool" |
"string") and ``evaluate(design: dict) -> dict``; optionally ``check(name, value)`` (raise
InputError for an unknown input or a bad value, before anything runs), ``REQUIRED``
(inputs every design needs) and ``MAIN_RESPONSES`` (what sweep-plot shows by default).
``evaluate`` may return a ``status`` (default ``"ok"``); an exception is recorded as
``"error"``. ``model = "pump"`` is the piston pump (:mod:`studies.sweeps.pump`); any
importable module name works. An ``evaluate`` that takes ``warm`` starts each design from the
nearest one solved before it in its batch (:mod:`studies.sweeps.locality`).
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from geometry import validate
from geometry.errors import InputError
from studies.sweeps.cluster import CONNECT_TIMEOUT, Cluster, check_options, default_workers  # noqa: F401
from studies.sweeps.main_effects import main_effects, plot_main_effects  # noqa: F401
from studies.sweeps.schema import META_COLUMNS  # noqa: F401
from studies.sweeps.store import (  # noqa: F401
    DESIGNS_FILE, FORMATS, PARTS_DIR, SPEC_FILE, CsvStore, ParquetStore, open_store, read_results, status_counts,
    table_schema)
from studies.sweeps.sweep_spec import (  # noqa: F401
    MAX_DESIGNS, SAMPLERS, Factor, SweepSpec, check_spec, load_model, load_spec, parse_spec, sample_designs,
    spec_to_toml, with_base_model)

#: most designs per dask task (a task of pump designs then takes a second or two: a kill loses little work)
MAX_BATCH = 400


@dataclass(frozen=True)
class SweepRun:
    """How a sweep runs (the keyword arguments of :func:`run_sweep`).

    Parameters
    ----------
    fmt : str
        Results table format: ``parquet`` or ``csv``.
    scheduler : str, optional
        Address of a dask scheduler to connect to (``tcp://host:8786``).
    client : distributed.Client, optional
        An existing client to use (then neither ``scheduler`` nor ``n_workers`` is used).
    n_workers : int, optional
        Processes of the LocalCluster started otherwise (default: one per core).
    batch_size : int, optional
        Designs per dask task (default: ~20 tasks per worker, ~8 for a warm-starting model).
    force : bool
        Start over in a folder that holds another sweep.
    retry_failed : bool
        Recompute the designs recorded with status ``error``.
    progress : bool
        A progress bar on stderr.
    designs : list of dict, optional
        Run these designs ({factor: value}, in order) instead of sampling the spec's.
    desc : str
        The progress bar's label.
    group : int
        Runs of that many consecutive designs belong together (a design's operating points)
        and stay together in a batch.
    """

    fmt: str = "parquet"
    scheduler: str | None = None
    client: object = None
    n_workers: int | None = None
    batch_size: int | None = None
    force: bool = False
    retry_failed: bool = False
    progress: bool = True
    designs: list | None = None
    desc: str = "sweep"
    group: int = 1


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


def _evaluate_one(model, design_id: int, design: dict, warm) -> dict:
    """One design's row: its inputs, the model's outputs, status and error, its CPU seconds."""
    row = {"design_id": int(design_id), **design}
    t0 = time.process_time()
    try:
        out = dict(model.evaluate(design) if warm is None else model.evaluate(design, warm=warm))
        row.update({k: out.get(k) for k in model.OUTPUTS})
        row["status"] = str(out.get("status", "ok"))
        row["error"] = out.get("error")
    except Exception as exc:  # noqa: BLE001 - recorded per design, by design
        row.update({k: None for k in model.OUTPUTS})
        row["status"] = "error"
        row["error"] = f"{type(exc).__name__}: {exc}"
    row["eval_seconds"] = time.process_time() - t0
    return row


def evaluate_batch(model_name: str, fixed: dict, batch: list[tuple[int, dict]]) -> list[dict]:
    """Evaluate a batch of designs with one model; runs on a dask worker.

    Parameters
    ----------
    model_name : str
        The sweep model (:func:`~studies.sweeps.sweep_spec.load_model`).
    fixed : dict
        The inputs every design shares.
    batch : list of (int, dict)
        (design_id, inputs) pairs.

    Returns
    -------
    list of dict
        One row per design: the inputs, the model outputs, ``status``, ``error`` and
        ``eval_seconds`` (CPU). An exception becomes ``status = "error"`` with its message, so
        one bad design never stops a sweep.
    """
    model = load_model(model_name)
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
    return [_evaluate_one(model, batch[i][0], {**fixed, **batch[i][1]}, None if slots is None else slots[i])
            for i in order]


def _default_batch(n_todo: int, n_workers: int, warm: bool = False) -> int:
    """Designs per dask task: ~20 tasks per worker balance the load; a model that warm-starts a design from its
    batch's neighbours (:func:`accepts_warm`) gets ~8 larger tasks per worker, so that most designs have a close
    neighbour in their batch and the per-task costs (scheduling, a Parquet part) stay small."""
    if warm:
        return max(1, min(MAX_BATCH, math.ceil(n_todo / (8 * n_workers))))
    return max(1, min(50, math.ceil(n_todo / (20 * n_workers))))


def accepts_warm(model) -> bool:
    """Whether a sweep model's ``evaluate`` takes ``warm`` (a :class:`studies.sweeps.locality.WarmSlot`).

    Parameters
    ----------
    model : module
        A sweep model.

    Returns
    -------
    bool
    """
    import inspect

    try:
        return "warm" in inspect.signature(model.evaluate).parameters
    except (TypeError, ValueError):
        return False


# --------------------------------------------------------------------------- the sweep folder
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
    (out / SPEC_FILE).write_text(spec.text or spec_to_toml(spec))


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
    """A hash of a spec and an explicit list of designs (resume safety of ``run_sweep(designs=...)``).

    Parameters
    ----------
    spec : SweepSpec
    designs : list of dict

    Returns
    -------
    str
        16 hex digits.
    """
    h = hashlib.sha256(spec.digest.encode())
    for d in designs:
        h.update(repr(sorted(d.items())).encode())
    return h.hexdigest()[:16]


# --------------------------------------------------------------------------- running
def check_run_arguments(spec, out, run: SweepRun) -> None:
    """Refuse the first bad argument of :func:`run_sweep` (types and values), before any work.

    Parameters
    ----------
    spec : SweepSpec
    out : str or os.PathLike
    run : SweepRun
    """
    if not isinstance(spec, SweepSpec):
        raise InputError("spec", f"expected a SweepSpec (studies.sweeps.load_spec(path)), got {type(spec).__name__}")
    validate.path(out, "out")
    validate.choice(run.fmt, "fmt", FORMATS)
    check_options(run, "n_workers", ("force", "retry_failed", "progress"))
    if run.designs is not None:
        if not isinstance(run.designs, (list, tuple)) or not all(isinstance(d, dict) for d in run.designs):
            raise InputError("designs", "expected a list of {factor: value} dicts")
        validate.size(max(1, len(run.designs)), "designs", limit=MAX_DESIGNS, unit="designs")


def run_sweep(spec: SweepSpec, out: str | Path, run: SweepRun | None = None, **options) -> dict:
    """Run (or resume) a sweep into a folder.

    Parameters
    ----------
    spec : SweepSpec
        The sweep (:func:`~studies.sweeps.sweep_spec.load_spec`).
    out : str or os.PathLike
        The sweep folder; a rerun resumes it.
    run : SweepRun, optional
        How it runs; or give its fields as keyword arguments (``fmt``, ``scheduler``,
        ``client``, ``n_workers``, ``batch_size``, ``force``, ``retry_failed``, ``progress``,
        ``designs``, ``desc``, ``group``; :class:`SweepRun`).

    Returns
    -------
    dict
        The summary (CONTRACT.md, "Sweeps"): designs, skipped, computed, failed, status counts,
        the results file, ``complete``, ``wall_seconds`` and ``designs_per_hour``.

    Notes
    -----
    The cluster: an existing ``client``; else one connected to ``scheduler``; else a
    ``LocalCluster`` of ``n_workers`` single-threaded processes, started and closed again.
    With ``designs`` the folder's digest covers them, so a rerun resumes only with the very
    same list. A model whose ``evaluate`` takes ``warm`` (:func:`accepts_warm`, the pump) has
    its designs sent in batches of near designs (:func:`studies.sweeps.locality.locality_order`)
    and each design started from the nearest one solved before it in its batch
    (:func:`evaluate_batch`).
    """
    run = SweepRun(**options) if run is None else run
    check_run_arguments(spec, out, run)
    model = load_model(spec.model)
    check_spec(spec, model)
    out = Path(out)
    _prepare_folder(out, spec, run.fmt, run.force, None if run.designs is None else designs_digest(spec, run.designs))
    store = open_store(out, spec, model, run.fmt)
    designs = _designs(out, spec, run.designs)
    t_start = time.perf_counter()
    todo = _todo(store, designs, run.retry_failed)
    warm = accepts_warm(model)
    if warm and len(todo) > 1:
        todo = _local_order(todo, max(1, run.group))
    summary = {"model": spec.model, "sampler": spec.sampler, "designs": len(designs), "out": str(out),
               "format": run.fmt, "skipped": len(designs) - len(todo), "computed": 0}
    if not todo:      # a rerun with every design recorded: no cluster, no rate to measure
        summary["workers"] = 0
        if run.progress:
            print(f"{run.desc}: all {len(designs)} designs are already recorded in {out}; nothing to compute",
                  file=sys.stderr, flush=True)
    else:
        if run.progress:
            _announce(spec, run, len(todo), len(designs), warm)
        with Cluster(run.scheduler, run.n_workers, run.client) as cluster:
            _compute(spec, todo, store, summary, cluster, run, warm)
    return _finish(store, len(designs), summary, t_start)


def _announce(spec: SweepSpec, run: SweepRun, n_todo: int, n_designs: int, pump: bool) -> None:
    """Say what the sweep computes and, for the pump model, about how long (studies.costs)."""
    from studies import costs
    from studies.outputs import announce

    where = ("the scheduler's workers" if run.scheduler or run.client is not None
             else f"a local cluster of {run.n_workers or default_workers()} workers")
    workers = run.n_workers or (2 if run.scheduler or run.client is not None else default_workers())
    what = f"{n_todo} of {n_designs} runs of the {spec.model} model to compute on {where}"
    if not pump:
        announce(run.desc, what + "; no measured cost for this model")
        return
    start = 0.0 if run.client is not None else costs.SECONDS["cluster"]
    seconds = start + costs.estimate(pump__evaluation=n_todo) / workers
    announce(run.desc, what, seconds, "measured per-run cost" + costs.compile_note())


def _todo(store, designs: list[dict], retry_failed: bool) -> list:
    """(design_id, inputs) of the designs not recorded yet (and of those that failed, with ``retry_failed``)."""
    done = store.read()
    keep = done if not retry_failed else done[done["status"] != "error"]
    finished = set(int(i) for i in keep["design_id"])
    return [(i, d) for i, d in enumerate(designs) if i not in finished]


def _compute(spec: SweepSpec, todo: list, store, summary: dict, cluster: Cluster, run: SweepRun, warm: bool) -> None:
    """Evaluate ``todo`` in batches on the cluster, each finished batch into the store; sets the summary's
    ``workers`` and ``computed``."""
    from distributed import as_completed
    from tqdm import tqdm

    client = cluster.get()
    workers = max(1, len(client.scheduler_info().get("workers", {})) or (run.n_workers or 1))
    summary["workers"] = workers
    bs = run.batch_size or _default_batch(len(todo), workers, warm) * max(1, run.group)
    batches = [todo[i: i + bs] for i in range(0, len(todo), bs)]
    bar = tqdm(total=summary["designs"], initial=summary["skipped"], desc=run.desc, unit="design",
               file=sys.stderr, disable=not run.progress, smoothing=0.05)
    try:
        futures = client.map(evaluate_batch, [spec.model] * len(batches), [spec.fixed_dict] * len(batches), batches,
                             pure=False)
        for fut in as_completed(futures):
            rows = fut.result()
            store.append(rows)
            summary["computed"] += len(rows)
            bar.update(len(rows))
            fut.release()
    finally:
        bar.close()


def _finish(store, n_designs: int, summary: dict, t_start: float) -> dict:
    """The summary completed from the store: failures, status counts, the results file, the rate."""
    final = store.read()
    summary["failed"] = int((final["status"] == "error").sum())
    summary["status_counts"] = status_counts(final)
    if len(final) >= n_designs:
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
