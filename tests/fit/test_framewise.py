import numpy as np

from blendvoca.fit import fit_coefficients

from .conftest import drive, make_rig, smooth_track


def test_framewise_recovers_feasible_track(rng):
    neutral, deltas = make_rig(rng, 150, 6)
    truth = smooth_track(rng, 30, 6)
    coeffs = fit_coefficients(neutral, deltas, drive(neutral, deltas, truth), framewise=True)
    assert np.abs(coeffs - truth).max() < 1e-6


def test_framewise_respects_rate_and_is_causal(active_problem):
    neutral, deltas, frames = active_problem
    coeffs = fit_coefficients(neutral, deltas, frames, framewise=True)
    assert coeffs.min() >= 0 and coeffs.max() <= 1
    assert np.abs(np.diff(coeffs, axis=0)).max() <= 0.1 + 1e-9
    # Causal: a prefix does not depend on later frames.
    prefix = fit_coefficients(neutral, deltas, frames[:20], framewise=True)
    np.testing.assert_allclose(prefix, coeffs[:20], atol=1e-9)
    # Chunked streaming with the previous frame as warm start gives the same track.
    rest = fit_coefficients(neutral, deltas, frames[20:], framewise=True, warm_start=coeffs[19])
    np.testing.assert_allclose(rest, coeffs[20:], atol=1e-7)


def test_framewise_without_rate_is_bounds_only(active_problem):
    neutral, deltas, frames = active_problem
    a = fit_coefficients(neutral, deltas, frames, framewise=True, rate=False)
    b = fit_coefficients(neutral, deltas, frames, rate=False)
    np.testing.assert_allclose(a, b, atol=1e-8)
