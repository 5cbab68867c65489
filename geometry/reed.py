"""Parametric reed: the one description that formulas and meshes are built from.

Coordinates (SI units): ``s`` runs along the reed from the clamp line (s = 0) to
the tip (s = length); ``y`` runs across it from the centre line; ``z`` runs
through the thickness from the upstream face (z = 0, where grooves are cut) to
the downstream face (z = thickness).

The outline is a root section of width ``width_root`` for
``0 <= s < step_fraction * length`` (thesis Table 3.1, R_l), then ``width_tip``
up to a tip rounded with ``tip_radius`` (Table 3.5: a full semicircle when
``tip_radius == width_tip / 2``, square when 0).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Material:
    """Linear elastic reed material; SI units (Pa, kg/m^3)."""

    youngs_modulus: float
    density: float
    poisson_ratio: float


@dataclass(frozen=True)
class Groove:
    """A pocket of constant ``depth`` cut into the upstream face (z = 0).

    ``kind = "rect"``: the box ``s_start <= s <= s_end``, ``|y - y_center| <= width / 2``.
    ``kind = "half_ring"``: the half annulus ``r_inner <= |(s - s_center, y)| <= r_outer``
    with ``s >= s_center`` (it closes U-shaped grooves toward the tip).
    """

    depth: float
    kind: str = "rect"
    s_start: float = 0.0
    s_end: float = 0.0
    y_center: float = 0.0
    width: float = 0.0
    s_center: float = 0.0
    r_inner: float = 0.0
    r_outer: float = 0.0

    def s_range(self) -> tuple[float, float]:
        """Extent of the pocket along the reed [m]."""
        if self.kind == "half_ring":
            return self.s_center, self.s_center + self.r_outer
        return self.s_start, self.s_end

    def intervals(self, s: float) -> list[tuple[float, float]]:
        """The y-intervals [m] the pocket occupies across the section at ``s``."""
        if self.kind == "half_ring":
            ds = s - self.s_center
            if ds < 0.0 or ds > self.r_outer:
                return []
            y_out = np.sqrt(max(self.r_outer**2 - ds**2, 0.0))
            y_in = np.sqrt(max(self.r_inner**2 - ds**2, 0.0))
            if y_out <= y_in:
                return []
            return [(-y_out, -y_in), (y_in, y_out)]
        if self.s_start <= s <= self.s_end:
            return [(self.y_center - self.width / 2, self.y_center + self.width / 2)]
        return []

    def contains(self, s, y):
        """True where the point (s, y) lies in the pocket (vectorised)."""
        s = np.asarray(s, dtype=float)
        y = np.asarray(y, dtype=float)
        if self.kind == "half_ring":
            r = np.hypot(s - self.s_center, y)
            return (s >= self.s_center) & (r >= self.r_inner) & (r <= self.r_outer)
        return (
            (s >= self.s_start)
            & (s <= self.s_end)
            & (np.abs(y - self.y_center) <= self.width / 2)
        )


@dataclass(frozen=True)
class Reed:
    """A cantilever reed clamped at s = 0; all lengths in m."""

    length: float
    thickness: float
    width_root: float
    width_tip: float
    step_fraction: float
    tip_radius: float
    material: Material
    grooves: tuple[Groove, ...] = field(default_factory=tuple)
    name: str = "custom"

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
        return self.step_fraction > 0.0 and self.width_root != self.width_tip

    # -- outline ----------------------------------------------------------------
    def width(self, s):
        """Outline width W(s) [m] at distance s [m] from the clamp (vectorised)."""
        s = np.asarray(s, dtype=float)
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

    @property
    def face_area(self) -> float:
        """Face area [m^2]: W1 L1 + W2 (L - L1) - (2 - pi/2) R^2 (sum of Table 3.5 areas)."""
        L1 = self.step_location
        w1 = self.width_root if self.step_fraction > 0.0 else self.width_tip
        return (
            w1 * L1
            + self.width_tip * (self.length - L1)
            - (2.0 - np.pi / 2.0) * self.tip_radius**2
        )

    def breakpoints(self) -> np.ndarray:
        """Sorted s [m] where W(s) or the grooves change: the step, tip start and groove ends."""
        pts = {0.0, self.length}
        if self.step_fraction > 0.0:
            pts.add(self.step_location)
        if self.tip_radius > 0.0:
            pts.add(self.tip_start)
        for g in self.grooves:
            a, b = g.s_range()
            pts.update((min(max(a, 0.0), self.length), min(max(b, 0.0), self.length)))
        return np.array(sorted(pts))

    def outline(self, n_arc: int = 32) -> np.ndarray:
        """Closed outline polygon, counter-clockwise, as an (n, 2) array of (s, y) [m]."""
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
        """Material thickness [m] at the face point (s, y): h minus any pocket depth."""
        return self.thickness - self.groove_depth(s, y)

    def _pockets(self, s: float) -> list[tuple[float, float, float]]:
        """Pockets across the section at s as (y0, y1, depth), clipped to the outline, merged."""
        half = float(self.width(s)) / 2
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

        Rectangle W h minus the groove pockets cut from the upstream face, so the
        neutral axis shifts toward the downstream face where grooves are cut.
        """
        s_arr = np.atleast_1d(np.asarray(s, dtype=float))
        A = np.empty_like(s_arr)
        I = np.empty_like(s_arr)
        h = self.thickness
        for k, sk in enumerate(s_arr):
            W = float(self.width(sk))
            parts = [(W * h, h / 2, W * h**3 / 12)]  # (area, centroid z, own I)
            for y0, y1, d in self._pockets(sk):
                w = y1 - y0
                parts.append((-w * d, d / 2, -w * d**3 / 12))
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

    def thickness_at(self, s):
        """Section-mean thickness A(s) / W(s) [m]; equals ``thickness`` where there is no groove."""
        A, _ = self.section(s)
        W = self.width(s)
        return np.where(W > 0, A / np.where(W > 0, W, 1.0), 0.0)

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
        """Reed mass [kg] from s = 0 to the tip: rho_c (h A_face - groove volume)."""
        vol = self.thickness * self.face_area - sum(_groove_volume(g) for g in self.grooves)
        return self.material.density * vol


def _groove_volume(g: Groove) -> float:
    """Pocket volume [m^3] (assumes the pocket lies inside the outline, as validation ensures)."""
    if g.kind == "half_ring":
        return g.depth * np.pi / 2 * (g.r_outer**2 - g.r_inner**2)
    return g.depth * g.width * (g.s_end - g.s_start)
