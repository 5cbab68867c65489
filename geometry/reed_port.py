"""The port footprint on a reed's face and the quadrature rules of the modal reed.

A reed valve's pressure acts on the part of the reed face over the port, and the port
opens along that part's outline (the sealing line). :class:`ReedPort` is that footprint:
a rectangle ``s_start <= s <= s_end``, ``|y - y_center| <= width / 2`` on the face (s from
the clamp, y across from the centre line, SI units). No port (None) means the whole face,
the load eq 3.21 of Knutson (2016) assumes.

The rules below integrate over the face, the footprint and its outline, and give the
stations along the reed at which the modal model keeps its width-mean deflection and
twist. Each splits the reed at its breakpoints (steps, groove ends, the start of the
rounded tip) and uses Gauss-Legendre points on each piece; the piece ending at a rounded
tip is mapped so the square-root end of its width becomes smooth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import validate
from .declare import check_field, param
from .errors import InputError
from .reed import Reed

_SRC = "port footprint on the reed face (seat drawing)"
_LEN = (0.0, 10.0)
#: relative tolerance of "inside the outline" (a port drawn flush with the reed's edge is inside)
_TOL = 1e-9
#: port keys of a model file, in the order they are checked
PORT_KEYS = ("s_start", "s_end", "y_center", "width")


@dataclass(frozen=True)
class ReedPort:
    """The port's footprint on the reed face: s_start <= s <= s_end, |y - y_center| <= width / 2 [m]."""

    s_start: float = param("s_start", "m", _SRC + ": start, from the clamp line", bounds=_LEN)
    s_end: float = param("s_end", "m", _SRC + ": end, from the clamp line", bounds=_LEN, positive=True)
    width: float = param("width", "m", _SRC + ": width across the reed", bounds=_LEN, positive=True)
    y_center: float = param("y_center", "m", _SRC + ": centre, from the reed's centre line", default=0.0,
                            bounds=(-_LEN[1], _LEN[1]))

    def contains(self, s, y):
        """True where the face point (s, y) [m] lies on the footprint (vectorised)."""
        s, y = np.asarray(s, dtype=float), np.asarray(y, dtype=float)
        return (s >= self.s_start) & (s <= self.s_end) & (np.abs(y - self.y_center) <= self.width / 2)

    @property
    def area(self) -> float:
        """Footprint area [m^2]."""
        return (self.s_end - self.s_start) * self.width

    @property
    def perimeter(self) -> float:
        """Length of the footprint's outline (the sealing line) [m]."""
        return 2.0 * ((self.s_end - self.s_start) + self.width)


# ------------------------------------------------------------------------------ reading
def parse_port(table, where: str) -> ReedPort | None:
    """A :class:`ReedPort` from a model-file table (keys s_start, s_end, width, y_center [m]).

    ``where`` is the table's key path (``valves.delivery.port``); every error names
    ``where.key``. None or an absent table is the whole face (returns None). The port is
    not yet checked against a reed: :func:`check_port`.
    """
    if table is None:
        return None
    validate.keys(table, PORT_KEYS, where)
    vals = {}
    for key in PORT_KEYS:
        if key not in table:
            if key == "y_center":
                continue
            raise InputError(f"{where}.{key}", "missing; a port is a rectangle s_start..s_end [m] from the "
                             "clamp, width [m] across, centred at y_center [m] (default 0)")
        vals[key] = check_field(ReedPort, key, table[key], f"{where}.{key}")
    if vals["s_end"] <= vals["s_start"]:
        raise InputError(f"{where}.s_end", f"{vals['s_end']:g} m must exceed s_start = {vals['s_start']:g} m")
    return ReedPort(**vals)


