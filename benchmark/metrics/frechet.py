"""Frechet distance between Gaussians fitted to feature sets (as in FID).

The value is the squared 2-Wasserstein distance between the two Gaussians,
``|mu1 - mu2|^2 + tr(S1 + S2 - 2 (S1^1/2 S2 S1^1/2)^1/2)``, the quantity pytorch-fid
and the published BlendVOCA evaluation report (no square root taken).

The plug-in estimate is biased upwards at finite sample size; :func:`frechet_extrapolation`
extrapolates it to infinite sample size over subsets (``FD_inf``, Chong and Forsyth,
CVPR 2020), with :class:`GroupMoments` for drawing whole groups (a sentence's windows)
in closed form.
"""

from __future__ import annotations

from dataclasses import dataclass

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


#: Fractions of the sampling units (rows, or groups such as sentences) at which
#: :func:`frechet_extrapolation` computes FD before fitting ``FD_N = FD_inf + k / N``.
#: Chong and Forsyth (CVPR 2020) use 5,000 to 50,000 of 50,000 images (0.1 to 1); a test
#: split of a few sentences has too few units for 0.1, and the fit's extrapolation to
#: ``1/N = 0`` is short enough from 0.4 (see docs/metrics.md "Sample size").
EXTRAPOLATION_FRACTIONS = (0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
#: Random subsets drawn at each fraction below 1 (their FD values are averaged).
EXTRAPOLATION_DRAWS = 20


@dataclass(frozen=True)
class FrechetExtrapolation:
    """FD at several subsample sizes and its extrapolation to infinite sample size.

    Attributes
    ----------
    value : float
        ``FD_inf``, the intercept of the least-squares line through ``(1/units, distances)``.
    slope : float
        ``k`` of ``FD_N = FD_inf + k / N``: the finite-sample bias at ``N`` units is ``k / N``.
    units : (P,) ndarray
        Sampling units (rows, or groups) drawn at each point.
    distances : (P,) ndarray
        Mean FD over the draws at each point.
    """

    value: float
    slope: float
    units: np.ndarray
    distances: np.ndarray


class GroupMoments:
    """Per-group sums of a feature set, so that the mean and covariance of any union of
    groups (the windows of some sentences) come in closed form, without the rows.

    Parameters
    ----------
    x : (N, D) array_like
    groups : (N,) array_like
        A label per row.
    """

    def __init__(self, x, groups):
        x = _as_features(x, "GroupMoments")
        groups = np.asarray(groups)
        if groups.shape != (len(x),):
            raise ValueError(f"GroupMoments: expected one label per row ({len(x)}), got shape {groups.shape}")
        self.labels, owner = np.unique(groups, return_inverse=True)
        self.counts = np.bincount(owner, minlength=len(self.labels)).astype(np.float64)
        self.sums = np.zeros((len(self.labels), x.shape[1]))
        np.add.at(self.sums, owner, x)
        self.outers = np.stack([x[owner == i].T @ x[owner == i] for i in range(len(self.labels))])
        self._index = {label: i for i, label in enumerate(self.labels.tolist())}

    def subset(self, labels) -> "GroupMoments":
        """The moments of the groups ``labels`` only (labels this set lacks are skipped)."""
        picked = [self._index[label] for label in labels if label in self._index]
        out = object.__new__(GroupMoments)
        out.labels, out.counts, out.sums, out.outers = (self.labels[picked], self.counts[picked], self.sums[picked],
                                                        self.outers[picked])
        out._index = {label: i for i, label in enumerate(out.labels.tolist())}
        return out

    def rows(self, labels) -> int:
        """Rows of the groups ``labels`` (labels this set lacks count 0)."""
        return int(sum(self.counts[self._index[label]] for label in labels if label in self._index))

    def statistics(self, labels) -> tuple[np.ndarray, np.ndarray]:
        """Mean and unbiased covariance of the rows of the groups ``labels`` (as
        :func:`feature_statistics` of those rows; at least 2 rows)."""
        picked = [self._index[label] for label in labels if label in self._index]
        total = self.counts[picked].sum()
        if total < 2:
            raise ValueError(f"GroupMoments.statistics: the groups hold {int(total)} rows, need >= 2")
        mu = self.sums[picked].sum(axis=0) / total
        sigma = (self.outers[picked].sum(axis=0) - total * np.outer(mu, mu)) / (total - 1)
        return mu, 0.5 * (sigma + sigma.T)


def frechet_extrapolation(x, y, *, groups_x=None, groups_y=None, fractions=EXTRAPOLATION_FRACTIONS,
                          draws: int = EXTRAPOLATION_DRAWS, seed: int = 0, min_rows: int = 2) -> FrechetExtrapolation:
    """FD extrapolated to infinite sample size (Chong and Forsyth, CVPR 2020, "Effectively
    Unbiased FID and Inception Score and where to find them").

    The plug-in FD of ``N`` samples is biased upwards by about ``k / N`` (the means' and
    covariances' sampling noise adds to the distance, and it only vanishes as ``N``
    grows). So FD is computed on random subsets at several sizes, averaged over
    ``draws`` subsets per size, and the line ``FD_N = FD_inf + k / N`` fitted by least
    squares in ``1 / N`` is read at ``1 / N = 0``.

    Parameters
    ----------
    x : (N, D) array_like, or a :class:`GroupMoments` (then ``groups_x`` is not given)
    y : (M, D) array_like, or a :class:`GroupMoments`
    groups_x, groups_y : (N,), (M,) array_like, optional
        A label per row (e.g. the sentence of a window). Given (or the sides given as
        :class:`GroupMoments`), the subsets are drawn as labels (a fraction of the
        distinct labels of both sides together, every row of a drawn label on either
        side kept): rows of one label are not independent (the overlapping windows of
        a sentence), labels are, and the same label on both sides keeps the two sides
        paired (the same sentences). Not given: each side's rows are drawn
        independently at the same fraction.
    fractions : sequence of float in (0, 1]
        Subset sizes as fractions of the units (rounded; sizes that round alike count once).
    draws : int
        Subsets per size below the whole set.
    seed : int
    min_rows : int
        Smallest subset on either side (FD needs 2 rows).

    Returns
    -------
    FrechetExtrapolation

    Raises
    ------
    ValueError
        Fractions outside (0, 1], draws < 1, or fewer than two distinct subset sizes with
        at least ``min_rows`` rows on each side (too few units to extrapolate).
    """
    fractions = np.asarray(fractions, dtype=np.float64)
    if fractions.ndim != 1 or not np.all((fractions > 0) & (fractions <= 1)):
        raise ValueError(f"frechet_extrapolation: fractions must be in (0, 1], got {fractions.tolist()}")
    if draws < 1:
        raise ValueError(f"frechet_extrapolation: draws must be >= 1, got {draws}")
    if (groups_x is None) != (groups_y is None):
        raise ValueError("frechet_extrapolation: give groups for both sides or for neither")
    grouped = groups_x is not None or isinstance(x, GroupMoments) or isinstance(y, GroupMoments)
    rng = np.random.default_rng(seed)
    if grouped:
        for name, side, groups in (("x", x, groups_x), ("y", y, groups_y)):
            if isinstance(side, GroupMoments) and groups is not None:
                raise ValueError(f"frechet_extrapolation: {name} is a GroupMoments: give no groups for it")
            if not isinstance(side, GroupMoments):
                side = _as_features(side, f"frechet_extrapolation ({name})")
                if groups is None:
                    raise ValueError("frechet_extrapolation: give groups for both sides or for neither")
                if np.shape(groups) != (len(side),):
                    raise ValueError(f"frechet_extrapolation: groups_{name} must give one label per row "
                                     f"({len(side)}), got shape {np.shape(groups)}")
        mx = x if isinstance(x, GroupMoments) else GroupMoments(x, groups_x)
        my = y if isinstance(y, GroupMoments) else GroupMoments(y, groups_y)
        if mx.sums.shape[1] != my.sums.shape[1]:
            raise ValueError(f"frechet_extrapolation: feature dimensions differ: x {mx.sums.shape[1]}, "
                             f"y {my.sums.shape[1]}")
        labels = np.unique(np.concatenate([mx.labels, my.labels]))
        total = len(labels)

        def distance(count):
            drawn = labels if count == total else rng.choice(labels, count, replace=False)
            if mx.rows(drawn) < min_rows or my.rows(drawn) < min_rows:
                return None
            return frechet_distance_from_stats(*mx.statistics(drawn), *my.statistics(drawn))
    else:
        x = _as_features(x, "frechet_extrapolation (x)")
        y = _as_features(y, "frechet_extrapolation (y)")
        if x.shape[1] != y.shape[1]:
            raise ValueError(f"frechet_extrapolation: feature dimensions differ: x {x.shape}, y {y.shape}")
        total = min(len(x), len(y))

        def distance(count):
            nx, ny = max(1, round(count * len(x) / total)), max(1, round(count * len(y) / total))
            if nx < min_rows or ny < min_rows:
                return None
            return frechet_distance(x[rng.choice(len(x), nx, replace=False)], y[rng.choice(len(y), ny, replace=False)])

    units, distances = [], []
    for count in sorted({int(round(f * total)) for f in fractions}):
        values = [distance(count) for _ in range(1 if count == total else draws)] if count >= 1 else [None]
        if None not in values:
            units.append(count)
            distances.append(float(np.mean(values)))
    if len(units) < 2:
        raise ValueError(f"frechet_extrapolation: {total} units give fewer than two subset sizes with >= {min_rows} "
                         f"rows a side at fractions {fractions.tolist()}: too few to extrapolate")
    units, distances = np.asarray(units, dtype=np.int64), np.asarray(distances)
    intercept, slope = np.polynomial.polynomial.polyfit(1.0 / units, distances, 1)
    return FrechetExtrapolation(float(intercept), float(slope), units, distances)


def frechet_distance_infinity(x, y, **options) -> float:
    """``FD_inf``: FD extrapolated to infinite sample size (:func:`frechet_extrapolation`,
    whose keyword options it takes)."""
    return frechet_extrapolation(x, y, **options).value
