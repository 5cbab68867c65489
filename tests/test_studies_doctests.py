"""The doctests of the study and instrument modules: the default ``--doctest-modules`` run collects the test paths
(tests, lumped, geometry) only, and each example here quotes a thesis or textbook number that must stay true."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import instruments
import studies.sweeps
import studies.tables


def _modules() -> list[str]:
    names = ["studies.outputs", "studies.plots", "studies.cli.flags", "studies.validation.reed_check", "studies.costs",
             "studies.discrepancy.records"]
    for pkg in (studies.sweeps, studies.tables, instruments):
        names += [m.name for m in pkgutil.walk_packages(pkg.__path__, prefix=f"{pkg.__name__}.")]
    return sorted(names)


MODULES = _modules()


@pytest.mark.parametrize("name", MODULES)
def test_module_doctests_pass(name):
    mod = importlib.import_module(name)
    result = doctest.testmod(mod, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} doctest examples failed"


def test_the_thesis_numbers_are_doctested():
    """The examples that carry a printed number are collected (a module renamed away would drop them silently)."""
    counts = {n: doctest.DocTestFinder().find(importlib.import_module(n)) for n in
              ("instruments.lts", "studies.tables.fea", "studies.sweeps.schema")}
    assert all(sum(len(t.examples) for t in found) >= 2 for found in counts.values()), counts
