"""User workflows on top of the models, one subpackage per purpose.

- :mod:`studies.cli`: the ``valvelab`` command line, one module per command;
- :mod:`studies.validation`: the multi-fidelity validation (reed fidelities, Tables 5.4/5.6);
- :mod:`studies.tables`: the thesis's tables regenerated beside the printed values;
- :mod:`studies.discrepancy`: measured data, synthetic data and the discrepancy workflow;
- :mod:`studies.sweeps`: design sweeps on dask (and what is built on them);
- :mod:`studies.outputs`, :mod:`studies.plots`: output folders and figures shared by all.
"""