def check_port(port: ReedPort | None, reed: Reed, where: str = "port") -> ReedPort | None:
    """``port`` if it lies on the reed's face, else InputError naming ``where.<key>``.

    Checks the declared ranges (a port built in Python) and that the rectangle stays inside
    the outline: s_end <= L and |y_center| + width / 2 <= W(s) / 2 for every s of the port
    (W the outline width, rounded tip included).
    """
    if port is None:
        return None
    for key in PORT_KEYS:
        check_field(ReedPort, key, getattr(port, key), f"{where}.{key}")
    if port.s_end <= port.s_start:
        raise InputError(f"{where}.s_end", f"{port.s_end:g} m must exceed s_start = {port.s_start:g} m")
    L = reed.length
    if port.s_end > L * (1 + _TOL):
        raise InputError(f"{where}.s_end", f"{port.s_end:g} m is beyond the reed's tip at {L:g} m")
    s = np.unique(np.concatenate([np.linspace(port.s_start, port.s_end, 801),
                                  [b for b in reed.breakpoints() if port.s_start <= b <= port.s_end]]))
    s = np.clip(s, 0.0, L)
    half = np.asarray(reed.width(s), dtype=float) / 2
    reach = abs(port.y_center) + port.width / 2
    out = reach > half * (1 + _TOL) + _TOL * L
    if np.any(out):
        k = int(np.argmax(out))
        key = "y_center" if port.y_center != 0.0 and port.width / 2 <= half[k] else "width"
        raise InputError(f"{where}.{key}", f"the port reaches |y| = {reach:g} m but the reed is only "
                         f"{half[k]:g} m wide on each side of its centre line at s = {s[k]:g} m: the port "
                         "must lie on the reed's face")
    return port


def read_port(table, where: str, reed: Reed) -> ReedPort | None:
    """:func:`parse_port` then :func:`check_port` against ``reed`` (errors name ``where.<key>``)."""
    return check_port(parse_port(table, where), reed, where)


# ------------------------------------------------------------------------------ footprint
def footprint_mask(reed: Reed, port: ReedPort | None, s, y):
    """True where the face point (s, y) [m] is loaded: on the port, or anywhere on the face without one."""
    s, y = np.asarray(s, dtype=float), np.asarray(y, dtype=float)
    on_face = (s >= 0.0) & (s <= reed.length) & (np.abs(y) <= np.asarray(reed.width(s)) / 2)
    return on_face if port is None else on_face & port.contains(s, y)


def footprint_area(reed: Reed, port: ReedPort | None) -> float:
    """Loaded area [m^2]: the port's, or the whole face's."""
    return reed.face_area if port is None else port.area


# ------------------------------------------------------------------------------ quadrature
def section_breaks(reed: Reed) -> np.ndarray:
    """s [m] where a reed's width, thickness or grooves change (near-duplicates merged), 0 and L included."""
    br = np.unique(reed.section_breaks())
    return br[np.append(np.diff(br) > 1e-9 * reed.length, True)]


