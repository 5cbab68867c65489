"""Command-line flags checked while they are parsed, before any command runs.

Each numeric flag is declared with its unit and plausible range; the check is
:func:`geometry.validate.number`, so a flag refuses exactly what the same value in a
file would be refused for, with the same unit hint. A refusal is argparse's: exit 2 and
one line, ``valvelab pump: error: argument --speed-rpm: expected a number in rpm from 10
to 20000, got 1e+06``.

>>> import argparse
>>> p = argparse.ArgumentParser(prog="demo")
>>> _ = p.add_argument("--load-pressure-mpa", type=number("MPa", (0.01, 100.0)))
>>> p.parse_args(["--load-pressure-mpa", "2.76"]).load_pressure_mpa
2.76
"""

from __future__ import annotations

import argparse

from geometry import validate
from geometry.errors import InputError


def from_text(text: str, field: str, unit: str = "-", bounds=None, *, positive: bool = False,
              integer: bool = False):
    """``text`` (a flag or part of one) as a number checked by :func:`geometry.validate.number`; InputError."""
    try:
        v = float(text)
    except ValueError:
        raise InputError(field, f"expected {validate.describe(unit, bounds, positive, integer)}, got {text!r}") from None
    return validate.number(v, field, unit=unit, bounds=bounds, positive=positive, integer=integer)


def number(unit: str = "-", bounds=None, *, positive: bool = False, integer: bool = False):
    """An argparse ``type``: the text as a number checked by :func:`geometry.validate.number`."""

    def parse(text: str):
        try:
            return from_text(text, "", unit, bounds, positive=positive, integer=integer)
        except InputError as exc:
            raise argparse.ArgumentTypeError(exc.message) from None

    parse.__name__ = "integer" if integer else "number"
    return parse


def integer(lo: int, hi: int):
    """An argparse ``type``: an integer in [lo, hi]."""
    return number("-", (lo, hi), integer=True)


def address():
    """An argparse ``type``: a dask scheduler address (host:port or tcp://host:port)."""

    def parse(s: str) -> str:
        try:
            return validate.address(s, "")
        except InputError as exc:
            raise argparse.ArgumentTypeError(exc.message) from None

    parse.__name__ = "address"
    return parse


def text(max_len: int = 200):
    """An argparse ``type``: a non-empty string without control characters, at most ``max_len`` long."""

    def parse(s: str) -> str:
        if not s or len(s) > max_len or any(ord(c) < 32 for c in s):
            raise argparse.ArgumentTypeError(f"expected a name of 1 to {max_len} printable characters, got {s!r}")
        return s

    return parse
