"""Mean opinion score (1-5) per row and question, with the crossed bootstrap's 95 % interval."""

from __future__ import annotations

import numpy as np

from benchmark.study.analysis.bootstrap import percentile_interval


def mos_scores(judgements, weights: np.ndarray) -> list[dict]:
    """One record per row and question: ``mean`` with ``ci95`` and the counts."""
    out = []
    keys = np.unique(np.stack([judgements.row_a, judgements.question], axis=1), axis=0)
    for row, q in keys:
        mask = (judgements.row_a == row) & (judgements.question == q)
        w = weights[:, mask]
        total = w.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            replicates = np.where(total > 0, (w @ judgements.value[mask]) / np.where(total > 0, total, 1), np.nan)
        low, high = percentile_interval(replicates)
        out.append({"row": judgements.rows[row], "question": judgements.questions[q],
                    "mean": float(judgements.value[mask].mean()), "ci95": [float(low), float(high)],
                    "ratings": int(mask.sum()), "participants": int(np.unique(judgements.participant[mask]).size),
                    "items": int(np.unique(judgements.item[mask]).size)})
    return out
