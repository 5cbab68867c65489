"""The thesis's printed values (studies/data/thesis_values.toml), for side-by-side tables and tests."""

from __future__ import annotations

from functools import cache

from geometry.data_files import package_toml


@cache
def thesis_values() -> dict:
    """Every value the thesis prints that a table or test compares with (studies/data/thesis_values.toml).

    Returns
    -------
    dict
        Keyed by table (``table_3_3``, ...), SI units.
    """
    return package_toml("studies", "thesis_values.toml")


@cache
def experiments() -> list[dict]:
    """The 12 pump validation cases of Tables 5.3-5.6 (studies/data/experiments.toml).

    Returns
    -------
    list of dict
        Per case: the valve, speed, load pressure, the measured and the thesis's modeled delivery.
    """
    return package_toml("studies", "experiments.toml")["case"]
