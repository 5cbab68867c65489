"""Design sweeps: a spec of factors and ranges sampled, run on dask, stored as Parquet/CSV.

- :mod:`~studies.sweeps.schema`: the one machinery every study spec is checked with (tables,
  keys, numbers, ranges, levels, model references; one wording for every refusal);
- :mod:`~studies.sweeps.sweep_spec`: the sweep file, its :class:`~studies.sweeps.sweep_spec.SweepSpec` and its
  samplers;
- :mod:`~studies.sweeps.sweep`: the resumable dask runner (:func:`~studies.sweeps.sweep.run_sweep`);
- :mod:`~studies.sweeps.store`: the results tables (Parquet parts or CSV);
- :mod:`~studies.sweeps.main_effects`: the mean response against each factor;
- :mod:`~studies.sweeps.cluster`: the dask cluster every study runs on;
- :mod:`~studies.sweeps.pump`: the piston pump as a sweep model (inputs by model-file path);
- :mod:`~studies.sweeps.random_designs`: random plausible pump designs (tests, benchmarks);
- :mod:`~studies.sweeps.design`: sensitivity and optimisation studies on the same machinery.
"""

from studies.sweeps.main_effects import main_effects
from studies.sweeps.store import read_results
from studies.sweeps.sweep import SweepRun, run_sweep
from studies.sweeps.sweep_spec import SweepSpec, load_spec, parse_spec

__all__ = ["SweepRun", "SweepSpec", "load_spec", "main_effects", "parse_spec", "read_results", "run_sweep"]
