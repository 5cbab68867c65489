"""Design studies on the fast pump model: global sensitivity and optimisation (issue 13).

- :mod:`studies.sweeps.design.spec`: the spec file shared by ``valvelab sensitivity`` and
  ``valvelab optimize`` (base model, operating points, variables with ranges or
  distributions, derived keys, outputs, objectives, constraints), checked field by field;
- :mod:`studies.sweeps.design.outputs`: the outputs a spec may name (units, labels);
- :mod:`studies.sweeps.design.evaluate`: the pump at one operating point as a sweep model
  (:mod:`studies.sweeps.sweep` protocol), with the reed's kappa, omega and bending stress;
- :mod:`studies.sweeps.design.stress`: the reed's Euler-Bernoulli bending stress at a lift,
  calibrated against the solid FEA (:mod:`fea.reed_stress`);
- :mod:`studies.sweeps.design.runner`: designs x operating points on dask through
  :func:`studies.sweeps.sweep.run_sweep` (resumable Parquet stores, failures recorded);
- :mod:`studies.sweeps.design.sensitivity`: Sobol (Saltelli sampling, bootstrap intervals) and
  Morris screening with SALib;
- :mod:`studies.sweeps.design.optimize`: NSGA-II (pymoo) and differential evolution (scipy), the
  multi-fidelity re-check of the front (solid FEA, reference integrator) and the design files.
"""
