"""The step-anatomy benchmark's two Rosenbrock tableaus have their orders (benchmarks/pump_step_anatomy.py).

Its README claim (Rodas5P's cost against Rodas4P's on the pump) rests on the transcribed Rodas5P
coefficients and on its step driver: both are checked here on a stiff, nonlinear,
non-autonomous problem, y0' = -L (y0 - sin t) + cos t (Prothero-Robinson, L = 50) and
y1' = -y1^2 + y0, against scipy's Radau at rtol 1e-13: fixed steps h = 1/20 .. 1/80 over [0, 1]
must converge at order 4 (Rodas4P) and 5 (Rodas5P). A mistyped coefficient drops the order to
1-3.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import pump_step_anatomy as anatomy  # noqa: E402

LAMBDA = 50.0


def _rhs(t, y, p, out):
    out[0] = -LAMBDA * (y[0] - math.sin(t)) + math.cos(t)
    out[1] = -y[1] ** 2 + y[0]


def _jac(t, y, p, f0, jac, ft, yp, fp, atol, rtol, n_dyn, h):
    jac[:] = 0.0
    jac[0, 0] = -LAMBDA
    jac[1, 0] = 1.0
    jac[1, 1] = -2.0 * y[1]
    ft[0] = LAMBDA * math.cos(t) - math.sin(t)
    ft[1] = 0.0
    return 0


def _errors(tab) -> list[float]:
    seg = anatomy.Segment({"rhs": _rhs, "jacobian": _jac, "update_tolerances": lambda p, atol: None},
                          np.zeros(1), np.full(2, 1e-6), 1e-6, 2)
    y0 = np.array([0.3, 1.0])

    def f(t, y):
        out = np.empty(2)
        _rhs(t, y, None, out)
        return out

    exact = solve_ivp(f, (0.0, 1.0), y0, method="Radau", rtol=1e-13, atol=1e-14).y[:, -1]
    errors = []
    for n in (20, 40, 80):
        y, t = y0.copy(), 0.0
        for _ in range(n):
            y = seg.step(tab, t, y, 1.0 / n)[0]
            t += 1.0 / n
        errors.append(float(np.max(np.abs(y - exact))))
    return errors


@pytest.mark.parametrize("name, order", [("rodas4p", 4), ("rodas5p", 5)])
def test_tableau_converges_at_its_order(name, order):
    tab = getattr(anatomy, name)()
    e = _errors(tab)
    observed = math.log2(e[1] / e[2])
    assert observed > order - 0.3, (name, e, observed)
    assert tab[-1] == order          # the controller's exponent is 1/order
