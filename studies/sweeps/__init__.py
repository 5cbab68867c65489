"""Design sweeps: a spec of factors and ranges sampled, run on dask, stored as Parquet/CSV.

- :mod:`~studies.sweeps.sweep`: spec parsing, sampling, the resumable dask runner, main effects;
- :mod:`~studies.sweeps.pump`: the piston pump as a sweep model (inputs by model-file path);
- :mod:`~studies.sweeps.random_designs`: random plausible pump designs (tests, benchmarks).
"""

from studies.sweeps.sweep import SweepSpec, load_spec, main_effects, parse_spec, read_results, run_sweep

__all__ = ["SweepSpec", "load_spec", "main_effects", "parse_spec", "read_results", "run_sweep"]
