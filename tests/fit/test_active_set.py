"""The active-set start of the banded solver on speech-like tracks (mostly on the lower bound)."""

import numpy as np

from blendvoca.fit import fit_sequence, normal_equations, solve_banded_qp

from .conftest import drive, make_rig
from .test_fit_coefficients import _dense_reference


def _speech_like(rng, num_frames=60, num_shapes=8):
    neutral, deltas = make_rig(rng, num_vertices=200, num_shapes=num_shapes)
    t = np.arange(num_frames)[:, None]
    bursts = np.sin(2 * np.pi * rng.uniform(0.01, 0.03, num_shapes) * t + rng.uniform(0, 6, num_shapes))
    truth = np.clip(0.6 * bursts, 0.0, None)  # half of the time at 0, slow enough for the rate bound
    frames = drive(neutral, deltas, truth) + rng.normal(size=(num_frames, 200, 3)) * 3e-4
    return neutral, deltas, frames


def test_active_set_start_is_the_certified_optimum(rng):
    neutral, deltas, frames = _speech_like(rng)
    result = fit_sequence(neutral, deltas, frames, rate_bound=0.1)
    assert result.solver == "banded-active-set" and result.converged
    assert result.activity["lower"].mean() > 0.2  # the lower bound really binds
    system = normal_equations(neutral, deltas, frames)
    reference = _dense_reference(system)
    assert np.abs(result.coeffs - reference).max() < 1e-4
    assert system.objective(result.coeffs) <= system.objective(reference) * (1 + 1e-9)
    # KKT certificate with the returned multipliers.
    sol = solve_banded_qp(system.gram, system.rhs, rate_bound=0.1)
    u = sol.coeffs
    rate_term = np.zeros_like(u)
    rate_term[1:] += sol.rate_multipliers
    rate_term[:-1] -= sol.rate_multipliers
    residual = u @ system.gram - system.rhs - sol.lower_multipliers + sol.upper_multipliers + rate_term
    assert np.abs(residual).max() < 1e-9 * np.abs(system.rhs).max()
    assert sol.lower_multipliers.min() >= -1e-12
    assert np.all(sol.lower_multipliers[u > 1e-6] == 0)


def test_feasible_least_squares_is_returned_as_is(rng):
    neutral, deltas = make_rig(rng, num_vertices=100, num_shapes=4)
    truth = 0.5 + 0.2 * np.sin(np.arange(30)[:, None] / 10.0 + np.arange(4))
    frames = drive(neutral, deltas, truth)
    system = normal_equations(neutral, deltas, frames)
    sol = solve_banded_qp(system.gram, system.rhs, rate_bound=0.1)
    assert sol.solver == "least-squares"
    np.testing.assert_allclose(sol.coeffs, truth, atol=1e-9)
    assert not sol.lower_multipliers.any() and not sol.rate_multipliers.any()
