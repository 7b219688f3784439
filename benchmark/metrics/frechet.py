"""Frechet distance between Gaussians fitted to feature sets (as in FID).

The value is the squared 2-Wasserstein distance between the two Gaussians,
``|mu1 - mu2|^2 + tr(S1 + S2 - 2 (S1^1/2 S2 S1^1/2)^1/2)``, the quantity pytorch-fid
and the published BlendVOCA evaluation report (no square root taken).
"""

from __future__ import annotations

import numpy as np
from scipy import linalg


def _as_features(x, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] < 2:
        raise ValueError(f"{name}: expected features of shape (N >= 2, D), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: features contain NaN or inf")
    return x


def feature_statistics(x) -> tuple[np.ndarray, np.ndarray]:
    """Mean and unbiased covariance of features.

    Parameters
    ----------
    x : (N, D) array_like

    Returns
    -------
    mu : (D,) ndarray
    sigma : (D, D) ndarray
        ``np.cov(x, rowvar=False)`` (divides by N - 1).
    """
    x = _as_features(x, "feature_statistics")
    return x.mean(axis=0), np.atleast_2d(np.cov(x, rowvar=False))


def _psd_sqrt(sigma: np.ndarray) -> np.ndarray:
    w, v = linalg.eigh(sigma)
    return (v * np.sqrt(np.clip(w, 0.0, None))) @ v.T


def frechet_distance_from_stats(mu1, sigma1, mu2, sigma2) -> float:
    """Frechet distance between N(mu1, sigma1) and N(mu2, sigma2).

    Parameters
    ----------
    mu1, mu2 : (D,) array_like
    sigma1, sigma2 : (D, D) array_like
        Symmetric positive semi-definite covariances.

    Returns
    -------
    float
        ``|mu1 - mu2|^2 + tr(sigma1) + tr(sigma2) - 2 tr((sigma1 sigma2)^1/2)``.

    Notes
    -----
    ``tr((sigma1 sigma2)^1/2)`` is computed as the sum of square roots of the
    eigenvalues of the symmetric ``sigma1^1/2 sigma2 sigma1^1/2`` (same spectrum as
    ``sigma1 sigma2``), which stays real and stable where a general ``sqrtm`` of the
    non-symmetric product can return complex parts. Equal covariances give the
    closed form ``|mu1 - mu2|^2`` exactly.
    """
    mu1 = np.atleast_1d(np.asarray(mu1, dtype=np.float64))
    mu2 = np.atleast_1d(np.asarray(mu2, dtype=np.float64))
    sigma1 = np.atleast_2d(np.asarray(sigma1, dtype=np.float64))
    sigma2 = np.atleast_2d(np.asarray(sigma2, dtype=np.float64))
    d = mu1.shape[0]
    if mu1.shape != (d,) or mu2.shape != (d,) or sigma1.shape != (d, d) or sigma2.shape != (d, d):
        raise ValueError(
            "frechet_distance_from_stats: expected mu (D,), sigma (D, D) on both sides, got "
            f"{mu1.shape}, {sigma1.shape}, {mu2.shape}, {sigma2.shape}"
        )
    diff = mu1 - mu2
    mean_term = float(diff @ diff)
    if np.array_equal(sigma1, sigma2):
        return mean_term
    sigma1 = 0.5 * (sigma1 + sigma1.T)
    sigma2 = 0.5 * (sigma2 + sigma2.T)
    root1 = _psd_sqrt(sigma1)
    inner = root1 @ sigma2 @ root1
    eig = linalg.eigvalsh(0.5 * (inner + inner.T))
    tr_covmean = float(np.sqrt(np.clip(eig, 0.0, None)).sum())
    return mean_term + float(np.trace(sigma1) + np.trace(sigma2)) - 2.0 * tr_covmean


def frechet_distance(x, y) -> float:
    """Frechet distance between Gaussians fitted to two feature sets.

    Parameters
    ----------
    x : (N, D) array_like
    y : (M, D) array_like

    Returns
    -------
    float
    """
    x = _as_features(x, "frechet_distance (x)")
    y = _as_features(y, "frechet_distance (y)")
    if x.shape[1] != y.shape[1]:
        raise ValueError(f"frechet_distance: feature dimensions differ: x {x.shape}, y {y.shape}")
    return frechet_distance_from_stats(*feature_statistics(x), *feature_statistics(y))
