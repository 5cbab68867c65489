"""The thesis's printed values (studies/data/thesis_values.toml), for side-by-side tables and tests."""

from __future__ import annotations

from functools import cache

from geometry.data_files import package_toml


@cache
def thesis_values() -> dict:
    """All printed values, keyed by table (``table_3_3``, ...)."""
    return package_toml("studies", "thesis_values.toml")


@cache
def experiments() -> list[dict]:
    """The 12 pump validation cases of Tables 5.3-5.6 (studies/data/experiments.toml)."""
    return package_toml("studies", "experiments.toml")["case"]
