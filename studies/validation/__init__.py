"""The multi-fidelity validation: reed parameters by fidelity, then the thesis's pump cases, with their uncertainty.

- :mod:`~studies.validation.reed_check`: one reed at every fidelity, deviations flagged;
- :mod:`~studies.validation.chain`: the 12 pump cases of Tables 5.4 and 5.6, tables and plots;
- :mod:`~studies.validation.vv20`: every comparison with its uncertainty (ASME V&V 20), from
  :mod:`~studies.validation.numerical` (u_num), :mod:`~studies.validation.input_uncertainty`
  (u_input) and :mod:`~studies.validation.measurement` (u_D);
- :mod:`~studies.validation.joint` and :mod:`~studies.validation.procedure`: a rig's comparisons judged
  together (calibration, predictions, differences, rig tests, the detectable error), run on the pump cases by
  :mod:`~studies.validation.pump_vv20` and on synthetic measurements by :mod:`~studies.validation.coverage`.
"""

from studies.validation.chain import cases, run_case, run_cases, table_rows
from studies.validation.pump_vv20 import pump_validation
from studies.validation.reed_check import multi_fidelity_check
from studies.validation.vv20 import ValidationTable, point_uncertainty, reed_validation

__all__ = ["ValidationTable", "cases", "multi_fidelity_check", "point_uncertainty", "pump_validation",
           "reed_validation", "run_case", "run_cases", "table_rows"]
