"""The joint least-squares polish's Jacobian (studies.discrepancy.fitting): forward differences simulated in one
batch, then Broyden's secant updates; checked against the closed-form Jacobian of linear and quadratic residuals."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import least_squares

from studies.discrepancy.fitting import POLISH_STEP, SecantJacobian, forward_jacobian

A = np.array([[1.0, 2.0, 0.0], [0.5, -1.0, 3.0], [2.0, 0.0, 1.0], [0.0, 4.0, -2.0]])
B = np.array([0.3, -0.2, 0.1, 0.5])


class Batches:
    """A stand-in for Problem.sims: records each batch of (condition, model) jobs."""

    def __init__(self):
        self.batches = []

    def many(self, jobs):
        self.batches.append(list(jobs))
        return [None] * len(jobs)


def problem():
    runs = [SimpleNamespace(name="a"), SimpleNamespace(name="b")]
    return SimpleNamespace(sims=Batches(), conds={"a": "cond a", "b": "cond b"}, fit_runs=runs)


def model_of(u):
    return tuple(np.round(u, 12))


def linear(u):
    return A @ u + B


def test_forward_jacobian_of_linear_residuals_is_exact_and_one_batch():
    pb = problem()
    u = np.array([0.2, 0.995, 0.5])            # the second one step from its upper bound: a backward step
    J = forward_jacobian(pb, linear, model_of, u, (np.zeros(3), np.ones(3)), linear(u))
    assert J == pytest.approx(A, rel=1e-9, abs=1e-9)
    assert len(pb.sims.batches) == 1 and len(pb.sims.batches[0]) == 3 * 2     # every column, every fitting run
    stepped = [np.array(m) for _, m in pb.sims.batches[0][::2]]
    assert stepped[1][1] == pytest.approx(u[1] - POLISH_STEP)                 # stays inside the bounds
    assert all(np.all(s <= 1.0) for s in stepped)


def test_secant_update_meets_the_secant_condition_and_keeps_an_exact_jacobian_exact():
    def quad(u):                               # a residual with a curvature: the update is not exact in general
        return A @ u + B + np.array([u[0] ** 2, 0.0, u[1] * u[2], 0.0])

    pb = problem()
    jac = SecantJacobian(pb, quad, model_of, (np.zeros(3), np.ones(3)))
    u0, u1 = np.array([0.2, 0.3, 0.4]), np.array([0.25, 0.28, 0.45])
    J0 = jac(u0).copy()
    J1 = jac(u1)
    assert J1 @ (u1 - u0) == pytest.approx(quad(u1) - quad(u0), rel=1e-12, abs=1e-12)   # Broyden's condition
    assert len(pb.sims.batches) == 1                       # the update simulates nothing
    # a direction orthogonal to the step keeps the earlier Jacobian's derivative
    ortho = np.cross(u1 - u0, [1.0, 0.0, 0.0])
    assert J1 @ ortho == pytest.approx(J0 @ ortho, rel=1e-12, abs=1e-12)
    lin = SecantJacobian(problem(), linear, model_of, (np.zeros(3), np.ones(3)))
    lin(u0)
    assert lin(u1) == pytest.approx(A, rel=1e-9, abs=1e-9)


def test_least_squares_with_the_secant_jacobian_reaches_the_minimum_of_a_smooth_problem():
    # the closed-form least-squares solution of a linear problem inside the box, reached within a polish's
    # budget of evaluations (Settings.polish_nfev = 5 per parameter)
    target = np.array([0.3, 0.6, 0.45])
    b = -A @ target
    fun = lambda u: A @ u + b                               # noqa: E731
    res = least_squares(fun, np.full(3, 0.5), jac=SecantJacobian(problem(), fun, model_of, (np.zeros(3), np.ones(3))),
                        bounds=(np.zeros(3), np.ones(3)), x_scale=0.1, max_nfev=15, method="trf")
    assert res.x == pytest.approx(target, abs=1e-6)
