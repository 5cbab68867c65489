"""The validation layer: every input valvelab reads is checked here, before any work starts.

One place says what a good input is, whatever it arrives through (a command-line flag, a
TOML or CSV file, a Python call):

- :func:`number`: finite, an integer where one is asked, inside a physically plausible
  range, and, when a refused value would be in range read in a unit commonly typed
  instead, a hint naming it ("expected a number in MPa from 0.01 to 100, got 2.76e+06
  (did you mean 2.76 MPa? 2.76e+06 looks like a value in Pa)");
- :func:`choice`, :func:`keys` (a misspelt key is an error that suggests the closest valid
  one), :func:`columns` (CSV headers: duplicated, unknown and missing columns);
- :func:`read_text`, :func:`read_toml`: a missing file, a folder, a binary or oversized file;
- :func:`size`: a request whose memory (or sample count) would exceed a limit is refused
  with the estimate, before anything is allocated.

Every refusal is an :class:`~geometry.errors.InputError` naming the field; the command
line turns it into exit status 2 and one line on stderr. Layers above declare *what* to
check (:func:`geometry.declare.param` for model parameters, ``studies.cli.flags`` for
command-line flags); the checks themselves live only here. This module is in the bottom
layer because every layer reads inputs.

Example
-------
>>> number(2.76e6, "--load-pressure-mpa", unit="MPa", bounds=(0.01, 100))
Traceback (most recent call last):
...
geometry.errors.InputError: --load-pressure-mpa: expected a number in MPa from 0.01 to 100, got 2.76e+06 (did you mean 2.76 MPa? 2.76e+06 looks like a value in Pa)
>>> number(593, "--speed-rpm", unit="rpm", bounds=(10, 20000))
593.0
>>> keys({"air_contnet": 0.01}, ("air_content", "speed_rpm"), "run.toml")
Traceback (most recent call last):
...
geometry.errors.InputError: run.toml.air_contnet: unknown key (did you mean air_content?); expected one of air_content, speed_rpm
"""

from __future__ import annotations

import difflib
import math
import os
import re
import tomllib
from pathlib import Path

from .errors import InputError

#: unit -> (factor, the unit the value was probably typed in): 2.76 in a Pa field looks like MPa
UNIT_SLIPS = {
    "Pa": ((1e6, "MPa"), (1e5, "bar"), (1e3, "kPa"), (1e9, "GPa")),
    "MPa": ((1e-6, "Pa"), (1e-3, "kPa"), (0.1, "bar")),
    "m": ((1e-3, "mm"), (1e-6, "um")),
    "mm": ((1e3, "m"), (1e-3, "um")),
    "m^2": ((1e-6, "mm^2"),),
    "m^3": ((1e-6, "cm^3"), (1e-3, "L"), (1e-9, "mm^3")),
    "kg": ((1e-3, "g"),),
    "kg/m^3": ((1e3, "g/cm^3"),),
    "rad": ((math.pi / 180.0, "deg"),),
    "Pa s": ((1e-3, "mPa s (cP)"),),
    "Hz": ((1e3, "kHz"),),
    "rpm": ((60.0 / (2.0 * math.pi), "rad/s"),),
}

#: text input files larger than this are refused (a TOML or CSV input, not a data dump)
MAX_TEXT_BYTES = 200_000_000


def describe(unit: str = "-", bounds=None, positive: bool = False, integer: bool = False) -> str:
    """'a number in N/m from 1 to 1e+08' style text for messages."""
    what = "an integer" if integer else "a number"
    u = "" if unit in ("-", "", None) else f" in {unit}"
    if bounds is None:
        return f"{'a positive' if positive else 'a finite'} {'integer' if integer else 'number'}{u}"
    lo, hi = (f"{int(b)}" if integer and abs(b) < 1e16 else f"{b:g}" for b in bounds)
    low = f"above {lo}" if positive and float(lo) == 0 else f"from {lo}"
    return f"{what}{u} {low} to {hi}"


