"""The one loader of the data files that ship inside valvelab's packages.

Every cited parameter table (``lumped/data/oil.toml``, ``geometry/data/reed_*.toml``,
``instruments/data/lts.toml``, ...) is read through :func:`package_toml`, parsed once per
process. A user's own files are read with :func:`geometry.validate.read_toml` instead,
which names the file in every refusal.

>>> package_toml("lumped", "oil.toml")["viscosity"]["kinematic_low"]   # m^2/s at 40 C, Table A.1
4.42e-05
"""

from __future__ import annotations

import copy
import tomllib
from functools import lru_cache
from importlib import resources


@lru_cache(maxsize=None)
def _parsed(package: str, name: str) -> dict:
    return tomllib.loads(package_text(package, name))


def package_text(package: str, name: str) -> str:
    """The text of ``<package>/data/<name>``."""
    return resources.files(package).joinpath("data", *name.split("/")).read_text(encoding="utf-8")


def package_toml(package: str, name: str) -> dict:
    """``<package>/data/<name>`` parsed (a fresh copy: callers may change it)."""
    return copy.deepcopy(_parsed(package, name))


def package_names(package: str, folder: str = "", suffix: str = ".toml") -> list[str]:
    """File names (without ``suffix``) in ``<package>/data/<folder>``, sorted."""
    base = resources.files(package).joinpath("data", *filter(None, folder.split("/")))
    return sorted(p.name[: -len(suffix)] for p in base.iterdir() if p.name.endswith(suffix))
