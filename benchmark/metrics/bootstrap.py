"""Seeded bootstrap confidence intervals over sentences.

Every benchmark metric gets a 95 % interval from resampling the scored sentences
with replacement (the sentence is the unit of the test set): for per-sentence
metrics the interval of the mean of the sentence values, for set-level metrics
(FD, WInD, multimodality) the interval of the metric recomputed on the resampled
set of generated sentences. Percentile intervals; where a set-level statistic's
resampling bias puts the point estimate outside them (FD grows when repeated
sentences shrink the set's spread) the interval is extended to contain it, so
``ci95`` always brackets ``mean``.

Rows of one split share their resamples: :func:`bootstrap_indices` depends only on
the number of sentences, the number of resamples and the seed, so two methods scored
on the same sentences with the same seed see the same resampled sentences in
replicate ``i``. That pairing is what :func:`probability_of_improvement` reads.

Rows trained with several seeds get a two-level bootstrap (seeds with replacement,
then sentences with replacement within each drawn seed):
:func:`two_level_mean_replicates` from per-sentence values, :func:`two_level_replicates`
from each seed's sentence-level replicates (set-level metrics).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "BOOTSTRAP_RESAMPLES",
    "bootstrap_indices",
    "interval",
    "mean_ci",
    "mean_replicates",
    "probability_of_improvement",
    "two_level_mean_replicates",
    "two_level_replicates",
]

#: Resamples of the per-sentence means (cheap: vectorised).
BOOTSTRAP_RESAMPLES = 1000


def bootstrap_indices(n: int, resamples: int, seed: int) -> np.ndarray:
    """``(resamples, n)`` int64 indices drawn with replacement from ``range(n)`` (``numpy`` PCG64, ``seed``)."""
    if n < 1 or resamples < 1:
        raise ValueError(f"bootstrap_indices: expected n >= 1 and resamples >= 1, got n={n}, resamples={resamples}")
    return np.random.default_rng(np.random.SeedSequence([int(seed), 0xB007])).integers(0, n, size=(resamples, n))


#: Entropy words of the streams below (beside the seed), so that none shares a stream
#: with another or with :func:`bootstrap_indices` (``[seed, 0xB007]``).
_SENTENCE_STREAM = 0xB007
_SEED_DRAWS = 0x5EED
_REPLICATE_DRAWS = 0x2E91


def interval(replicates, point: float, level: float = 0.95) -> list[float]:
    """Percentile interval of bootstrap ``replicates``, extended to contain ``point``.

    Parameters
    ----------
    replicates : array_like, shape (resamples,)
        The statistic on each resample (:func:`mean_replicates`, :func:`two_level_replicates`, ...).
    point : float
        The statistic on the data as they are; the interval always contains it (a
        set-level statistic's resampling bias can put it outside the percentiles).
    level : float
        Coverage, 0.95 for the ``ci95`` of the result files.

    Returns
    -------
    [low, high] : list of float
    """
    stats = np.asarray(replicates, dtype=np.float64)
    alpha = (1.0 - level) / 2.0
    lo, hi = np.quantile(stats, [alpha, 1.0 - alpha])
    return [float(min(lo, point)), float(max(hi, point))]


_interval = interval  # the name the functions below and older callers use


def mean_replicates(values, *, resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0) -> np.ndarray:
    """Means of ``values`` over the resampled sentences of :func:`bootstrap_indices`.

    Replicate ``i`` is the mean over row ``i`` of ``bootstrap_indices(N, resamples, seed)``,
    so two rows scored on the same ``N`` sentences with the same ``seed`` are paired
    (same resampled sentences at the same index). ``mean_ci`` is
    ``interval(mean_replicates(values, ...), values.mean())``.

    ``scipy.stats.bootstrap`` draws its own indices inside one call; the rows here must
    be a function of ``(N, resamples, seed)`` alone, shared by every method and metric
    scored at different times, so they come from :func:`bootstrap_indices` (the tests
    check the interval against ``scipy.stats.bootstrap``'s percentile interval).

    Parameters
    ----------
    values : array_like, shape (N,)
        One value per sentence, N >= 1.
    resamples : int
    seed : int

    Returns
    -------
    ndarray, shape (resamples,)
    """
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 1 or values.size < 1:
        raise ValueError(f"mean_replicates: expected a non-empty 1-d array of values, got shape {values.shape}")
    return values[bootstrap_indices(values.size, resamples, seed)].mean(axis=1)


def _position_rows(n: int, resamples: int, seed: int, position: int) -> np.ndarray:
    """Sentence rows of the ``position``-th seed drawn in each replicate: position 0 is
    :func:`bootstrap_indices` (one seed = the one-level bootstrap), the others have
    streams of their own. They depend on ``(n, resamples, seed, position)`` only, so rows
    compared with each other see the same sentences at the same position."""
    if position == 0:
        return bootstrap_indices(n, resamples, seed)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), _SENTENCE_STREAM, int(position)]))
    return rng.integers(0, n, size=(resamples, n))


def _seed_draws(n_seeds: int, resamples: int, seed: int, stream: int) -> np.ndarray:
    """``(resamples, n_seeds)`` seeds drawn with replacement (stream ``stream``)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), _SEED_DRAWS, int(stream)]))
    return rng.integers(0, n_seeds, size=(resamples, n_seeds))


