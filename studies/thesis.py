"""The thesis's printed values (studies/data/thesis_values.toml), for side-by-side tables and tests."""

from __future__ import annotations

import tomllib
from functools import cache
from importlib import resources


@cache
def thesis_values() -> dict:
    """All printed values, keyed by table (``table_3_3``, ...)."""
    return tomllib.loads(resources.files("studies").joinpath("data/thesis_values.toml").read_text())


@cache
def experiments() -> list[dict]:
    """The 12 pump validation cases of Tables 5.3-5.6 (studies/data/experiments.toml)."""
    text = resources.files("studies").joinpath("data/experiments.toml").read_text()
    return tomllib.loads(text)["case"]
