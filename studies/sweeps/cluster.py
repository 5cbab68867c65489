"""The dask cluster a sweep or a design study runs on: a scheduler's address, a client given, or a LocalCluster.

One place starts and closes it (:class:`Cluster`): sweeps (:func:`studies.sweeps.sweep.run_sweep`),
sensitivity and optimisation studies and the validation's input-uncertainty runs share it.
A LocalCluster has one single-threaded worker process per core (the simulations are CPU bound).
"""

from __future__ import annotations

import os

from geometry import validate
from geometry.errors import InputError

CONNECT_TIMEOUT = "10s"  # to reach --scheduler


def default_workers() -> int:
    """The number of local worker processes: one per core this process may use.

    Returns
    -------
    int
    """
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)


def check_options(options, workers_field: str, switches: tuple) -> None:
    """Refuse the first bad option of a run on a cluster, before any work.

    Parameters
    ----------
    options : SweepRun or StudyRun
        With ``scheduler`` (an address), a worker count and ``batch_size``.
    workers_field : str
        The name of its worker count (``n_workers``, ``workers``).
    switches : tuple of str
        Its options that must be True or False.
    """
    if options.scheduler is not None:
        validate.address(options.scheduler, "scheduler")
    workers = getattr(options, workers_field)
    if workers is not None:
        validate.number(workers, workers_field, integer=True, bounds=(1, 1024))
    if options.batch_size is not None:
        validate.number(options.batch_size, "batch_size", integer=True, bounds=(1, 1_000_000))
    for name in switches:
        validate.boolean(getattr(options, name), name)


class Cluster:
    """A dask client, started on first use.

    Parameters
    ----------
    scheduler : str, optional
        A scheduler's address (``tcp://host:8786``); its client is connected on first use.
    workers : int, optional
        Worker processes of the LocalCluster started when neither ``scheduler`` nor ``client``
        is given (default :func:`default_workers`).
    client : distributed.Client, optional
        A client to use as it is (never closed here).
    """

    def __init__(self, scheduler: str | None = None, workers: int | None = None, client=None):
        if workers is not None and workers < 1:
            raise InputError("--workers", f"must be a positive integer, got {workers}")
        self.scheduler, self.n_workers, self.client = scheduler, workers, client
        self._own = None
        self._given = client is not None

    def get(self):
        """The client, connected or started now if need be.

        Returns
        -------
        distributed.Client
        """
        if self.client is None:
            from distributed import Client, LocalCluster

            if self.scheduler:
                try:
                    self.client = Client(self.scheduler, timeout=CONNECT_TIMEOUT)
                except OSError as exc:
                    raise InputError("--scheduler", f"cannot connect to {self.scheduler} ({exc})") from None
            else:
                # ":0": the scheduler's HTTP server on a free port (None still tries 8787 and, when another
                # cluster holds it, warns "Port 8787 is already in use" on the user's terminal)
                self._own = LocalCluster(n_workers=self.n_workers or default_workers(), threads_per_worker=1,
                                         processes=True, dashboard_address=":0", silence_logs=40)
                self.client = Client(self._own)
        return self.client

    @property
    def workers(self) -> int:
        """The workers the cluster has (or will have when started)."""
        if self.client is None:
            return self.n_workers or default_workers()
        return max(1, len(self.client.scheduler_info().get("workers", {})))

    def check_reachable(self) -> None:
        """Connect now to a --scheduler (a bad address is an input error before any computation)."""
        if self.scheduler:
            self.get()

    def close(self) -> None:
        """Close the client and the LocalCluster started here (a client given is left open)."""
        if not self._given and self.client is not None:
            self.client.close()
            self.client = None
        if self._own is not None:
            self._own.close()
            self._own = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
