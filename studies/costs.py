"""What a long command costs, said before it starts: measured per-unit wall times and their sum.

Each figure is the wall time of one unit of work on the project's 2-core machine with other jobs
running (load average 9-11): an idle machine finishes sooner. ``python benchmarks/bench_cli.py
--estimates`` runs the README's long commands and prints each announced estimate beside the wall
time it took. The fast path compiles once per install (numba, cached on disk): the first run
after installing or changing the physics takes :data:`COMPILE_SECONDS` more, which
:func:`compile_note` says when the cache is empty.
"""

from __future__ import annotations

from pathlib import Path

#: wall seconds per unit of work (what each unit is: the comment above its key)
SECONDS = {
    # one reed's kappa, gammas, omega_n at the fidelity's default mesh (the prototype: beam 0.09 s, plate 2.1 s,
    # solid 6.8 s; the uniform reed 0.02, 1.7, 4.1 s)
    "fea:analytic": 0.05, "fea:beam": 0.1, "fea:plate": 2.0, "fea:solid": 7.0,
    # the shapes check --out draws (the solid with torsion: 10.7 s)
    "shapes:analytic": 0.0, "shapes:beam": 0.05, "shapes:plate": 1.7, "shapes:solid": 11.0,
    # six modes of one reed with their shapes (plate 1.8 s, solid 10.9 s)
    "modes:analytic": 0.1, "modes:beam": 0.2, "modes:plate": 2.0, "modes:solid": 11.0,
    # one thesis pump case to cyclic steady state on the fast path (Table 5.4: six in 9.6 s)
    "pump:fast": 1.6,
    # one pump run on the reference stepper (scipy Radau; the optimisation's re-check: 1.0-1.6 s)
    "pump:reference": 1.6,
    # one Monte Carlo draw of a run's declared inputs (pump --uncertainty: 128 draws in 14.9 s)
    "pump:draw": 0.12,
    # one design at one operating point on a dask worker, fast path (sensitivity_quick.toml: 1024 in 25 s on
    # two workers), per worker
    "pump:evaluation": 0.05,
    # a local dask cluster of two workers started, the models imported and warmed on them
    "cluster": 10.0,
    # a generation of a design study besides its evaluations (its sweep folder and dask round trip: 1.5-2 s)
    "generation": 2.0,
    # the whole of `valvelab validate`, its fast path compiled (benchmarks/bench_validation.py: 89.8 s on an idle
    # machine, 340 s at load average 13.9) and with --quick (104 s at load 17)
    "validate": 90.0, "validate:quick": 104.0,
    # one measured run of a discrepancy dataset through the whole workflow on two workers (bench_discrepancy.py:
    # median 8.6 s for six runs over 99 datasets, 6.0-21.3 s for 4-12 runs; the slowest, where two effects
    # trade, 35 s: four times the median)
    "discrepancy:run": 1.6,
}
#: the fast path's one-off compilation (numba) on a fresh install [s] (measured: 75-115 s under load)
COMPILE_SECONDS = 120.0


def estimate(**units: float) -> float | None:
    """Seconds for the given units of work.

    Parameters
    ----------
    **units : float
        Counts by :data:`SECONDS` key, a colon written as ``__`` (``fea__solid=4``).

    Returns
    -------
    float or None
        The sum of count x seconds per unit [s]; None when a unit has no measured cost (a fidelity an
        extension registers).

    >>> estimate(fea__solid=4, pump__fast=6)
    37.6
    >>> estimate(fea__shell=1) is None
    True
    """
    keys = {k: k.replace("__", ":") for k in units}
    if any(key not in SECONDS for key in keys.values()):
        return None
    return round(sum(SECONDS[keys[k]] * n for k, n in units.items()), 6)


def fast_path_compiled(one_dof: bool = True) -> bool:
    """Whether the fast path's compiled solver is in numba's cache for the current physics sources.

    Parameters
    ----------
    one_dof : bool
        The flavour: pumps whose valves have one degree of freedom each (disc, ball, eq 3.21 reeds), else the
        modal and FE reeds'.

    Returns
    -------
    bool
        True where the cache is elsewhere (``NUMBA_CACHE_DIR``: not looked into).
    """
    import os

    if os.environ.get("NUMBA_CACHE_DIR"):
        return True
    from lumped.solver import compiled

    digest = compiled.source_digest("lumped.solver.steppers")     # the solver's cache name (steppers._build_rodas)
    folder = Path(compiled.__file__).parent / "__pycache__"
    return any(folder.glob(f"rodas.solve__pump{'1' if one_dof else 'n'}_{digest}*.nbi"))


def compile_note(one_dof: bool = True) -> str:
    """``; the fast path compiles first (about 2 min, once)`` when its cache is empty, else nothing.

    Parameters
    ----------
    one_dof : bool
        As :func:`fast_path_compiled`.

    Returns
    -------
    str
    """
    if fast_path_compiled(one_dof):
        return ""
    return f"; the fast path compiles first (about {COMPILE_SECONDS / 60:.0f} min, once per install)"
