"""Where simulation and measurement disagree, which missing effect explains it, and by how much.

- :mod:`~studies.discrepancy.measured`: the measured-data format (run folders, traces);
- :mod:`~studies.discrepancy.synth`: synthetic data from a model with hidden effects;
- :mod:`~studies.discrepancy.gap`: gap metrics between a trace and a simulated cycle;
  :mod:`~studies.discrepancy.words`: the disagreements in words;
- :mod:`~studies.discrepancy.workflow`: the search over candidate effects (:class:`~studies.discrepancy.workflow.Workflow`),
  a facade over its parts: ``settings``, ``problem``, ``profile``, ``fitting``, ``selection``, ``search``,
  ``joint``, ``backward``, ``leftover``, ``records``, ``holdout``, ``simulations``;
- :mod:`~studies.discrepancy.pump_sim`, :mod:`~studies.discrepancy.model_choice`: the model
  the workflow simulates; :mod:`~studies.discrepancy.report`: the report folder;
- :mod:`~studies.discrepancy.confusion`: confusion matrices over seeds
  (``python -m studies.discrepancy.confusion``).
"""

from studies.discrepancy.gap import CycleTrace, GapScales
from studies.discrepancy.measured import Run, Trace, read_dataset, read_run, write_dataset
from studies.discrepancy.model_choice import choose, load_model
from studies.discrepancy.synth import Condition, Noise, synthesize, thesis_conditions, write_synthetic
from studies.discrepancy.workflow import ModelFailure, Outcome, RunCondition, Settings, Workflow

__all__ = ["Condition", "CycleTrace", "GapScales", "ModelFailure", "Noise", "Outcome", "Run", "RunCondition",
           "Settings", "Trace", "Workflow", "choose", "load_model", "read_dataset", "read_run", "synthesize",
           "thesis_conditions", "write_dataset", "write_synthetic"]
