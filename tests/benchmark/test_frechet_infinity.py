"""FD extrapolated to infinite sample size recovers the closed-form Frechet distance of
two known Gaussians, where the plug-in FD of the same samples is biased upwards."""

from __future__ import annotations

import numpy as np
import pytest

from benchmark.metrics.frechet import (
    GroupMoments,
    feature_statistics,
    frechet_distance,
    frechet_distance_from_stats,
    frechet_distance_infinity,
    frechet_extrapolation,
)

D, N, REPLICATIONS = 16, 100, 40


def _gaussians(seed=0):
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(D, D)) / np.sqrt(D), rng.normal(size=(D, D)) / np.sqrt(D)
    return np.zeros(D), a @ a.T + 0.1 * np.eye(D), np.full(D, 0.1), b @ b.T + 0.1 * np.eye(D)


def test_fd_inf_recovers_the_closed_form_where_plain_fd_is_biased():
    mu1, sigma1, mu2, sigma2 = _gaussians()
    truth = frechet_distance_from_stats(mu1, sigma1, mu2, sigma2)
    rng = np.random.default_rng(1)
    plain, extrapolated = [], []
    for r in range(REPLICATIONS):
        x, y = rng.multivariate_normal(mu1, sigma1, N), rng.multivariate_normal(mu2, sigma2, N)
        plain.append(frechet_distance(x, y))
        extrapolated.append(frechet_distance_infinity(x, y, seed=r))
    se_plain = np.std(plain, ddof=1) / np.sqrt(REPLICATIONS)
    se_inf = np.std(extrapolated, ddof=1) / np.sqrt(REPLICATIONS)
    bias_plain, bias_inf = np.mean(plain) - truth, np.mean(extrapolated) - truth
    # plain FD at N = 100 is biased upwards, far beyond its standard error
    assert bias_plain > 8 * se_plain and bias_plain > 0.1 * truth
    # FD_inf is not: within 3 standard errors of the truth, and its bias a fraction of plain FD's
    assert abs(bias_inf) < 3 * se_inf
    assert abs(bias_inf) < 0.25 * bias_plain


def test_the_fitted_slope_is_the_plain_fd_bias():
    """The line's slope k predicts plain FD's excess at N: FD_N - FD_inf = k / N > 0."""
    mu1, sigma1, mu2, sigma2 = _gaussians()
    rng = np.random.default_rng(2)
    x, y = rng.multivariate_normal(mu1, sigma1, N), rng.multivariate_normal(mu2, sigma2, N)
    fit = frechet_extrapolation(x, y, seed=0)
    assert fit.slope > 0
    assert fit.units[-1] == N and fit.distances[-1] == pytest.approx(frechet_distance(x, y))
    assert fit.value + fit.slope / N == pytest.approx(frechet_distance(x, y), abs=0.1 * fit.slope / N + 0.05)


def test_grouped_draws_keep_the_sides_paired_and_recover_the_truth():
    """Rows labelled by group (a sentence's windows): whole groups are drawn, on both sides."""
    mu1, sigma1, mu2, sigma2 = _gaussians()
    truth = frechet_distance_from_stats(mu1, sigma1, mu2, sigma2)
    rng = np.random.default_rng(3)
    groups = np.repeat(np.arange(N // 2), 2)
    values = []
    for r in range(REPLICATIONS):
        x, y = rng.multivariate_normal(mu1, sigma1, N), rng.multivariate_normal(mu2, sigma2, N)
        fit = frechet_extrapolation(x, y, groups_x=groups, groups_y=groups, seed=r)
        assert set(fit.units) <= set(range(2, N // 2 + 1)) and fit.units[-1] == N // 2
        values.append(fit.value)
    assert abs(np.mean(values) - truth) < 3 * np.std(values, ddof=1) / np.sqrt(REPLICATIONS)


@pytest.mark.parametrize("options, message", [
    ({"fractions": (0.0, 1.0)}, "fractions must be in (0, 1]"),
    ({"fractions": (0.5, 1.5)}, "fractions must be in (0, 1]"),
    ({"draws": 0}, "draws must be >= 1"),
    ({"fractions": (1.0,)}, "too few to extrapolate"),
    ({"groups_x": np.zeros(10)}, "for both sides or for neither"),
    ({"groups_x": np.zeros(3), "groups_y": np.zeros(10)}, "one label per row"),
])
def test_bad_options_are_refused(options, message):
    x = np.random.default_rng(0).normal(size=(10, 2))
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")
                       .replace("]", r"\]")):
        frechet_extrapolation(x, x + 1, **options)


def test_group_moments_give_the_statistics_of_the_groups_rows():
    rng = np.random.default_rng(4)
    x, groups = rng.normal(size=(60, 5)), rng.integers(0, 6, 60)
    moments = GroupMoments(x, groups)
    picked = [1, 3, 4]
    mu, sigma = feature_statistics(x[np.isin(groups, picked)])
    got_mu, got_sigma = moments.statistics(picked)
    np.testing.assert_allclose(got_mu, mu, atol=1e-12)
    np.testing.assert_allclose(got_sigma, sigma, atol=1e-12)
    sub = moments.subset(picked)
    assert sub.rows(sub.labels) == moments.rows(picked) == int(np.isin(groups, picked).sum())
    np.testing.assert_allclose(sub.statistics(sub.labels)[1], sigma, atol=1e-12)
