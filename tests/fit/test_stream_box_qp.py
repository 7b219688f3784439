"""The streaming solver's box QP (hand-written active set) against scipy.optimize.lsq_linear."""

import numpy as np
import pytest
from scipy.linalg import cholesky, solve_triangular
from scipy.optimize import lsq_linear

from blendvoca.errors import UserError
from blendvoca.fit.box_qp import solve_box_qp


def _random_problem(rng, k, spread=1.5):
    basis = rng.normal(size=(3 * k + 5, k))
    hessian = basis.T @ basis + 1e-3 * np.eye(k)
    target = rng.uniform(-spread, 1 + spread, size=k)  # many outside [0, 1]
    linear = hessian @ target + rng.normal(size=k) * 0.1
    return hessian, linear


def _lsq_reference(hessian, linear, lower, upper):
    """``min 1/2 x^T H x - q x`` as ``min ||L^T x - L^-1 q||^2`` (H = L L^T) by scipy's BVLS."""
    factor = cholesky(hessian, lower=True)
    rhs = solve_triangular(factor, linear, lower=True)
    return lsq_linear(factor.T, rhs, bounds=(lower, upper), method="bvls", tol=1e-14).x


def _kkt_residual(hessian, linear, x, lower, upper):
    gradient = hessian @ x - linear
    free = (x > lower) & (x < upper)
    wrong = np.concatenate([np.abs(gradient[free]), -gradient[(x <= lower) & (lower < upper)],
                            gradient[(x >= upper) & (lower < upper)], [0.0]])
    return wrong.max()


@pytest.mark.parametrize("k", [1, 2, 8, 32])
def test_matches_lsq_linear_on_random_problems(k):
    rng = np.random.default_rng(k)
    for _ in range(20):
        hessian, linear = _random_problem(rng, k)
        lower, upper = np.zeros(k), np.ones(k)
        solution = solve_box_qp(hessian, linear, lower, upper)
        assert solution.certified
        np.testing.assert_allclose(solution.x, _lsq_reference(hessian, linear, lower, upper), atol=1e-8)
        assert np.all(solution.x >= 0) and np.all(solution.x <= 1)
        assert _kkt_residual(hessian, linear, solution.x, lower, upper) < 1e-9 * np.abs(linear).max()


@pytest.mark.parametrize("steps", [1, 2])
def test_primal_phase_alone_reaches_the_optimum(monkeypatch, steps):
    """With (almost) no primal-dual steps the primal method does the work, from cold and warm starts."""
    import blendvoca.fit.box_qp as box_qp

    monkeypatch.setattr(box_qp, "PRIMAL_DUAL_STEPS", steps)
    rng = np.random.default_rng(3)
    for _ in range(20):
        hessian, linear = _random_problem(rng, 32, spread=3.0)
        lower, upper = np.zeros(32), np.ones(32)
        reference = _lsq_reference(hessian, linear, lower, upper)
        for status in (None, np.zeros(32), rng.integers(-1, 2, size=32)):
            solution = solve_box_qp(hessian, linear, lower, upper, status=status)
            assert solution.certified
            np.testing.assert_allclose(solution.x, reference, atol=1e-8)


def test_general_and_equal_bounds():
    rng = np.random.default_rng(5)
    k = 12
    for _ in range(20):
        hessian, linear = _random_problem(rng, k)
        centre = rng.uniform(0, 1, size=k)
        width = rng.uniform(0, 0.3, size=k)
        width[:3] = 0.0  # fixed unknowns
        lower, upper = centre - width, centre + width
        x = solve_box_qp(hessian, linear, lower, upper).x
        np.testing.assert_array_equal(x[:3], centre[:3])
        free = slice(3, None)
        shifted = linear[free] - hessian[free, :3] @ centre[:3]
        reference = _lsq_reference(hessian[free, free], shifted, lower[free], upper[free])
        np.testing.assert_allclose(x[free], reference, atol=1e-8)


def test_any_warm_start_reaches_the_same_optimum():
    rng = np.random.default_rng(7)
    k = 32
    hessian, linear = _random_problem(rng, k)
    lower, upper = np.zeros(k), np.ones(k)
    cold = solve_box_qp(hessian, linear, lower, upper)
    for _ in range(10):
        status = rng.integers(-1, 2, size=k)
        warm = solve_box_qp(hessian, linear, lower, upper, status=status)
        assert warm.certified
        np.testing.assert_allclose(warm.x, cold.x, atol=1e-10)
    # Started from its own answer it needs one solve.
    again = solve_box_qp(hessian, linear, lower, upper, status=cold.status)
    assert again.iterations == 1 and np.array_equal(again.x, cold.x)


def test_iteration_limit_is_reported_not_hidden():
    rng = np.random.default_rng(11)
    hessian, linear = _random_problem(rng, 32, spread=3.0)
    lower, upper = np.zeros(32), np.ones(32)
    solution = solve_box_qp(hessian, linear, lower, upper, status=np.zeros(32), max_iter=1)
    assert not solution.certified
    assert np.all(solution.x >= lower) and np.all(solution.x <= upper)


def test_input_errors():
    with pytest.raises(UserError, match="hessian"):
        solve_box_qp(np.eye(3), np.zeros(2), np.zeros(2), np.ones(2))
    with pytest.raises(UserError, match="lower bound"):
        solve_box_qp(np.eye(2), np.zeros(2), np.ones(2), np.zeros(2))
    with pytest.raises(UserError, match="status"):
        solve_box_qp(np.eye(2), np.zeros(2), np.zeros(2), np.ones(2), status=[2, 0])
