"""The multi-fidelity validation: reed parameters by fidelity, then the thesis's pump cases.

- :mod:`~studies.validation.reed_check`: one reed at every fidelity, deviations flagged;
- :mod:`~studies.validation.chain`: the 12 pump cases of Tables 5.4 and 5.6, tables and plots.
"""

from studies.validation.chain import cases, run_case, run_cases, table_rows
from studies.validation.reed_check import multi_fidelity_check

__all__ = ["cases", "multi_fidelity_check", "run_case", "run_cases", "table_rows"]
