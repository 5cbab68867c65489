"""Parametric reed: the one description that formulas and meshes are built from.

Coordinates (SI units): ``s`` runs along the reed from the clamp line (s = 0) to
the tip (s = length); ``y`` runs across it from the centre line; ``z`` runs
through the thickness from the upstream face (z = 0, where grooves are cut) to
the downstream face (z = thickness).

Two ways to describe the outline along s, both resolved into the same list of
:class:`Piece` objects (:meth:`Reed.pieces`) that every model reads:

- the thesis's one-step form (Table 3.1): a root section of width ``width_root`` for
  ``0 <= s < step_fraction * length`` (R_l), then ``width_tip``, all of thickness
  ``thickness``;
- sections (:class:`Section`, ``[[reed.sections]]`` in the geometry file): any number of
  pieces from the clamp to the tip, each with its own width, optional thickness (default
  ``thickness``), optional linear width taper and optional linear thickness taper. The upstream
  face z = 0 is flat (it seals on the seat); a thickness step or taper is one of the downstream face.

Either form ends in a tip rounded with ``tip_radius`` (Table 3.5: a full semicircle when
``tip_radius == width / 2`` of the last piece, square when 0). On a tapered last piece
the rounded corners follow the taper: the edge is the straight taper edge moved inward by
R - sqrt(R^2 - d^2), d = s - (L - R) (a circular arc when the piece is not tapered).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .declare import param

# plausible ranges: any reed from a 0.1 mm micro-valve strip to a 10 m plate; the
# proportions (slenderness, width to length) are checked in geometry.reed_io
_LEN = (1e-4, 10.0)
_THICK = (1e-6, 0.1)
_WIDTH = (1e-5, 10.0)

@dataclass(frozen=True)
class Material:
    """Linear elastic reed material; SI units (Pa, kg/m^3)."""

    youngs_modulus: float = param("youngs_modulus", "Pa", "datasheet (Table 3.1: Delrin 2.9 GPa)",
                                  bounds=(1e6, 1.5e12), positive=True, doc="rubber to diamond")
    density: float = param("density", "kg/m^3", "datasheet (Table 3.1: 1410 kg/m^3)", bounds=(100.0, 25000.0),
                           positive=True)
    poisson_ratio: float = param("poisson_ratio", "-", "datasheet (not in the thesis: thesis-notes)",
                                 bounds=(0.0, 0.4999))


class GrooveShape:
    """A groove kind: the footprint of a pocket and what the readers, meshes and quadrature need of it.

    The pocket is cut into the upstream face. One subclass per kind, registered in :data:`GROOVE_KINDS`; a new
    kind is a subclass here with its fields declared on :class:`Groove` (docs/extending.md).
    """

    #: the kind's name (``[[reed.grooves]] kind``) and its file keys besides ``kind`` and ``depth``
    name = ""
    keys: tuple = ()

    def s_range(self, g: "Groove") -> tuple[float, float]:
        """Extent of the pocket along the reed [m]."""
        raise NotImplementedError

    def intervals(self, g: "Groove", s: float) -> list[tuple[float, float]]:
        """The y-intervals [m] the pocket occupies across the section at ``s``."""
        raise NotImplementedError

    def contains(self, g: "Groove", s, y):
        """True where the point (s, y) lies in the pocket (vectorised)."""
        raise NotImplementedError

    def volume(self, g: "Groove") -> float:
        """Pocket volume [m^3]: depth times the footprint area (the pocket lies inside the outline, as the
        reader's :meth:`check` ensures)."""
        raise NotImplementedError

    def kinks(self, g: "Groove") -> list[float]:
        """s [m] inside its extent where the section properties have a kink (quadrature breakpoints)."""
        return []

    def check(self, g: "Groove", reed: "Reed", where: str) -> None:
        """InputError naming the key of ``where`` when the pocket does not fit the reed."""

    def mirror(self, g: "Groove") -> "Groove":
        """The pocket mirrored about the centre line y = 0 (the symmetric half models compare it)."""
        return g

    def occ_surfaces(self, g: "Groove", occ) -> list[int]:
        """The pocket's footprint as surfaces of gmsh's OpenCASCADE kernel ``occ`` (their tags)."""
        raise NotImplementedError


class RectGroove(GrooveShape):
    """The box ``s_start <= s <= s_end``, ``|y - y_center| <= width / 2``."""

    name = "rect"
    keys = ("s_start", "s_end", "y_center", "width")

    def s_range(self, g):
        return g.s_start, g.s_end

    def intervals(self, g, s):
        if g.s_start <= s <= g.s_end:
            return [(g.y_center - g.width / 2, g.y_center + g.width / 2)]
        return []

    def contains(self, g, s, y):
        s = np.asarray(s, dtype=float)
        y = np.asarray(y, dtype=float)
        return (s >= g.s_start) & (s <= g.s_end) & (np.abs(y - g.y_center) <= g.width / 2)

    def volume(self, g):
        return g.depth * g.width * (g.s_end - g.s_start)

    def check(self, g, reed, where):
        from .errors import InputError

        if g.s_start < 0.0:
            raise InputError(f"{where}.s_start", f"must be >= 0 (the clamp line), got {g.s_start:g}")
        if g.s_end <= g.s_start:
            raise InputError(f"{where}.s_end", f"must exceed s_start = {g.s_start:g} m")
        if g.s_end > reed.length:
            raise InputError(f"{where}.s_end", f"{g.s_end:g} m is beyond the reed tip at {reed.length:g} m")
        s = np.linspace(g.s_start, g.s_end, 401)
        half = reed.width(s) / 2
        for yv in (g.y_center - g.width / 2, g.y_center + g.width / 2):
            if np.any(np.abs(yv) > half * (1 + 1e-9)):
                k = int(np.argmax(np.abs(yv) > half * (1 + 1e-9)))
                raise InputError(f"{where}.y_center", f"groove edge at y = {yv:g} m leaves the reed (half width "
                                                      f"{half[k]:g} m at s = {s[k]:g} m)")

    def mirror(self, g):
        return replace(g, y_center=-g.y_center)

    def occ_surfaces(self, g, occ):
        return [occ.addRectangle(g.s_start, g.y_center - g.width / 2, 0.0, g.s_end - g.s_start, g.width)]


class HalfRingGroove(GrooveShape):
    """The half annulus ``r_inner <= |(s - s_center, y)| <= r_outer`` with ``s >= s_center`` (it closes
    U-shaped grooves toward the tip)."""

    name = "half_ring"
    keys = ("s_center", "r_inner", "r_outer")

    def s_range(self, g):
        return g.s_center, g.s_center + g.r_outer

    def intervals(self, g, s):
        ds = s - g.s_center
        if ds < 0.0 or ds > g.r_outer:
            return []
        y_out = np.sqrt(max(g.r_outer**2 - ds**2, 0.0))
        y_in = np.sqrt(max(g.r_inner**2 - ds**2, 0.0))
        if y_out <= y_in:
            return []
        return [(-y_out, -y_in), (y_in, y_out)]

    def contains(self, g, s, y):
        s = np.asarray(s, dtype=float)
        y = np.asarray(y, dtype=float)
        r = np.hypot(s - g.s_center, y)
        return (s >= g.s_center) & (r >= g.r_inner) & (r <= g.r_outer)

    def volume(self, g):
        return g.depth * np.pi / 2 * (g.r_outer**2 - g.r_inner**2)

    def kinks(self, g):
        return [g.s_center + g.r_inner]        # the section's width in the pocket has a square-root end there

    def check(self, g, reed, where):
        from .errors import InputError

        if not 0.0 <= g.r_inner < g.r_outer:
            raise InputError(f"{where}.r_inner", f"must be in [0, r_outer), got {g.r_inner:g}")
        if g.s_center < 0.0:
            raise InputError(f"{where}.s_center", f"must be >= 0, got {g.s_center:g}")
        th = np.linspace(-np.pi / 2, np.pi / 2, 721)
        s = g.s_center + g.r_outer * np.cos(th)
        y = g.r_outer * np.sin(th)
        if np.any(s > reed.length) or np.any(np.abs(y) > reed.width(s) / 2 * (1 + 1e-9)):
            raise InputError(f"{where}.r_outer", "the half ring leaves the reed outline")

    def occ_surfaces(self, g, occ):
        outer = occ.addDisk(g.s_center, 0.0, 0.0, g.r_outer, g.r_outer)
        box = occ.addRectangle(g.s_center, -2 * g.r_outer, 0.0, 2 * g.r_outer, 4 * g.r_outer)
        half, _ = occ.intersect([(2, outer)], [(2, box)])
        if g.r_inner > 0.0:
            inner = occ.addDisk(g.s_center, 0.0, 0.0, g.r_inner, g.r_inner)
            half, _ = occ.cut(half, [(2, inner)])
        return [t for d, t in half if d == 2]


#: the groove kinds by name (``[[reed.grooves]] kind``)
GROOVE_KINDS: dict[str, GrooveShape] = {k.name: k for k in (RectGroove(), HalfRingGroove())}


@dataclass(frozen=True)
class Groove:
    """A pocket of constant ``depth`` cut into the upstream face (z = 0).

    Its kind is one of :data:`GROOVE_KINDS` (``rect``: :class:`RectGroove`, ``half_ring``: :class:`HalfRingGroove`);
    the fields a kind does not use keep their defaults.
    """

    depth: float = param("depth", "m", "drawing", bounds=_THICK, positive=True)
    kind: str = param("kind", "-", "drawing", default="rect", choices=tuple(GROOVE_KINDS))
    s_start: float = param("s_start", "m", "drawing", default=0.0, bounds=(0.0, _LEN[1]))
    s_end: float = param("s_end", "m", "drawing", default=0.0, bounds=(0.0, _LEN[1]))
    y_center: float = param("y_center", "m", "drawing", default=0.0, bounds=(-_WIDTH[1], _WIDTH[1]))
    width: float = param("width", "m", "drawing", default=0.0, bounds=(0.0, _WIDTH[1]), positive=True)
    s_center: float = param("s_center", "m", "drawing", default=0.0, bounds=(0.0, _LEN[1]))
    r_inner: float = param("r_inner", "m", "drawing", default=0.0, bounds=(0.0, _WIDTH[1]))
    r_outer: float = param("r_outer", "m", "drawing", default=0.0, bounds=(0.0, _WIDTH[1]), positive=True)

    @property
    def shape(self) -> GrooveShape:
        """Its kind (:data:`GROOVE_KINDS`)."""
        return GROOVE_KINDS[self.kind]

    def s_range(self) -> tuple[float, float]:
        """Extent of the pocket along the reed [m]."""
        return self.shape.s_range(self)

    def intervals(self, s: float) -> list[tuple[float, float]]:
        """The y-intervals [m] the pocket occupies across the section at ``s``."""
        return self.shape.intervals(self, s)

    def contains(self, s, y):
        """True where the point (s, y) lies in the pocket (vectorised)."""
        return self.shape.contains(self, s, y)

    @property
    def volume(self) -> float:
        """Pocket volume [m^3] (the pocket lies inside the outline, as validation ensures)."""
        return self.shape.volume(self)


@dataclass(frozen=True)
class Section:
    """One section of a multi-section reed (``[[reed.sections]]``); lengths in m.

    It runs from the previous section's ``s_end`` (0 for the first) to its own ``s_end``,
    with width ``width`` at its start varying linearly to ``taper_to`` at ``s_end`` (None:
    constant width) and thickness ``thickness`` (None: the reed's ``thickness``) at its start
    varying linearly to ``thickness_to`` at ``s_end`` (None: constant thickness).
    """

    s_end: float = param("s_end", "m", "drawing", bounds=_LEN, positive=True)
    width: float = param("width", "m", "drawing", bounds=_WIDTH, positive=True)
    thickness: float | None = param("thickness", "m", "drawing", bounds=_THICK, positive=True, optional=True)
    taper_to: float | None = param("taper_to", "m", "drawing", bounds=_WIDTH, positive=True, optional=True)
    thickness_to: float | None = param("thickness_to", "m", "drawing", bounds=_THICK, positive=True,
                                       optional=True)


@dataclass(frozen=True)
class Piece:
    """A resolved piece of the outline, its width and thickness linear in s.

    s0 <= s < s1 [m], width w0 -> w1 [m] and thickness h -> h1 [m] (``h1`` None: constant thickness h).
    """

    s0: float
    s1: float
    w0: float
    w1: float
    h: float
    h1: float | None = None

    @property
    def tapered(self) -> bool:
        """The width varies along the piece."""
        return self.w0 != self.w1

    @property
    def thickness_tapered(self) -> bool:
        """The thickness varies along the piece."""
        return self.h1 is not None and self.h1 != self.h

    @property
    def h_end(self) -> float:
        """Thickness at s1 [m]."""
        return self.h if self.h1 is None else self.h1

    @property
    def h_min(self) -> float:
        """Smallest thickness on the piece [m]."""
        return min(self.h, self.h_end)

    @property
    def h_max(self) -> float:
        """Largest thickness on the piece [m]."""
        return max(self.h, self.h_end)

    def width(self, s):
        """Straight-edged width [m] at s (linear between w0 and w1; no tip rounding)."""
        if not self.tapered:
            return np.full(np.shape(s), self.w0, dtype=float)
        return self.w0 + (self.w1 - self.w0) * (np.asarray(s, dtype=float) - self.s0) / (self.s1 - self.s0)

    def thickness(self, s):
        """Thickness [m] at s (linear between h and h1; grooves ignored)."""
        if not self.thickness_tapered:
            return np.full(np.shape(s), self.h, dtype=float)
        return self.h + (self.h1 - self.h) * (np.asarray(s, dtype=float) - self.s0) / (self.s1 - self.s0)

    @property
    def area(self) -> float:
        """Face area [m^2] of the straight-edged piece (trapezoid)."""
        return 0.5 * (self.w0 + self.w1) * (self.s1 - self.s0)

    @property
    def volume(self) -> float:
        """Volume [m^3] of the straight-edged piece without grooves: the integral of the product of its linear
        width and thickness, (s1 - s0) (h w0 / 3 + h w1 / 6 + h1 w0 / 6 + h1 w1 / 3)."""
        if not self.thickness_tapered:
            return self.h * self.area
        h0, h1 = self.h, self.h1
        return (self.s1 - self.s0) * (h0 * self.w0 / 3 + (h0 * self.w1 + h1 * self.w0) / 6 + h1 * self.w1 / 3)


@dataclass(frozen=True)
class Reed:
    """A cantilever reed clamped at s = 0; all lengths in m.

    For a reed given by ``sections`` the one-step fields still hold sensible values
    (built by :meth:`from_sections`): ``width_root`` is the first section's width,
    ``width_tip`` the width at the tip end of the last section (before rounding),
    ``step_fraction`` the first section's end / length (0 for one section) and
    ``thickness`` the reed-level default thickness. Every model reads the profile through
    :meth:`pieces`, :meth:`width`, :meth:`thickness_profile` and :meth:`section`.
    """

    length: float = param("length", "m", "drawing (Table 3.1: 1 in)", bounds=_LEN, positive=True,
                          typical=(1e-3, 0.2))
    thickness: float = param("thickness", "m", "drawing (Table 3.1: 1.35 mm)", bounds=_THICK, positive=True)
    width_root: float = param("width_root", "m", "drawing (Table 3.1)", bounds=_WIDTH, positive=True)
    width_tip: float = param("width_tip", "m", "drawing (Table 3.1)", bounds=_WIDTH, positive=True)
    step_fraction: float = param("step_fraction", "-", "R_l (Table 3.1)", bounds=(0.0, 0.999))
    tip_radius: float = param("tip_radius", "m", "drawing (Table 3.5)", bounds=(0.0, _WIDTH[1]))
    material: Material
    grooves: tuple[Groove, ...] = field(default_factory=tuple)
    name: str = "custom"
    sections: tuple[Section, ...] = field(default_factory=tuple)

    @classmethod
    def from_sections(cls, length: float, sections, thickness: float, tip_radius: float,
                      material: Material, grooves=(), name: str = "custom") -> "Reed":
        """A multi-section reed; the one-step fields are derived (see the class docstring)."""
        sections = tuple(sections)
        if not sections:
            raise ValueError("need at least one section")
        last = sections[-1]
        w_tip = last.width if last.taper_to is None else last.taper_to
        step = sections[0].s_end / length if len(sections) > 1 else 0.0
        return cls(length=length, thickness=thickness, width_root=sections[0].width, width_tip=w_tip,
                   step_fraction=step, tip_radius=tip_radius, material=material,
                   grooves=tuple(grooves), name=name, sections=sections)

    # -- the profile as pieces ------------------------------------------------------
    @property
    def is_sectioned(self) -> bool:
        """True for a reed described by ``sections`` (else the one-step form)."""
        return bool(self.sections)

    def pieces(self) -> tuple[Piece, ...]:
        """The outline from the clamp to the tip as pieces of linear width and constant thickness."""
        cached = self.__dict__.get("_pieces")
        if cached is not None:
            return cached
        if self.sections:
            out, s0 = [], 0.0
            for k, sec in enumerate(self.sections):
                s1 = self.length if k == len(self.sections) - 1 else sec.s_end
                h = self.thickness if sec.thickness is None else sec.thickness
                w1 = sec.width if sec.taper_to is None else sec.taper_to
                out.append(Piece(s0, s1, sec.width, w1, h, sec.thickness_to))
                s0 = s1
        else:
            h, L, L1 = self.thickness, self.length, self.step_location
            if self.step_fraction > 0.0:
                out = [Piece(0.0, L1, self.width_root, self.width_root, h),
                       Piece(L1, L, self.width_tip, self.width_tip, h)]
            else:
                out = [Piece(0.0, L, self.width_tip, self.width_tip, h)]
        out = tuple(out)
        self.__dict__["_pieces"] = out  # frozen dataclass: cache beside the fields
        return out

    def _piece_index(self, s) -> np.ndarray:
        """Index of the piece holding each s (a piece holds s0 <= s < s1; the tip belongs to the last)."""
        ends = np.array([p.s1 for p in self.pieces()[:-1]])
        return np.searchsorted(ends, np.asarray(s, dtype=float), side="right")

    @property
    def is_tapered(self) -> bool:
        """True when some piece's width varies linearly (a taper)."""
        return any(p.tapered for p in self.pieces())

    @property
    def has_thickness_taper(self) -> bool:
        """True when some piece's thickness varies linearly."""
        return any(p.thickness_tapered for p in self.pieces())

    @property
    def has_thickness_steps(self) -> bool:
        """True when the thickness changes along the reed (a step between pieces, or a taper)."""
        return len({p.h for p in self.pieces()}) > 1 or self.has_thickness_taper

    @property
    def max_thickness(self) -> float:
        """Largest thickness of any piece [m]."""
        return max(p.h_max for p in self.pieces())

    @property
    def min_thickness(self) -> float:
        """Smallest thickness of any piece [m]."""
        return min(p.h_min for p in self.pieces())

    @property
    def max_width(self) -> float:
        """Largest width of the outline [m]."""
        return max(max(p.w0, p.w1) for p in self.pieces())

    @property
    def is_piecewise_uniform(self) -> bool:
        """True when the profile is a chain of uniform beams: no taper (width or thickness), square tip, no
        grooves."""
        return not self.is_tapered and not self.has_thickness_taper and self.tip_radius == 0.0 and not self.grooves

    def thickness_profile(self, s):
        """Thickness h(s) [m] of the piece at s, grooves ignored (vectorised; ``thickness`` for one-step reeds;
        linear inside a piece with a thickness taper)."""
        if not self.sections:
            return np.full(np.shape(s), self.thickness, dtype=float) if np.ndim(s) else self.thickness
        ps = self.pieces()
        k = np.clip(self._piece_index(s), 0, len(ps) - 1)
        if not self.has_thickness_taper:
            out = np.array([p.h for p in ps])[k]
            return out if np.ndim(s) else float(out)
        s_arr = np.atleast_1d(np.asarray(s, dtype=float))
        k = np.atleast_1d(k)
        out = np.empty(s_arr.shape)
        for i, p in enumerate(ps):
            sel = k == i
            out[sel] = p.thickness(s_arr[sel])
        return out if np.ndim(s) else float(out[0])

    # -- derived lengths (Table 3.5) ------------------------------------------------
    @property
    def step_location(self) -> float:
        """L1 = R_l L [m], where the width changes from width_root to width_tip."""
        return self.step_fraction * self.length

    @property
    def tip_start(self) -> float:
        """s [m] where the rounded tip begins (L1 + L2 of Table 3.5)."""
        return self.length - self.tip_radius

    @property
    def width_ratio(self) -> float:
        """W21 = W2 / W1 (Table 3.1)."""
        return self.width_tip / self.width_root

    @property
    def is_stepped(self) -> bool:
        """True when the width or thickness changes along the reed (a step or a taper)."""
        if self.sections:
            ps = self.pieces()
            return len(ps) > 1 and len({(p.w0, p.w1, p.h) for p in ps}) > 1 or self.is_tapered
        return self.step_fraction > 0.0 and self.width_root != self.width_tip

    # -- outline ----------------------------------------------------------------
    def width(self, s):
        """Outline width W(s) [m] at distance s [m] from the clamp (vectorised)."""
        s = np.asarray(s, dtype=float)
        if self.sections:
            return self._sectioned_width(s)
        w1 = self.width_root if self.step_fraction > 0.0 else self.width_tip
        w = np.where(s < self.step_location, w1, self.width_tip)
        R = self.tip_radius
        if R > 0.0:
            d = np.clip(s - self.tip_start, 0.0, R)
            w = np.where(
                s > self.tip_start,
                self.width_tip - 2 * R + 2 * np.sqrt(np.maximum(R**2 - d**2, 0.0)),
                w,
            )
        return np.where((s < 0.0) | (s > self.length), 0.0, w)

    def _sectioned_width(self, s: np.ndarray) -> np.ndarray:
        ps = self.pieces()
        k = np.clip(self._piece_index(s), 0, len(ps) - 1)
        w = np.empty(s.shape)
        for i, p in enumerate(ps):
            sel = k == i
            w[sel] = p.width(s[sel])
        R = self.tip_radius
        if R > 0.0:
            d = np.clip(s - self.tip_start, 0.0, R)
            w = np.where(s > self.tip_start, w - 2 * R + 2 * np.sqrt(np.maximum(R**2 - d**2, 0.0)), w)
        return np.where((s < 0.0) | (s > self.length), 0.0, w)

    @property
    def face_area(self) -> float:
        """Face area [m^2]: W1 L1 + W2 (L - L1) - (2 - pi/2) R^2 (sum of Table 3.5 areas; trapezoids per section)."""
        if self.sections:
            return sum(p.area for p in self.pieces()) - (2.0 - np.pi / 2.0) * self.tip_radius**2
        L1 = self.step_location
        w1 = self.width_root if self.step_fraction > 0.0 else self.width_tip
        return (
            w1 * L1
            + self.width_tip * (self.length - L1)
            - (2.0 - np.pi / 2.0) * self.tip_radius**2
        )

    def breakpoints(self) -> np.ndarray:
        """Sorted s [m] where W(s), h(s) or the grooves change: steps, section ends, tip start and groove ends."""
        pts = {0.0, self.length}
        if self.sections:
            pts.update(p.s1 for p in self.pieces())
        elif self.step_fraction > 0.0:
            pts.add(self.step_location)
        if self.tip_radius > 0.0:
            pts.add(self.tip_start)
        for g in self.grooves:
            a, b = g.s_range()
            pts.update((min(max(a, 0.0), self.length), min(max(b, 0.0), self.length)))
        return np.array(sorted(pts))

    def section_breaks(self) -> np.ndarray:
        """The :meth:`breakpoints` and the kinks inside grooves (:meth:`GrooveShape.kinks`): where the section
        properties A(s), I(s) are not smooth (the quadrature's pieces), clipped to [0, L]."""
        pts = list(self.breakpoints())
        for g in self.grooves:
            pts += g.shape.kinks(g)
        return np.clip(np.array(pts), 0.0, self.length)

    def outline(self, n_arc: int = 32) -> np.ndarray:
        """Closed outline polygon, counter-clockwise, as an (n, 2) array of (s, y) [m]."""
        if self.sections:
            return self._sectioned_outline(n_arc)
        L, L1, R = self.length, self.step_location, self.tip_radius
        w1 = (self.width_root if self.step_fraction > 0.0 else self.width_tip) / 2
        w2 = self.width_tip / 2
        pts = [(0.0, -w1)]
        if L1 > 0.0 and w1 != w2:
            pts += [(L1, -w1), (L1, -w2)]
        if R > 0.0:
            # lower corner arc about (L - R, -(w2 - R)), then upper about (L - R, w2 - R)
            for yc, a0, a1 in ((-(w2 - R), -np.pi / 2, 0.0), (w2 - R, 0.0, np.pi / 2)):
                for a in np.linspace(a0, a1, n_arc + 1):
                    pts.append((L - R + R * np.cos(a), yc + R * np.sin(a)))
        else:
            pts += [(L, -w2), (L, w2)]
        if L1 > 0.0 and w1 != w2:
            pts += [(L1, w2), (L1, w1)]
        pts.append((0.0, w1))
        out = [pts[0]]
        for p in pts[1:]:  # drop repeats (a full semicircle meets itself at y = 0)
            if np.hypot(p[0] - out[-1][0], p[1] - out[-1][1]) > 1e-12:
                out.append(p)
        return np.array(out)

    def lower_edge(self, n_arc: int = 32) -> list[tuple[float, float]]:
        """Points (s, y) [m] of the lower edge y = -W(s)/2 from the clamp corner to the tip end (y <= 0).

        Straight edges are given by their ends (a step adds a point on each side); the
        rounded tip corner by ``n_arc + 1`` points, evenly spaced in angle.
        """
        ps, R, L = self.pieces(), self.tip_radius, self.length
        pts = [(0.0, -ps[0].w0 / 2)]
        for k, p in enumerate(ps):
            last = k == len(ps) - 1
            s_end = self.tip_start if (last and R > 0.0) else p.s1
            if s_end > pts[-1][0] + 1e-12 * L and (p.tapered or last or ps[k + 1].w0 != p.w1):
                pts.append((s_end, -float(p.width(s_end)) / 2))
            if not last and ps[k + 1].w0 != p.w1:
                pts.append((p.s1, -ps[k + 1].w0 / 2))
        if R > 0.0:
            p = ps[-1]
            for a in np.linspace(0.0, np.pi / 2, n_arc + 1)[1:]:
                d = R * np.sin(a)
                s = self.tip_start + d
                pts.append((s, -(float(p.width(s)) / 2 - (R - R * np.cos(a)))))
        return pts

    def _sectioned_outline(self, n_arc: int) -> np.ndarray:
        low = self.lower_edge(n_arc)
        if self.tip_radius == 0.0 or low[-1][1] < -1e-12 * self.length:
            up = [(s, -y) for s, y in reversed(low)]
        else:
            up = [(s, -y) for s, y in reversed(low[:-1])]
        pts = low + up
        out = [pts[0]]
        for p in pts[1:]:
            if np.hypot(p[0] - out[-1][0], p[1] - out[-1][1]) > 1e-12:
                out.append(p)
        return np.array(out)

    # -- thickness and sections ---------------------------------------------------
    def groove_depth(self, s, y):
        """Depth [m] of the pocket at (s, y), 0 outside grooves (vectorised)."""
        s = np.asarray(s, dtype=float)
        y = np.asarray(y, dtype=float)
        depth = np.zeros(np.broadcast(s, y).shape)
        for g in self.grooves:
            depth = np.maximum(depth, np.where(g.contains(s, y), g.depth, 0.0))
        return depth

    def local_thickness(self, s, y):
        """Material thickness [m] at the face point (s, y): h(s) minus any pocket depth."""
        return self.thickness_profile(s) - self.groove_depth(s, y)

    def _pockets(self, s: float, width: float | None = None) -> list[tuple[float, float, float]]:
        """Pockets across the section at s as (y0, y1, depth), clipped to the outline (``width`` [m]: W(s), if
        known), merged."""
        half = float(self.width(s) if width is None else width) / 2
        by_depth: dict[float, list[tuple[float, float]]] = {}
        for g in self.grooves:
            for a, b in g.intervals(s):
                a, b = max(a, -half), min(b, half)
                if b > a:
                    by_depth.setdefault(g.depth, []).append((a, b))
        out = []
        for depth, ivs in by_depth.items():
            ivs.sort()
            cur = list(ivs[0])
            for a, b in ivs[1:]:
                if a <= cur[1]:
                    cur[1] = max(cur[1], b)
                else:
                    out.append((cur[0], cur[1], depth))
                    cur = [a, b]
            out.append((cur[0], cur[1], depth))
        return out

    def section(self, s) -> tuple[np.ndarray, np.ndarray]:
        """Cross-section area A(s) [m^2] and second moment I(s) [m^4] about its own centroid.

        Rectangle W(s) h(s) minus the groove pockets cut from the upstream face, so the
        neutral axis shifts toward the downstream face where grooves are cut. At a step
        (width or thickness) the value is the one of the piece beginning there.
        """
        s_arr = np.atleast_1d(np.asarray(s, dtype=float))
        A = np.empty_like(s_arr)
        I = np.empty_like(s_arr)
        hs = np.atleast_1d(self.thickness_profile(s_arr))
        Ws = np.atleast_1d(self.width(s_arr))       # vectorised: the same values as one s at a time
        for k, sk in enumerate(s_arr):
            parts = self._section_parts(sk, float(hs[k]), float(Ws[k]))
            a = sum(p[0] for p in parts)
            if a <= 0.0:
                A[k], I[k] = 0.0, 0.0
                continue
            zc = sum(p[0] * p[1] for p in parts) / a
            A[k] = a
            I[k] = sum(p[2] + p[0] * (p[1] - zc) ** 2 for p in parts)
        if np.ndim(s) == 0:
            return A[0], I[0]
        return A, I

    def _section_parts(self, s: float, h: float, W: float) -> list[tuple[float, float, float]]:
        """(area [m^2], centroid z [m], own second moment [m^4]) of the rectangle W h and of each pocket (negative)
        of the section at s: what :meth:`section` and :meth:`neutral_axis` add up."""
        parts = [(W * h, h / 2, W * h**3 / 12)]
        for y0, y1, d in (self._pockets(s, W) if self.grooves else ()):
            w = y1 - y0
            parts.append((-w * d, d / 2, -w * d**3 / 12))
        return parts

    def neutral_axis(self, s: float) -> float:
        """Height of the section's centroid above the upstream face z = 0 [m]: h/2 without grooves, shifted toward
        the downstream face by the pockets cut from the upstream one.

        Parameters
        ----------
        s : float
            Position from the clamp [m].

        Returns
        -------
        float
            z_c [m].
        """
        parts = self._section_parts(s, float(self.thickness_profile(s)), float(self.width(s)))
        return sum(p[0] * p[1] for p in parts) / sum(p[0] for p in parts)

    def thickness_at(self, s):
        """Section-mean thickness A(s) / W(s) [m]; equals ``thickness`` where there is no groove."""
        A, _ = self.section(s)
        W = self.width(s)
        return np.where(W > 0, A / np.where(W > 0, W, 1.0), 0.0)

    def scaled(self, length: float = 1.0, thickness: float = 1.0, name: str | None = None) -> "Reed":
        """This reed stretched ``length`` times along s and ``thickness`` times through its thickness.

        Every position along s (length, sections' ends, grooves' s_start, s_end, s_center)
        scales with ``length``; every thickness and groove depth with ``thickness``; widths,
        the tip radius and the ring radii of half-ring grooves stay. E.g. ``scaled(2, 0.5)``:
        twice as long and half as thick (a reed whose one-mode model should fail first).
        """
        a, b = float(length), float(thickness)
        sections = tuple(replace(sec, s_end=sec.s_end * a,
                                 thickness=None if sec.thickness is None else sec.thickness * b,
                                 thickness_to=None if sec.thickness_to is None else sec.thickness_to * b)
                         for sec in self.sections)
        grooves = tuple(replace(g, depth=g.depth * b, s_start=g.s_start * a, s_end=g.s_end * a,
                                s_center=g.s_center * a) for g in self.grooves)
        return replace(self, length=self.length * a, thickness=self.thickness * b, sections=sections,
                       grooves=grooves, name=self.name if name is None else name)

    def with_heavy_tip(self, factor: float = 3.0, name: str | None = None) -> "Reed":
        """This reed with its tip piece ``factor`` times as thick (a reed whose one-mode model should fail).

        The tip piece is the rounded end, s >= L - tip_radius (the last quarter for a square tip),
        within the last piece; the reed is rewritten as sections so the step is a thickness step of
        the downstream face. Widths, tapers, grooves and the material stay.
        """
        pieces = list(self.pieces())
        last = pieces[-1]
        start = self.length - (self.tip_radius if self.tip_radius > 0.0 else 0.25 * self.length)
        start = max(start, last.s0)
        w_split = float(last.width(start)) if last.tapered else last.w0
        h_split = float(last.thickness(start)) if last.thickness_tapered else last.h
        taper = last.thickness_tapered
        sections = [Section(s_end=p.s1, width=p.w0, thickness=p.h, taper_to=p.w1 if p.tapered else None,
                            thickness_to=p.h1 if p.thickness_tapered else None) for p in pieces[:-1]]
        if start > last.s0:
            sections.append(Section(s_end=start, width=last.w0, thickness=last.h,
                                    taper_to=w_split if last.tapered else None,
                                    thickness_to=h_split if taper else None))
        sections.append(Section(s_end=self.length, width=w_split, thickness=h_split * float(factor),
                                taper_to=last.w1 if last.tapered else None,
                                thickness_to=last.h_end * float(factor) if taper else None))
        return Reed.from_sections(self.length, sections, self.thickness, self.tip_radius, self.material,
                                  self.grooves, self.name if name is None else name)

    def _corner_volume(self) -> float:
        """Volume [m^3] the rounded tip cuts from the square one: (2 - pi/2) R^2 h at the tip's start, plus,
        on a thickness taper of slope h', h' R^3 / 3 (the corners' first moment about the tip's start)."""
        last, r = self.pieces()[-1], self.tip_radius
        if not last.thickness_tapered:
            return last.h * (2.0 - np.pi / 2.0) * r**2
        slope = (last.h1 - last.h) / (last.s1 - last.s0)
        return float(last.thickness(self.tip_start)) * (2.0 - np.pi / 2.0) * r**2 + slope * r**3 / 3.0

    def mass_per_length(self, s):
        """m(s) = rho_c A(s) [kg/m], the mass per unit length of eq 3.8."""
        A, _ = self.section(s)
        return self.material.density * A

    def flexural_rigidity(self, s):
        """EI(s) [N m^2] of the (possibly grooved) section."""
        _, I = self.section(s)
        return self.material.youngs_modulus * I

    @property
    def mass(self) -> float:
        """Reed mass [kg] from s = 0 to the tip: rho_c (sum of h A_face per piece - groove volume)."""
        if self.sections:
            ps = self.pieces()
            vol = sum(p.volume for p in ps) - self._corner_volume() - sum(g.volume for g in self.grooves)
            return self.material.density * vol
        vol = self.thickness * self.face_area - sum(g.volume for g in self.grooves)
        return self.material.density * vol
