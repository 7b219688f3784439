"""Seeded bootstrap confidence intervals over sentences.

Every benchmark metric gets a 95 % interval from resampling the scored sentences
with replacement (the sentence is the unit of the test set): for per-sentence
metrics the interval of the mean of the sentence values, for set-level metrics
(FD, WInD, multimodality) the interval of the metric recomputed on the resampled
set of generated sentences. Percentile intervals; where a set-level statistic's
resampling bias puts the point estimate outside them (FD grows when repeated
sentences shrink the set's spread) the interval is extended to contain it, so
``ci95`` always brackets ``mean``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BOOTSTRAP_RESAMPLES", "bootstrap_indices", "mean_ci", "statistic_ci", "statistics_ci"]

#: Resamples of the per-sentence means (cheap: vectorised).
BOOTSTRAP_RESAMPLES = 1000


def bootstrap_indices(n: int, resamples: int, seed: int) -> np.ndarray:
    """``(resamples, n)`` int64 indices drawn with replacement from ``range(n)`` (``numpy`` PCG64, ``seed``)."""
    if n < 1 or resamples < 1:
        raise ValueError(f"bootstrap_indices: expected n >= 1 and resamples >= 1, got n={n}, resamples={resamples}")
    return np.random.default_rng(np.random.SeedSequence([int(seed), 0xB007])).integers(0, n, size=(resamples, n))


def _interval(stats, point: float, level: float) -> list[float]:
    stats = np.asarray(stats, dtype=np.float64)
    alpha = (1.0 - level) / 2.0
    lo, hi = np.quantile(stats, [alpha, 1.0 - alpha])
    return [float(min(lo, point)), float(max(hi, point))]


def mean_ci(values, *, resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0, level: float = 0.95) -> list[float]:
    """Percentile bootstrap interval of the mean of ``values`` (N,) (``[v, v]`` for one value).

    Returns
    -------
    [low, high] : list of float
        Contains ``values.mean()``.
    """
    values = np.asarray(values, dtype=np.float64)
    point = float(values.mean())
    if values.size < 2:
        return [point, point]
    idx = bootstrap_indices(values.size, resamples, seed)
    return _interval(values[idx].mean(axis=1), point, level)


def statistic_ci(statistic, n: int, point: float, *, resamples: int, seed: int = 0, level: float = 0.95,
                 progress=None) -> list[float]:
    """Percentile bootstrap interval of ``statistic(indices)`` over resampled sentence indices.

    Parameters
    ----------
    statistic : callable ((n,) int ndarray) -> float
        The metric recomputed on the sentences ``indices`` (with repeats).
    n : int
        Number of sentences.
    point : float
        The metric on the full set (always inside the interval).
    resamples : int
    progress : callable, optional
        Wraps the resample iterator (e.g. ``tqdm``).

    Returns
    -------
    [low, high] : list of float
    """
    if n < 2:
        return [float(point), float(point)]
    rows = bootstrap_indices(n, resamples, seed)
    iterator = progress(rows) if progress is not None else rows
    return _interval([statistic(row) for row in iterator], float(point), level)


def statistics_ci(statistics, n: int, point: float, *, resamples: int, seed: int = 0,
                  level: float = 0.95) -> list[float]:
    """`statistic_ci` with all resamples handed over at once (e.g. to compute them in parallel).

    Parameters
    ----------
    statistics : callable ((resamples, n) int ndarray) -> (resamples,) floats
        The metric recomputed on every row of sentence indices, in row order.
    n, point, resamples, seed, level
        As in `statistic_ci` (same rows for the same ``seed``, so the same interval).

    Returns
    -------
    [low, high] : list of float
    """
    if n < 2:
        return [float(point), float(point)]
    rows = bootstrap_indices(n, resamples, seed)
    values = list(statistics(rows))
    if len(values) != len(rows):
        raise ValueError(f"statistics_ci: expected {len(rows)} values, one per resample, got {len(values)}")
    return _interval(values, float(point), level)
