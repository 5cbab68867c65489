"""The Reynolds-consistent orifice solve of lumped/fluid/orifice.py against an independent solve."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lumped.fluid import orifice
from lumped.model.model_file import load_model

#: (Cd_inf, A, B, C) of eqs 2.48 (disc, last coefficient corrected) and 3.89 (reed)
CORRELATIONS = {v: tuple(getattr(load_model(v).inlet, f) for f in ("cd_inf", "cd_a", "cd_b", "cd_c"))
                for v in ("disc", "reed")}
RHO, MU, PERIMETER = 876.0, 0.0683, 0.0658
K = 4 * RHO / (MU * PERIMETER)


def _exact_s(g: float, cd_inf: float, a: float, b: float, c: float) -> np.longdouble:
    """s = sqrt(Re) solving s^2 = G Cd(s), by bisection on ln s in extended precision."""
    L = np.longdouble
    g, cd_inf, a, b, c = map(L, (g, cd_inf, a, b, c))

    def w(sig):
        s = np.exp(sig)
        return 2 * sig - np.log(a * np.expm1(-b * s) - (cd_inf + a) * np.expm1(-c * s)) - np.log(g)

    lo, hi = L(-120), L(60)
    for _ in range(120):
        mid = (lo + hi) / 2
        if w(mid) < 0:
            lo = mid
        else:
            hi = mid
    return np.exp((lo + hi) / 2)


@pytest.mark.parametrize("valve", ["disc", "reed"])
def test_flow_and_cd_match_an_extended_precision_solve(valve):
    """Q and Cd within 1e-13 of a long-double bisection, from creeping to fully turbulent flow."""
    par = CORRELATIONS[valve]
    dp = 2.0e5
    worst_q = worst_cd = 0.0
    for lg in np.linspace(-30.0, 25.0, 111):          # G from 1e-13 to 7e10: sqrt(Re) from 1e-15 to 2e5
        g = math.exp(lg)
        area = g / (K * math.sqrt(2 * dp / RHO))
        q, cd, dq_ddp, dq_da = orifice.orifice_flow(area, dp, RHO, MU, PERIMETER, *par)
        s = _exact_s(K * area * math.sqrt(2 * dp / RHO), *par)
        q_exact = float(s * s / np.longdouble(K))
        worst_q = max(worst_q, abs(q / q_exact - 1))
        worst_cd = max(worst_cd, abs(cd / float(orifice.discharge_coefficient(s, *par)) - 1))
    # the correlation itself loses ~1e-14 to cancellation near Re -> 0 (reed: A ~ -(Cd_inf + A))
    assert worst_q < 1e-13 and worst_cd < 1e-13


@pytest.mark.parametrize("valve", ["disc", "reed"])
def test_few_iterations_over_the_pump_range(valve, monkeypatch):
    """Halley from the laminar/turbulent limits: about 3 Cd evaluations for sqrt(Re) in 1e-2..1e3.

    (Counted through the exponentials: two per evaluation, plus e^step for long steps; the
    Newton solve it replaced needed 5-7 evaluations of four exponentials each.)
    """
    par = CORRELATIONS[valve]
    calls = [0]

    class Counting:
        def __getattr__(self, name):
            f = getattr(math, name)
            if name in ("exp", "expm1"):
                def counted(x):
                    calls[0] += 1
                    return f(x)
                return counted
            return f

    monkeypatch.setattr(orifice, "math", Counting())
    counts = []
    for sig in np.linspace(math.log(1e-2), math.log(1e3), 60):
        s = math.exp(sig)
        g = s * s / float(orifice.discharge_coefficient(s, *par))
        calls[0] = 0
        orifice.orifice_flow(g / (K * math.sqrt(2 * 1e5 / RHO)), 1e5, RHO, MU, PERIMETER, *par)
        counts.append(calls[0] / 2)
    assert max(counts) <= 5 and np.mean(counts) <= 3.5


def test_derivatives_are_those_of_the_flow():
    """dQ/d(dp) and dQ/dA against central differences, both signs of dp."""
    par = CORRELATIONS["reed"]
    for area, dp in ((1e-7, 3e3), (4e-6, -2e5), (1e-5, 1.5e6)):
        q, cd, dq_ddp, dq_da = orifice.orifice_flow(area, dp, RHO, MU, PERIMETER, *par)
        h = abs(dp) * 1e-6
        fd = (orifice.orifice_flow(area, dp + h, RHO, MU, PERIMETER, *par)[0]
              - orifice.orifice_flow(area, dp - h, RHO, MU, PERIMETER, *par)[0]) / (2 * h)
        assert dq_ddp == pytest.approx(fd, rel=1e-7)
        ha = area * 1e-6
        fa = (orifice.orifice_flow(area + ha, dp, RHO, MU, PERIMETER, *par)[0]
              - orifice.orifice_flow(area - ha, dp, RHO, MU, PERIMETER, *par)[0]) / (2 * ha)
        assert dq_da == pytest.approx(fa, rel=1e-7)
