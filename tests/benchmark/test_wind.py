import numpy as np
import pytest

from benchmark.metrics import (
    frechet_distance_from_stats,
    gmm_components,
    transport_cost,
    wind,
    wind_from_gmms,
    wind_scores,
)


def test_single_component_equals_frechet_distance():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(300, 4))
    y = rng.normal(size=(250, 4)) * 1.5 + 1.0
    gx, gy = gmm_components(x, 1), gmm_components(y, 1)
    expected = frechet_distance_from_stats(gx[1][0], gx[2][0], gy[1][0], gy[2][0])
    assert wind_from_gmms(gx, gy) == pytest.approx(expected, rel=1e-9)
    # and the fitted single Gaussian is the (biased) sample mean / covariance
    mean, std = wind(x, y, n_components=1, repeats=3)
    ref = frechet_distance_from_stats(x.mean(0), np.cov(x, rowvar=False, ddof=0), y.mean(0), np.cov(y, rowvar=False, ddof=0))
    assert mean == pytest.approx(ref, rel=1e-4)
    assert std == pytest.approx(0.0, abs=1e-9)


def test_symmetric():
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.normal(size=(100, 3)), rng.normal(size=(100, 3)) + 4])
    y = rng.normal(size=(200, 3)) * 2
    assert wind(x, y, 3, repeats=2, seed=5)[0] == pytest.approx(wind(y, x, 3, repeats=2, seed=5)[0], rel=1e-7)


def test_transport_lp_known_answer():
    cost = np.array([[0.0, 1.0], [1.0, 0.0]])
    assert transport_cost(cost, [0.5, 0.5], [0.5, 0.5]) == pytest.approx(0.0, abs=1e-12)
    assert transport_cost(cost, [1.0, 0.0], [0.25, 0.75]) == pytest.approx(0.75)
    # uniform weights: optimal transport is an optimal assignment (Birkhoff), an
    # independent reference through the Hungarian algorithm
    from scipy.optimize import linear_sum_assignment

    rng = np.random.default_rng(2)
    c = rng.uniform(size=(6, 6))
    rows, cols = linear_sum_assignment(c)
    u = np.full(6, 1 / 6)
    assert transport_cost(c, u, u) == pytest.approx(c[rows, cols].sum() / 6, rel=1e-9)


def test_identical_mixtures_give_zero_and_repeats_count():
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.normal(size=(150, 2)), rng.normal(size=(150, 2)) + 6])
    assert wind(x, x, 2, repeats=2)[0] == pytest.approx(0.0, abs=1e-6)
    assert len(wind_scores(x, x + 1, 2, repeats=4)) == 4


def test_bad_input():
    with pytest.raises(ValueError, match="repeats"):
        wind(np.zeros((10, 2)), np.zeros((10, 2)), repeats=0)
    with pytest.raises(ValueError, match="sum to 1"):
        transport_cost(np.zeros((2, 2)), [0.5, 0.4], [0.5, 0.5])


def test_parallel_fits_are_bit_identical_to_sequential():
    from benchmark.metrics import gmm_components_many

    rng = np.random.default_rng(5)
    x = np.concatenate([rng.normal(size=(150, 6)), rng.normal(size=(150, 6)) + 3])
    y = rng.normal(size=(200, 6)) * 1.3
    jobs = [(x, 3, s) for s in range(3)] + [(y, 2, 7)]
    sequential = [gmm_components(*job) for job in jobs]
    for got, want in zip(gmm_components_many(jobs, workers=2), sequential, strict=True):
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(wind_scores(x, y, 3, repeats=4, seed=2, workers=2),
                                  wind_scores(x, y, 3, repeats=4, seed=2, workers=1))


def _clustered(seed, n=400, dim=6):
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(5, dim)) * 3.0
    return centres[rng.integers(0, 5, n)] + rng.normal(size=(n, dim))


def test_warm_start_rejects_a_mixture_of_another_size():
    x = _clustered(0)
    fit = gmm_components(x, 3, seed=0)
    with pytest.raises(ValueError, match="init has 3 components"):
        gmm_components(x, 5, seed=0, init=fit)


def test_warm_start_error_within_a_quarter_of_the_refit_spread():
    # The documented bound (docs/metrics.md "WInD cost"): a refit warm-started from
    # a mixture already fitted to the same windows moves WInD by at most 0.25 x the
    # spread of WInD over seeded cold fits (its std over repeats).
    x, y = _clustered(1), _clustered(2) + 0.5
    spread = np.std(wind_scores(x, y, n_components=5, repeats=6, seed=0), ddof=1)
    assert spread > 0
    cold_x, cold_y = gmm_components(x, 5, seed=0), gmm_components(y, 5, seed=0)
    warm_x = gmm_components(x, 5, seed=0, init=cold_x)
    change = abs(wind_from_gmms(warm_x, cold_y) - wind_from_gmms(cold_x, cold_y))
    assert change <= 0.25 * spread


def test_a_constant_generator_is_fitted_without_warnings():
    import warnings

    from benchmark.metrics.wind import gmm_components

    x = np.tile(np.linspace(0.0, 1.0, 8), (200, 1))  # one distinct point, as a constant row's features
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        weights, means, _ = gmm_components(x, 5, seed=0)
    # all the weight on the one point; the other components are empty
    assert np.isclose(weights.max(), 1.0) and np.allclose(means[np.argmax(weights)], x[0])
