import numpy as np
import pytest
import qpsolvers

from blendvoca.fit import (
    fit_coefficients,
    fit_sequence,
    least_squares_coefficients,
    normal_equations,
    solve_banded_qp,
    solve_sparse_qp,
)

from .conftest import drive, make_rig, smooth_track


def test_recovers_known_coefficients(rng):
    neutral, deltas = make_rig(rng, 300, 32)
    truth = smooth_track(rng, 120, 32)
    frames = drive(neutral, deltas, truth)
    coeffs = fit_coefficients(neutral, deltas, frames, rate_bound=0.1)
    assert coeffs.shape == (120, 32)
    assert np.abs(coeffs - truth).max() < 1e-4


def test_recovers_known_coefficients_at_the_bounds(rng):
    # Coefficients that sit on 0 and 1 (as speech tracks do) and move at the rate limit.
    neutral, deltas = make_rig(rng, 150, 6)
    truth = np.zeros((30, 6))
    truth[:, 1] = 1.0
    truth[:, 2] = np.minimum(np.arange(30) * 0.1, 1.0)  # exactly at the rate bound
    truth[:, 3] = np.clip(np.sin(np.arange(30) / 5.0), 0, 1) * 0.3
    frames = drive(neutral, deltas, truth)
    coeffs = fit_coefficients(neutral, deltas, frames, rate_bound=0.1)
    assert np.abs(coeffs - truth).max() < 1e-4


def test_vertex_subset_ignores_other_vertices(rng):
    neutral, deltas = make_rig(rng, 200, 8)
    truth = smooth_track(rng, 40, 8)
    frames = drive(neutral, deltas, truth)
    frames[:, 150:] += 0.5  # garbage outside the subset (like the FLAME neck and eyeballs)
    coeffs = fit_coefficients(neutral, deltas, frames, vertex_subset=np.arange(150))
    assert np.abs(coeffs - truth).max() < 1e-4


