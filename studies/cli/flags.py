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
    """A number given as text (a flag or part of one), checked by :func:`geometry.validate.number`.

    Parameters
    ----------
    text : str
    field : str
        Named by the refusal.
    unit : str
    bounds : tuple of float, optional
        Inclusive plausible range in ``unit``.
    positive, integer : bool

    Returns
    -------
    float or int
    """
    try:
        v = float(text)
    except ValueError:
        raise InputError(field, f"expected {validate.describe(unit, bounds, positive, integer)}, got {text!r}") from None
    return validate.number(v, field, unit=unit, bounds=bounds, positive=positive, integer=integer)


def number(unit: str = "-", bounds=None, *, positive: bool = False, integer: bool = False):
    """An argparse ``type``: the text as a number checked by :func:`geometry.validate.number`.

    Parameters
    ----------
    unit : str
        The flag's unit (for the message and the unit hint).
    bounds : tuple of float or callable, optional
        Inclusive plausible range, or a function returning it: called when the flag is given, so
        a range declared in the model layer (``lumped``, seconds to import) costs nothing to
        ``--help`` or to a command line without the flag.
    positive, integer : bool

    Returns
    -------
    callable
    """

    def parse(text: str):
        try:
            return from_text(text, "", unit, bounds() if callable(bounds) else bounds, positive=positive,
                             integer=integer)
        except InputError as exc:
            raise argparse.ArgumentTypeError(exc.message) from None

    parse.__name__ = "integer" if integer else "number"
    return parse


def choice(names, what: str = "one of"):
    """An argparse ``type``: one of the names a function returns, looked up when the flag is given.

    argparse's ``choices`` needs the names while the parser is built; names registered by the model
    layer (the valve kinds) would import it for every ``--help``.

    Parameters
    ----------
    names : callable
        Returns the accepted names.
    what : str
        Leads the list in the refusal.

    Returns
    -------
    callable
    """

    def parse(s: str) -> str:
        known = tuple(names())
        if s not in known:
            raise argparse.ArgumentTypeError(f"expected {what} {', '.join(known)}, got {s!r}")
        return s

    parse.__name__ = "choice"
    return parse


def integer(lo: int, hi: int):
    """An argparse ``type``: an integer in [lo, hi].

    Parameters
    ----------
    lo, hi : int

    Returns
    -------
    callable
    """
    return number("-", (lo, hi), integer=True)


def address():
    """An argparse ``type``: a dask scheduler address (host:port or tcp://host:port).

    Returns
    -------
    callable
    """

    def parse(s: str) -> str:
        try:
            return validate.address(s, "")
        except InputError as exc:
            raise argparse.ArgumentTypeError(exc.message) from None

    parse.__name__ = "address"
    return parse


def text(max_len: int = 200):
    """An argparse ``type``: a non-empty string without control characters.

    Parameters
    ----------
    max_len : int
        Its largest length.

    Returns
    -------
    callable
    """

    def parse(s: str) -> str:
        if not s or len(s) > max_len or any(ord(c) < 32 for c in s):
            raise argparse.ArgumentTypeError(f"expected a name of 1 to {max_len} printable characters, got {s!r}")
        return s

    return parse


def add_cluster_flags(p, per_task: str, what: str) -> None:
    """Add the flags of a command that runs on a dask cluster.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's subparser.
    per_task : str
        What a dask task evaluates (``designs``, ``evaluations``), for the help.
    what : str
        What the output folder holds (``sweep``, ``study``), for the help.
    """
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", type=address(),
                   help="dask scheduler address (e.g. tcp://host:8786); default: a local cluster")
    p.add_argument("--workers", type=integer(1, 1024), default=None,
                   help="local cluster worker processes (default: one per core)")
    p.add_argument("--batch-size", type=integer(1, 1_000_000), default=None,
                   help=f"{per_task} per dask task (default: automatic)")
    p.add_argument("--force", action="store_true", help=f"start over in a folder that holds another {what}")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


def check_cluster_flags(args) -> None:
    """Refuse cluster flags that contradict each other (``--workers`` with ``--scheduler``).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (:func:`add_cluster_flags`).
    """
    if args.scheduler is not None and args.workers is not None:
        raise InputError("--workers", "applies to the local cluster only; the scheduler at --scheduler has its own")