def unit_hint(value: float, unit: str, bounds, positive: bool = False) -> str:
    """' (did you mean ...?)' when ``value`` would be in range read in a unit commonly typed instead."""
    if bounds is None or not math.isfinite(value):
        return ""
    lo, hi = bounds
    for factor, other in UNIT_SLIPS.get(unit, ()):
        v = value * factor
        if lo <= v <= hi and (v > 0 or not positive):
            return f" (did you mean {v:g} {unit}? {value:g} looks like a value in {other})"
    return ""


def number(value, where: str, *, unit: str = "-", bounds=None, positive: bool = False,
           integer: bool = False) -> float | int:
    """``value`` as a float (an int with ``integer``), or InputError naming ``where``.

    Refused: a non-number (a bool is not a number), NaN, infinity, a fraction where an
    integer is asked, zero or less with ``positive``, anything outside ``bounds``
    (inclusive, the plausible range in ``unit``).
    """
    text = describe(unit, bounds, positive, integer)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        if getattr(getattr(value, "dtype", None), "kind", "") in ("i", "u", "f") and not getattr(value, "shape", ()):
            value = float(value)                   # a numpy integer or float scalar (not a bool, not an array)
        else:
            raise InputError(where, f"expected {text}, got {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise InputError(where, f"expected {text}, got {value}")
    if integer:
        if int(value) != value:
            raise InputError(where, f"expected {text}, got {value!r}")
        value = int(value)
    else:
        value = float(value)
    if (positive and not value > 0) or (bounds is not None and not bounds[0] <= value <= bounds[1]):
        raise InputError(where, f"expected {text}, got {value:g}{unit_hint(value, unit, bounds, positive)}")
    return value


def boolean(value, where: str) -> bool:
    """``value`` if it is True or False (a numpy bool too), else InputError: 1, "yes" or None are not switches."""
    if isinstance(value, bool) or type(value).__name__ == "bool_":
        return bool(value)
    raise InputError(where, f"expected True or False, got {value!r}")


def path(value, where: str) -> Path:
    """``value`` (a str or os.PathLike) as a Path; InputError for another type or an empty name."""
    if not isinstance(value, (str, os.PathLike)):
        raise InputError(where, f"expected a file or folder path (str or pathlib.Path), got {type(value).__name__} "
                                f"{value!r}")
    text = os.fspath(value)
    if not isinstance(text, str) or not text.strip() or "\x00" in text:
        raise InputError(where, f"expected a file or folder name, got {text!r}")
    return Path(text)


def closest(value, options, cutoff: float = 0.6) -> str | None:
    """The option closest to a misspelt ``value`` (difflib ratio at least ``cutoff``), or None."""
    near = difflib.get_close_matches(str(value), tuple(options), n=1, cutoff=cutoff)
    return near[0] if near else None


def _near(value, options) -> str:
    """' (did you mean X?)' for the closest of ``options`` to a misspelt ``value``, else ''."""
    near = closest(value, options)
    return f" (did you mean {near}?)" if near else ""


def choice(value, where: str, choices) -> str:
    """``value`` if it is one of ``choices`` (strings), else InputError with the closest suggested."""
    choices = tuple(choices)
    if not isinstance(value, str) or value not in choices:
        raise InputError(where, f"expected one of {', '.join(choices)}, got {value!r}{_near(value, choices)}")
    return value


def keys(table: dict, allowed, where: str, required=(), sep: str = ".") -> None:
    """InputError for the first key of ``table`` not in ``allowed`` (or a ``required`` one missing);
    the field is named ``where + sep + key``."""
    if not isinstance(table, dict):
        raise InputError(where, "expected a table")
    allowed = tuple(allowed)
    for k in table:
        if k not in allowed:
            raise InputError(f"{where}{sep}{k}", f"unknown key{_near(k, allowed)}; expected one of {', '.join(allowed)}")
    for k in required:
        if k not in table:
            raise InputError(f"{where}{sep}{k}", "missing")


def columns(header, where: str, *, required=(), allowed=None) -> list[str]:
    """CSV header names, stripped; InputError for an empty, duplicated, unknown or missing column."""
    names = [str(h).strip() for h in header]
    seen = set()
    for i, n in enumerate(names):
        if not n:
            raise InputError(where, f"column {i + 1} has no name")
        if n in seen:
            raise InputError(f"{where}, {n}", "this column appears twice; keep one")
        seen.add(n)
    if allowed is not None:
        allowed = tuple(allowed)
        for n in names:
            if n not in allowed:
                raise InputError(f"{where}, {n}", f"unknown column{_near(n, allowed)}; expected some of "
                                                  f"{', '.join(allowed)}")
    for n in required:
        if n not in seen:
            raise InputError(f"{where}, {n}", "missing column")
    return names


#: a dask scheduler address: [scheme://]host:port (host a name, an IPv4 address or a bracketed IPv6 one)
_ADDRESS = re.compile(r"(?:(tcp|tls|ws|wss|ucx)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9](?:[A-Za-z0-9.-]*[A-Za-z0-9])?)"
                      r":([0-9]{1,5})")


def address(value, where: str) -> str:
    """A scheduler address ``host:port`` or ``tcp://host:port`` (also tls, ws, wss, ucx); else InputError.

    >>> address("tcp://10.0.0.5:8786", "--scheduler")
    'tcp://10.0.0.5:8786'
    >>> address("localhost", "--scheduler")
    Traceback (most recent call last):
    ...
    geometry.errors.InputError: --scheduler: expected a scheduler address host:port or tcp://host:port, got 'localhost' (no port)
    """
    expected = "expected a scheduler address host:port or tcp://host:port"
    if not isinstance(value, str):
        raise InputError(where, f"{expected}, got {value!r}")
    m = _ADDRESS.fullmatch(value.strip())
    if m is None:
        why = " (no port)" if ":" not in value.split("://")[-1] else ""
        raise InputError(where, f"{expected}, got {value!r}{why}")
    if not 1 <= int(m.group(3)) <= 65535:
        raise InputError(where, f"{expected} with a port from 1 to 65535, got {value!r}")
    return value.strip()


def read_text(path, where: str, *, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of an input file; InputError for a missing file, a folder, a binary or huge one."""
    p = Path(path)
    if not p.exists():
        raise InputError(where, f"{p}: no such file")
    if p.is_dir():
        raise InputError(where, f"{p} is a folder; expected a file")
    try:
        n = p.stat().st_size
        if n > max_bytes:
            raise InputError(where, f"{p} is {n / 1e6:.0f} MB; an input file of at most {max_bytes / 1e6:.0f} MB "
                                    "is expected")
        raw = p.read_bytes()
    except OSError as exc:
        raise InputError(where, f"{p} cannot be read ({exc.strerror})") from None
    if b"\x00" in raw[:8192]:
        raise InputError(where, f"{p} is a binary file; expected text (TOML or CSV)")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(where, f"{p} is not UTF-8 text (byte {exc.start}); expected a text file") from None


def read_toml(path, where: str) -> dict:
    """A TOML file as a dict; InputError naming the file (and the line) when it cannot be read."""
    text = read_text(path, where)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(where, f"{path} is not valid TOML ({exc})") from None


def size(count, where: str, *, limit: float, unit: str = "samples", bytes_each: float | None = None,
         how: str = "") -> int:
    """``count`` as an int if it is at most ``limit``; else InputError with the estimate.

    ``bytes_each`` turns the count into a memory estimate in the message; ``how`` says
    how to ask for less (e.g. "lower --sample-rate-hz or --revolutions").
    """
    n = number(count, where, positive=True)
    if n > limit:
        est = f" (about {_bytes(n * bytes_each)})" if bytes_each else ""
        tail = f"; {how}" if how else ""
        raise InputError(where, f"{n:.3g} {unit}{est} is more than the {limit:.3g} allowed{tail}")
    return int(n) if float(n).is_integer() else n


def _bytes(b: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if b < 1000.0:
            return f"{b:.3g} {unit}"
        b /= 1000.0
    return f"{b:.3g} EB"
