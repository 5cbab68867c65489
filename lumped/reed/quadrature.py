"""Spectral quadrature on a reed's piecewise-smooth profile (shared by every reed model).

Integrals over a reed (mode-function parameters, static deflection chains) have
integrands that jump at the width step and behave like square roots at rounded tips
and inside grooves (half rings); a rule across such points converges slowly. Splitting the
reed at its breakpoints and mapping each piece so the end behaviour becomes analytic
gives exponential convergence with a few tens of nodes per piece.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.polynomial import chebyshev as _cheb

from geometry.reed import Reed

#: Chebyshev nodes per piece between breakpoints; 24 gives ~1e-12 on the thesis reeds
NODES_PER_PIECE = 24


@lru_cache(maxsize=8)
def _cheb_rule(n: int):
    """Chebyshev-Gauss nodes x in (-1, 1) and the matrices turning nodal values into antiderivative coefficients."""
    x = np.sort(np.cos((2 * np.arange(n) + 1) * np.pi / (2 * n)))
    Vinv = np.linalg.inv(_cheb.chebvander(x, n - 1))
    eye = np.eye(n)
    # antiderivatives vanishing at x = -1 (forward) and x = +1 (backward), (n+1, n) each
    fwd = np.column_stack([_cheb.chebint(eye[j], lbnd=-1) for j in range(n)]) @ Vinv
    bwd = np.column_stack([_cheb.chebint(eye[j], lbnd=1) for j in range(n)]) @ Vinv
    return x, fwd, bwd


class ProfileQuadrature:
    """Spectral cumulative quadrature on [0, L] for a reed's piecewise-smooth profile.

    Each piece [a, b] between breakpoints is mapped by s = a + (b - a)(1 - cos(pi t)) / 2,
    t in (0, 1), which makes the square-root end behaviour of rounded tips and
    half-ring grooves analytic in t; Chebyshev interpolation in t is then exponentially
    accurate. ``forward(f)`` gives int_0^s f at the nodes, ``backward(f)`` int_s^L f,
    ``weights`` the definite integral, ``forward_at(s_out)`` the forward operator
    evaluated at arbitrary points.
    """

    def __init__(self, breaks: np.ndarray, n: int = NODES_PER_PIECE):
        br = np.unique(np.asarray(breaks, dtype=float))
        br = br[np.append(np.diff(br) > 1e-12 * br[-1], True)]  # drop near-duplicates, keep L
        self.breaks = br
        self.n = n
        x, fwd, bwd = _cheb_rule(n)
        t = (x + 1) / 2
        pieces = len(br) - 1
        N = pieces * n
        self.s = np.empty(N)
        self.dsdt = np.empty(N)
        Tn = _cheb.chebvander(x, n)  # (n, n+1) evaluates antiderivative coefficient vectors
        Fl = Tn @ fwd / 2  # d t / d x = 1/2
        Bl = -(Tn @ bwd) / 2
        tot = (_cheb.chebvander(np.array([1.0]), n) @ fwd / 2)[0]
        Q = np.zeros((N, N))
        R = np.zeros((N, N))
        w = np.zeros(N)
        for k in range(pieces):
            a, b = br[k], br[k + 1]
            sl = slice(k * n, (k + 1) * n)
            self.s[sl] = a + (b - a) * (1 - np.cos(np.pi * t)) / 2
            self.dsdt[sl] = (b - a) * np.pi / 2 * np.sin(np.pi * t)
            w[sl] = tot * self.dsdt[sl]
        for k in range(pieces):
            sl = slice(k * n, (k + 1) * n)
            J = self.dsdt[sl]
            Q[sl, sl] = Fl * J
            Q[sl, : k * n] = w[: k * n]
            R[sl, sl] = Bl * J
            R[sl, (k + 1) * n:] = w[(k + 1) * n:]
        self.weights = w
        self.Q = Q
        self.R = R
        self._fwd = fwd

    def integral(self, f) -> float:
        """int_0^L f ds for nodal values f."""
        return float(self.weights @ f)

    def forward_at(self, s_out) -> np.ndarray:
        """Matrix (len(s_out), N) giving int_0^{s_out} f ds from nodal values f."""
        s_out = np.atleast_1d(np.asarray(s_out, dtype=float))
        n, br = self.n, self.breaks
        k = np.clip(np.searchsorted(br, s_out, side="right") - 1, 0, len(br) - 2)
        a, b = br[k], br[k + 1]
        t = np.arccos(np.clip(1 - 2 * (s_out - a) / (b - a), -1.0, 1.0)) / np.pi
        rows = _cheb.chebvander(2 * t - 1, n) @ self._fwd / 2  # (len, n) partial weights in t
        E = np.zeros((s_out.size, self.s.size))
        for kk in np.unique(k):
            sel = k == kk
            sl = slice(kk * n, (kk + 1) * n)
            E[np.ix_(sel, np.arange(sl.start, sl.stop))] = rows[sel] * self.dsdt[sl]
            E[sel, : kk * n] = self.weights[: kk * n]
        return E


def profile_breaks(reed: Reed) -> np.ndarray:
    """Breakpoints of the section properties (geometry.reed.Reed.section_breaks).

    Parameters
    ----------
    reed : geometry.Reed
        The reed.

    Returns
    -------
    array of float
        Arc lengths [m] where EI(s) or m(s) jumps or changes law.
    """
    return reed.section_breaks()
