import numpy as np
import pytest
from scipy import linalg

from benchmark.metrics import feature_statistics, frechet_distance, frechet_distance_from_stats


def scipy_reference(mu1, s1, mu2, s2):
    covmean = linalg.sqrtm(s1 @ s2)
    covmean = covmean.real
    d = mu1 - mu2
    return d @ d + np.trace(s1) + np.trace(s2) - 2 * np.trace(covmean)


@pytest.mark.parametrize("dim", [1, 5, 64])
def test_matches_scipy_sqrtm_reference(dim):
    rng = np.random.default_rng(dim)
    x = rng.normal(size=(500, dim)) @ rng.normal(size=(dim, dim))
    y = rng.normal(size=(400, dim)) @ rng.normal(size=(dim, dim)) + 0.3
    ref = scipy_reference(*feature_statistics(x), *feature_statistics(y))
    assert frechet_distance(x, y) == pytest.approx(ref, rel=1e-6)


def test_equal_covariances_give_closed_form():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(8, 8))
    sigma = a @ a.T
    mu1, mu2 = rng.normal(size=8), rng.normal(size=8)
    assert frechet_distance_from_stats(mu1, sigma, mu2, sigma) == np.sum((mu1 - mu2) ** 2)


def test_diagonal_closed_form_and_symmetry():
    s1, s2 = np.diag([1.0, 4.0, 9.0]), np.diag([4.0, 1.0, 0.25])
    mu = np.zeros(3)
    expected = sum((np.sqrt(a) - np.sqrt(b)) ** 2 for a, b in zip([1, 4, 9], [4, 1, 0.25]))
    assert frechet_distance_from_stats(mu, s1, mu, s2) == pytest.approx(expected, rel=1e-12)
    rng = np.random.default_rng(2)
    x, y = rng.normal(size=(100, 4)), rng.normal(size=(120, 4)) * 2
    assert frechet_distance(x, y) == pytest.approx(frechet_distance(y, x), rel=1e-10)
    assert frechet_distance(x, x) == pytest.approx(0.0, abs=1e-12)


def test_bad_input_raises():
    with pytest.raises(ValueError, match="feature dimensions differ"):
        frechet_distance(np.zeros((5, 3)), np.zeros((5, 4)))
    with pytest.raises(ValueError, match="N >= 2"):
        frechet_distance(np.zeros((1, 3)), np.zeros((5, 3)))
    with pytest.raises(ValueError, match="NaN"):
        frechet_distance(np.full((3, 2), np.nan), np.zeros((5, 2)))
