"""Per comparison and question: the share of answers preferring A, its 95 % interval from the
crossed bootstrap (:mod:`~benchmark.study.analysis.bootstrap`) and a two-sided test of 50 %.

The test is the bootstrap test on the same replicates (:func:`two_sided_p`): it treats
participants and sentences as random, as the interval does, so the test and the interval
never disagree (p < 0.05 exactly when the interval excludes 50 %). A sign-flip test over
participants alone would treat the sentences as fixed and claim more than the study shows.
"""

from __future__ import annotations

import numpy as np

from benchmark.study.analysis.bootstrap import percentile_interval, two_sided_p


def comparison_groups(judgements) -> list[tuple[int, int, int]]:
    """The ``(row_a, row_b, question)`` groups present, in row then question order."""
    keys = np.stack([judgements.row_a, judgements.row_b, judgements.question], axis=1)
    return [tuple(int(v) for v in key) for key in np.unique(keys, axis=0)]


def share_replicates(judgements, weights: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The bootstrap replicates of the share choosing A among the answers in ``mask`` (NaN where none drawn)."""
    w = weights[:, mask]
    total = w.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, (w @ judgements.value[mask]) / np.where(total > 0, total, 1), np.nan)


def preference_shares(judgements, weights: np.ndarray) -> list[dict]:
    """One record per comparison and question: ``share_a`` with ``ci95``, ``p_value`` and the counts."""
    out = []
    for a, b, q in comparison_groups(judgements):
        mask = (judgements.row_a == a) & (judgements.row_b == b) & (judgements.question == q)
        replicates = share_replicates(judgements, weights, mask)
        low, high = percentile_interval(replicates)
        out.append({
            "a": judgements.rows[a], "b": judgements.rows[b], "question": judgements.questions[q],
            "share_a": float(judgements.value[mask].mean()), "ci95": [float(low), float(high)],
            "p_value": two_sided_p(replicates, 0.5), "answers": int(mask.sum()),
            "participants": int(np.unique(judgements.participant[mask]).size),
            "items": int(np.unique(judgements.item[mask]).size),
        })
    return out
