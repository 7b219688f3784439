"""The crossed (two-way) bootstrap: participants and items resampled independently.

A replicate draws the participants with replacement (``P`` out of ``P``) and, independently,
the items (sentences, ``I`` out of ``I``); an answer enters the replicate as many times as
its participant was drawn times its item was drawn, so the answers kept are those in both
draws (Owen 2007, "the pigeonhole bootstrap"; Field and Welsh 2007). Both sources of
variation a study generalises over (other people, other sentences) are in the interval; the
price is a mildly conservative interval when one of them does not vary (the residual
variance is counted about twice), which the acceptance tests measure.
"""

from __future__ import annotations

import numpy as np


def crossed_weights(participant: np.ndarray, item: np.ndarray, n_participants: int, n_items: int,
                    replicates: int, rng: np.random.Generator) -> np.ndarray:
    """``(replicates, answers)`` weights: how many times each answer enters each replicate."""
    draws_p = rng.multinomial(n_participants, np.full(n_participants, 1.0 / n_participants), size=replicates)
    draws_i = rng.multinomial(n_items, np.full(n_items, 1.0 / n_items), size=replicates)
    return (draws_p[:, participant] * draws_i[:, item]).astype(np.float64)


def percentile_interval(replicates: np.ndarray, level: float = 0.95) -> np.ndarray:
    """The percentile interval of bootstrap ``replicates`` along axis 0 (NaN replicates, where a
    group was not drawn, left out): ``[low, high]`` per column."""
    tail = 100 * (1 - level) / 2
    return np.nanpercentile(replicates, [tail, 100 - tail], axis=0)


def two_sided_p(replicates: np.ndarray, null: float) -> float:
    """The bootstrap test of ``estimate == null``: twice the smaller share of replicates on either
    side of ``null`` (counting the estimate itself, (k + 1) / (B + 1)), at most 1. It rejects at
    5 % where the 95 % percentile interval excludes ``null``."""
    finite = replicates[np.isfinite(replicates)]
    if finite.size == 0:
        return float("nan")
    below = (np.count_nonzero(finite <= null) + 1) / (finite.size + 1)
    above = (np.count_nonzero(finite >= null) + 1) / (finite.size + 1)
    return float(min(1.0, 2 * min(below, above)))