def _check_resamples(resamples: int, where: str) -> None:
    if isinstance(resamples, bool) or not isinstance(resamples, (int, np.integer)) or resamples < 1:
        raise ValueError(f"{where}: expected resamples >= 1, got {resamples!r}")


# The two-level bootstrap is written by hand: scipy.stats.bootstrap resamples the
# observations of one level (several samples only paired or independently), and
# rliable's stratified bootstrap resamples runs within each task, not sentences within
# each drawn run; neither nests a resample of sentences inside a resample of seeds.


def two_level_mean_replicates(values, *, resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0,
                              stream: int = 0) -> np.ndarray:
    """Two-level bootstrap of the mean of per-sentence values over training seeds.

    Replicate ``i`` draws ``n_seeds`` seeds with replacement and, for each drawn seed,
    ``n_sentences`` sentences with replacement (a fresh draw per drawn seed), and
    averages the drawn seeds' means over their drawn sentences. With one seed it is
    :func:`mean_replicates` (same rows).

    Pairing: the sentences of the ``m``-th seed drawn in replicate ``i`` depend only on
    ``(n_sentences, resamples, seed, m)``, so two rows scored on the same sentences with
    the same ``seed`` see the same resampled sentences there; which seeds are drawn
    depends on ``stream`` as well, so give rows compared with each other different
    streams (their training seeds are unrelated) and the same ``seed``.

    Parameters
    ----------
    values : array_like, shape (n_seeds, n_sentences)
        ``values[k, j]``: seed ``k``'s value on sentence ``j`` (the same sentences for
        every seed).
    resamples : int
    seed : int
        Seed of the sentence draws (and of the seed draws, with ``stream``).
    stream : int
        Separates the seed draws of rows compared with each other.

    Returns
    -------
    ndarray, shape (resamples,)
    """
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 2 or values.shape[0] < 1 or values.shape[1] < 1:
        raise ValueError(f"two_level_mean_replicates: expected values of shape (n_seeds >= 1, n_sentences >= 1), "
                         f"got {values.shape}")
    _check_resamples(resamples, "two_level_mean_replicates")
    n_seeds, n = values.shape
    if n_seeds == 1:
        return mean_replicates(values[0], resamples=resamples, seed=seed)
    drawn = _seed_draws(n_seeds, resamples, seed, stream)
    total = np.zeros(resamples, dtype=np.float64)
    for position in range(n_seeds):
        rows = _position_rows(n, resamples, seed, position)
        total += values[drawn[:, position][:, None], rows].mean(axis=1)
    return total / n_seeds