def _dense_reference(system, delta=0.1, bounds=True, solver="cvxopt"):
    """The QP solved by a dense interior-point solver (an independent reference)."""
    T, K = system.rhs.shape
    # Scaled to a unit Hessian diagonal so that cvxopt's absolute tolerances bite.
    scale = np.diag(system.gram).max()
    P = np.kron(np.eye(T), system.gram / scale)
    q = -system.rhs.ravel() / scale
    diff = np.kron(np.eye(T - 1, T, 1) - np.eye(T - 1, T), np.eye(K))
    G = np.vstack([diff, -diff]) if delta is not None else None
    h = np.full(2 * (T - 1) * K, delta) if delta is not None else None
    lb = np.zeros(T * K) if bounds else None
    ub = np.ones(T * K) if bounds else None
    if solver == "cvxopt":
        options = dict(abstol=1e-9, reltol=1e-9, feastol=1e-9)
    else:
        options = dict(tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    x = qpsolvers.solve_qp(P, q, G, h, lb=lb, ub=ub, solver=solver, **options)
    assert x is not None
    return x.reshape(T, K)


def test_active_constraints_match_dense_cvxopt(active_problem):
    neutral, deltas, frames = active_problem
    result = fit_sequence(neutral, deltas, frames, rate_bound=0.1)
    system = normal_equations(neutral, deltas, frames)
    reference = _dense_reference(system)
    coeffs = result.coeffs
    # The test is about active constraints: make sure all three kinds are.
    assert result.activity["lower"].mean() > 0.05
    assert result.activity["upper"].mean() > 0.05
    assert result.activity["rate"].mean() > 0.05
    assert np.abs(coeffs - reference).max() < 1e-4
    f_ours, f_ref = system.objective(coeffs), system.objective(reference)
    assert abs(f_ours - f_ref) <= 1e-6 * abs(f_ref)
    assert f_ours <= f_ref * (1 + 1e-9)  # never worse than the reference
    # Feasible.
    assert coeffs.min() >= 0.0 and coeffs.max() <= 1.0
    assert np.abs(np.diff(coeffs, axis=0)).max() <= 0.1 + 1e-9
    assert result.converged and result.solver == "banded-ipm+polish"


def test_kkt_certificate(active_problem):
    neutral, deltas, frames = active_problem
    system = normal_equations(neutral, deltas, frames)
    sol = solve_banded_qp(system.gram, system.rhs, rate_bound=0.1)
    u = sol.coeffs
    # Stationarity of 1/2 u^T G u - c.u with multipliers of the three constraint kinds.
    grad = u @ system.gram - system.rhs
    rate_term = np.zeros_like(u)
    rate_term[1:] += sol.rate_multipliers
    rate_term[:-1] -= sol.rate_multipliers
    residual = grad - sol.lower_multipliers + sol.upper_multipliers + rate_term
    assert np.abs(residual).max() < 1e-9 * np.abs(system.rhs).max()
    assert sol.lower_multipliers.min() >= -1e-12 and sol.upper_multipliers.min() >= -1e-12
    # Complementarity: multipliers vanish off their bounds.
    assert np.all(sol.lower_multipliers[u > 1e-6] == 0)
    assert np.all(sol.upper_multipliers[u < 1 - 1e-6] == 0)
    inactive_rate = np.abs(np.diff(u, axis=0)) < 0.1 - 1e-6
    assert np.all(sol.rate_multipliers[inactive_rate] == 0)


@pytest.mark.parametrize("solver", ["piqp", "clarabel", "osqp", "cvxopt"])
def test_general_solvers_agree(active_problem, solver):
    neutral, deltas, frames = active_problem
    ours = fit_coefficients(neutral, deltas, frames)
    theirs = fit_coefficients(neutral, deltas, frames, solver=solver)
    assert np.abs(ours - theirs).max() < 1e-4


def test_bounds_only_is_per_frame(active_problem):
    neutral, deltas, frames = active_problem
    coeffs = fit_coefficients(neutral, deltas, frames, rate=False)
    system = normal_equations(neutral, deltas, frames)
    # cvxopt stops 2e-4 short of the optimum on this one (its objective is
    # higher than ours); Clarabel reaches it.
    reference = _dense_reference(system, delta=None, solver="clarabel")
    assert np.abs(coeffs - reference).max() < 1e-4
    # Separable: fitting one frame alone gives the same row.
    alone = fit_coefficients(neutral, deltas, frames[7:8], rate=False)
    np.testing.assert_allclose(alone[0], coeffs[7], atol=1e-8)


def test_unconstrained_is_least_squares(active_problem):
    neutral, deltas, frames = active_problem
    coeffs = fit_coefficients(neutral, deltas, frames, bounds=False, rate=False)
    basis = deltas.reshape(deltas.shape[0], -1).T
    offsets = (frames - neutral).reshape(frames.shape[0], -1).T
    expected = np.linalg.lstsq(basis, offsets, rcond=None)[0].T
    np.testing.assert_allclose(coeffs, expected, atol=1e-9)
    system = normal_equations(neutral, deltas, frames)
    np.testing.assert_allclose(least_squares_coefficients(system.gram, system.rhs), expected, atol=1e-9)
    assert coeffs.min() < 0 and coeffs.max() > 1  # the problem really needs the constraints


def test_rate_only_matches_reference(active_problem):
    neutral, deltas, frames = active_problem
    coeffs = fit_coefficients(neutral, deltas, frames, bounds=False)
    reference = _dense_reference(normal_equations(neutral, deltas, frames), bounds=False)
    assert np.abs(coeffs - reference).max() < 1e-4


def test_warm_start_gives_same_optimum(active_problem):
    neutral, deltas, frames = active_problem
    cold = fit_coefficients(neutral, deltas, frames)
    warm = fit_coefficients(neutral, deltas, frames, warm_start=np.clip(cold + 0.05, 0, 1))
    assert np.abs(cold - warm).max() < 1e-7


def test_unit_scale_invariance(active_problem):
    # Millimetres instead of metres: same coefficients (the solver scales internally).
    neutral, deltas, frames = active_problem
    a = fit_coefficients(neutral, deltas, frames)
    b = fit_coefficients(neutral * 1000, deltas * 1000, frames * 1000)
    assert np.abs(a - b).max() < 1e-7


def test_single_frame_and_sparse_interface(rng):
    neutral, deltas = make_rig(rng, 50, 3)
    frames = drive(neutral, deltas, np.array([[0.2, 1.4, -0.3]]))
    coeffs = fit_coefficients(neutral, deltas, frames)
    np.testing.assert_allclose(coeffs, [[0.2, 1.0, 0.0]], atol=0.2)
    system = normal_equations(neutral, deltas, frames)
    np.testing.assert_allclose(solve_sparse_qp(system.gram, system.rhs), coeffs, atol=1e-6)


def test_fit_sequence_diagnostics(rng):
    neutral, deltas = make_rig(rng, 100, 4)
    truth = smooth_track(rng, 20, 4)
    frames = drive(neutral, deltas, truth)
    frames[5, 0] += [0.003, 0.0, 0.004]  # one vertex off by 5 mm in one frame
    result = fit_sequence(neutral, deltas, frames)
    assert result.max_error[5] == pytest.approx(0.005, rel=0.05)
    assert result.max_error[0] < 1e-7
    assert result.rmse.shape == (20,)
    assert result.objective == pytest.approx(0.005**2, rel=0.1)


def test_bad_arguments_raise(rng):
    neutral, deltas = make_rig(rng, 20, 2)
    frames = neutral[None]
    with pytest.raises(ValueError, match="solver"):
        fit_coefficients(neutral, deltas, frames, solver="magic")
    with pytest.raises(ValueError, match="rate_bound"):
        fit_coefficients(neutral, deltas, frames, rate_bound=-1.0)
    with pytest.raises(TypeError, match="rate_bound"):
        fit_coefficients(neutral, deltas, frames, rate_bound="0.1")
    with pytest.raises(ValueError, match="framewise"):
        fit_coefficients(neutral, deltas, frames, framewise=True, bounds=False)


def test_old_keyword_spellings_warn_with_their_end_date_and_give_the_same_fit(rng):
    from blendvoca.fit import SOLVERS, framewise_coefficients, solve_sparse_qp

    neutral, deltas = make_rig(rng, 40, 3)
    frames = drive(neutral, deltas, smooth_track(rng, 30, 3))
    new = fit_sequence(neutral, deltas, frames, rate_bound=0.05, solver="banded")
    with pytest.warns(DeprecationWarning, match=r"fit_sequence\(delta=\) is now fit_sequence\(rate_bound=\); "
                                                r"delta= is removed after 2027-06-30"):
        old = fit_sequence(neutral, deltas, frames, delta=0.05)
    np.testing.assert_array_equal(old.coeffs, new.coeffs)
    with pytest.warns(DeprecationWarning, match=r"method= is removed after 2027-06-30"):
        np.testing.assert_array_equal(fit_coefficients(neutral, deltas, frames, rate_bound=0.05, method="banded"),
                                      new.coeffs)
    with pytest.raises(TypeError, match="got both rate_bound= and its old spelling delta="):
        fit_coefficients(neutral, deltas, frames, rate_bound=0.05, delta=0.05)
    system = normal_equations(neutral, deltas, frames)
    with pytest.warns(DeprecationWarning, match="framewise_coefficients"):
        np.testing.assert_array_equal(framewise_coefficients(system.gram, system.rhs, delta=0.05),
                                      framewise_coefficients(system.gram, system.rhs, rate_bound=0.05))
    with pytest.warns(DeprecationWarning, match="solve_banded_qp"):
        np.testing.assert_array_equal(solve_banded_qp(system.gram, system.rhs, delta=0.05).coeffs, new.coeffs)
    assert solve_sparse_qp.__name__ == "solve_sparse_qp"
    with pytest.warns(DeprecationWarning, match="METHODS is now blendvoca.fit.SOLVERS"):
        from blendvoca.fit import METHODS
    assert METHODS == SOLVERS