def _gauss(a: float, b: float, n: int, sqrt_end: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """n Gauss-Legendre points and weights on [a, b]; with ``sqrt_end`` through s = b - (b - a)(1 - t)^2,
    which makes a square-root end at b (the rounded tip's width) smooth in t."""
    x, w = np.polynomial.legendre.leggauss(n)
    t = (x + 1) / 2
    if not sqrt_end:
        return a + (b - a) * t, w * (b - a) / 2
    return b - (b - a) * (1 - t) ** 2, w / 2 * 2 * (b - a) * (1 - t)


def line_rule(breaks, n: int, a: float | None = None, b: float | None = None,
              sqrt_end: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Points and weights for int_a^b f ds [m]: Gauss on each piece between ``breaks``.

    About ``n`` points in all, shared by length, at least 3 per piece (exact for a
    piecewise quintic). The piece ending at ``sqrt_end`` (the tip of a rounded reed,
    where W(s) ~ sqrt(L - s)) is mapped so that end is smooth.
    """
    br = np.asarray(breaks, dtype=float)
    a = br[0] if a is None else a
    b = br[-1] if b is None else b
    tol = 1e-9 * (b - a)
    inner = br[(br > a + tol) & (br < b - tol)]
    edges = np.concatenate([[a], inner, [b]])
    edges = edges[np.append(True, np.diff(edges) > tol)]      # near-duplicate breaks are one
    edges[-1] = b
    ss, ww = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        k = max(3, int(round(n * (hi - lo) / (b - a))))
        s, w = _gauss(lo, hi, k, sqrt_end is not None and abs(hi - sqrt_end) <= tol)
        ss.append(s)
        ww.append(w)
    return np.concatenate(ss), np.concatenate(ww)


def _tip_end(reed: Reed) -> float | None:
    """L when the tip is rounded (W ~ sqrt(L - s) there), else None."""
    return reed.length if reed.tip_radius > 0.0 else None


def station_rule(reed: Reed, n: int = 32) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stations s_k [m], weights [m] (int_0^L f ds = sum w_k f(s_k)) and widths W(s_k) [m] along the reed.

    About ``n`` stations (at least 3 per piece between :func:`section_breaks`); the modal
    reed keeps each mode's width-mean deflection and twist there (strip theory).
    """
    s, w = line_rule(section_breaks(reed), n, sqrt_end=_tip_end(reed))
    return s, w, np.asarray(reed.width(s), dtype=float)


def face_rule(reed: Reed, port: ReedPort | None = None, n_s: int = 96, n_y: int = 12,
              breaks=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (s, y) [m] and weights [m^2] integrating over the footprint (the whole face without a port).

    Whole face: Gauss along s (as :func:`station_rule`) times Gauss-Legendre across
    -W(s)/2..W(s)/2. Port: Gauss along s times Gauss across the port's width. Along s the
    rule is split at the reed's breakpoints and at ``breaks`` [m] (e.g. the nodes of a
    beam mesh, so a piecewise-cubic field is integrated exactly). ``sum w f(s, y)``
    approximates the area integral of f; ``n_y = 1`` suffices for fields constant across.
    """
    eta, we = np.polynomial.legendre.leggauss(n_y)
    br = section_breaks(reed) if breaks is None else np.union1d(section_breaks(reed), np.asarray(breaks, float))
    if port is None:
        s, ws = line_rule(br, n_s, sqrt_end=_tip_end(reed))
        W = np.asarray(reed.width(s), dtype=float)
        S = np.repeat(s, n_y)
        Y = (eta[None, :] * W[:, None] / 2).ravel()
        wt = (ws[:, None] * we[None, :] * W[:, None] / 2).ravel()
        return S, Y, wt
    s, ws = line_rule(br, n_s, port.s_start, port.s_end, _tip_end(reed))
    S = np.repeat(s, n_y)
    Y = np.tile(port.y_center + eta * port.width / 2, len(s))
    wt = (ws[:, None] * we[None, :] * port.width / 2).ravel()
    return S, Y, wt


def edge_rule(reed: Reed, port: ReedPort | None = None, n: int = 48) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (s, y) [m] and weights [m] along the footprint's outline, the port's sealing line.

    A port: its four sides (the sides along s split at the reed's breakpoints), weights the
    arc length, so ``sum w f`` is the line integral of f. The whole face: the tip centre
    (L, 0) with weight 1 (its sealing line's mean lift is taken to be the tip's, as eq 3.21 does).
    """
    if port is None:
        return np.array([reed.length]), np.array([0.0]), np.array([1.0])
    br = section_breaks(reed)
    s, ws = line_rule(br, n, port.s_start, port.s_end)
    eta, we = np.polynomial.legendre.leggauss(max(3, int(round(n * port.width / (port.s_end - port.s_start)))))
    y = port.y_center + eta * port.width / 2
    wy = we * port.width / 2
    lo, hi = port.y_center - port.width / 2, port.y_center + port.width / 2
    S = np.concatenate([s, s, np.full(len(y), port.s_start), np.full(len(y), port.s_end)])
    Y = np.concatenate([np.full(len(s), lo), np.full(len(s), hi), y, y])
    return S, Y, np.concatenate([ws, ws, wy, wy])


def face_grid(reed: Reed, ns: int = 121, ny: int = 13) -> tuple[np.ndarray, np.ndarray]:
    """Points (s, y) [m] covering the face, edges and tip included (for the max |w| of a mode shape)."""
    s = np.unique(np.concatenate([np.linspace(0.0, reed.length, ns), section_breaks(reed)]))
    eta = np.linspace(-1.0, 1.0, ny)
    W = np.asarray(reed.width(s), dtype=float)
    return np.repeat(s, ny), (eta[None, :] * W[:, None] / 2).ravel()