def two_level_replicates(per_seed, *, resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0,
                         stream: int = 0) -> np.ndarray:
    """Two-level bootstrap from each training seed's sentence-level replicates.

    For statistics that are not means of per-sentence values (FD, WInD, ...), each seed
    ``k`` has its statistic on resampled sentences, ``per_seed[k]``. Replicate ``i``
    draws ``len(per_seed)`` seeds with replacement and, for each drawn seed, one of its
    replicates (a fresh uniform index for each draw, so the draws are independent), and
    averages them. With one seed it is that seed's replicates resampled. When each
    ``per_seed[k]`` is seed ``k``'s exact one-level bootstrap distribution this is the
    distribution of :func:`two_level_mean_replicates` (the tests check both against
    enumeration).

    Pairing: the ``m``-th draw of replicate ``i`` takes index ``floor(u * len(per_seed[k]))``
    of the drawn seed ``k`` with ``u`` depending only on ``(resamples, seed, m)``; rows
    whose seeds' replicates were computed on the same sentence rows
    (:func:`bootstrap_indices` with one seed) and have as many of them are thus paired in
    sentences. Which seeds are drawn depends on ``stream`` as in
    :func:`two_level_mean_replicates`.

    Parameters
    ----------
    per_seed : sequence of array_like
        Seed ``k``'s replicates, 1-d, any non-zero lengths.
    resamples : int
    seed : int
    stream : int

    Returns
    -------
    ndarray, shape (resamples,)
    """
    arrays = [np.asarray(r, dtype=np.float64) for r in per_seed]
    if not arrays or any(a.ndim != 1 or a.size < 1 for a in arrays):
        raise ValueError("two_level_replicates: expected one non-empty 1-d array of replicates per seed, got shapes "
                         f"{[a.shape for a in arrays]}")
    _check_resamples(resamples, "two_level_replicates")
    n_seeds = len(arrays)
    lengths = np.array([a.size for a in arrays])
    flat = np.concatenate(arrays)
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    drawn = _seed_draws(n_seeds, resamples, seed, stream)
    total = np.zeros(resamples, dtype=np.float64)
    for position in range(n_seeds):
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), _REPLICATE_DRAWS, position]))
        u = rng.random(resamples)
        k = drawn[:, position]
        index = np.minimum((u * lengths[k]).astype(np.int64), lengths[k] - 1)
        total += flat[starts[k] + index]
    return total / n_seeds


def probability_of_improvement(rep_a, rep_b, *, higher_is_better: bool) -> float:
    """Fraction of paired replicates in which ``a`` is better than ``b`` (ties count half).

    Parameters
    ----------
    rep_a, rep_b : array_like, shape (resamples,)
        Replicates of two rows on the same resamples (replicate ``i`` of both on the same
        resampled sentences: same sentences, ``resamples`` and seed).
    higher_is_better : bool

    Returns
    -------
    float
        In [0, 1]; ``probability_of_improvement(b, a)`` is one minus it.
    """
    if not isinstance(higher_is_better, (bool, np.bool_)):
        raise ValueError(f"probability_of_improvement: higher_is_better must be True or False, "
                         f"got {higher_is_better!r}")
    a = np.asarray(rep_a, dtype=np.float64)
    b = np.asarray(rep_b, dtype=np.float64)
    if a.ndim != 1 or a.shape != b.shape or a.size < 1:
        raise ValueError(f"probability_of_improvement: expected two paired 1-d arrays of one length, got shapes "
                         f"{a.shape} and {b.shape}")
    diff = a - b if higher_is_better else b - a
    return float((np.count_nonzero(diff > 0) + 0.5 * np.count_nonzero(diff == 0)) / a.size)


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
    idx = bootstrap_indices(values.size, resamples, seed)  # = interval(mean_replicates(values, ...), point)
    return _interval(values[idx].mean(axis=1), point, level)
