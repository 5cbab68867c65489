"""The one plugin loader: objects named by ``module:attribute`` or by an entry point group.

A higher layer adds to a registry of a lower one without the lower one importing it:
``fea`` declares its reed fidelities as entry points of the group
``valvelab.reed_fidelities`` (pyproject.toml), which :mod:`lumped.reed.fidelities` loads
on first use; a user's sweep model or discrepancy simulator is named as
``package.module`` and loaded here too.
"""

from __future__ import annotations

import importlib
from importlib import metadata

from geometry.errors import InputError


def import_object(spec: str, field: str, attribute: str | None = None):
    """The object ``module:attribute`` (or the module, or ``attribute`` of it); InputError names ``field``."""
    modname, _, attr = spec.partition(":")
    attr = attr or attribute
    try:
        mod = importlib.import_module(modname)
    except ImportError as exc:
        raise InputError(field, f"cannot import {modname!r} ({exc})") from None
    if not attr:
        return mod
    try:
        return getattr(mod, attr)
    except AttributeError:
        raise InputError(field, f"module {modname!r} has no {attr!r}") from None


def entry_points(group: str) -> dict:
    """{name: loaded object} of every installed entry point of ``group`` (broken ones left out)."""
    out = {}
    for ep in metadata.entry_points(group=group):
        try:
            out[ep.name] = ep.load()
        except ImportError:  # an optional plugin whose dependencies are missing
            continue
    return out
