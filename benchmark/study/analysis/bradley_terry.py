"""Bradley-Terry strengths per question, when more than two rows are compared (``choix``).

The model: row i is preferred to row j with probability ``1 / (1 + exp(-(s_i - s_j)))``;
``s`` is the log-strength, defined up to a constant, so it is reported relative to the
reference row (the reference's strength is 0; a row at +1 is preferred to it 73 % of the
time). Fitted by choix's iterative Luce spectral ranking on the matrix of wins with a small
regularisation (``ALPHA``), which keeps a row that always won or always lost finite; the
interval is the crossed bootstrap's (the same replicates as the shares), each replicate
refitted from the point estimate.
"""

from __future__ import annotations

import choix
import numpy as np

from benchmark.study.analysis.bootstrap import percentile_interval
from blendvoca.runtime.progress import bar

ALPHA = 0.01


def win_matrix(n_rows: int, winners: np.ndarray, losers: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``(len(weights), n, n)``: entry ``[b, i, j]`` the weighted count of i preferred to j in replicate b."""
    onehot = np.zeros((winners.size, n_rows * n_rows))
    onehot[np.arange(winners.size), winners * n_rows + losers] = 1.0
    return (weights @ onehot).reshape(len(weights), n_rows, n_rows)


def fit_strengths(wins: np.ndarray, initial: np.ndarray | None = None) -> np.ndarray:
    """choix's log-strengths (mean 0) from one ``(n, n)`` matrix of wins."""
    return choix.ilsr_pairwise_dense(wins, alpha=ALPHA, initial_params=initial, max_iter=200, tol=1e-7)


def strength_replicates(judgements, weights: np.ndarray, question: int, progress: bool = False):
    """``(point, replicates, rows)``: log-strengths of the rows compared in ``question`` (point
    ``(n,)``, replicates ``(B, n)``) and those rows' indices into ``judgements.rows``."""
    mask = judgements.question == question
    a, b, chose_a = judgements.row_a[mask], judgements.row_b[mask], judgements.value[mask].astype(bool)
    present = np.unique(np.concatenate([a, b]))
    local = {int(r): k for k, r in enumerate(present)}
    winners = np.array([local[int(r)] for r in np.where(chose_a, a, b)], dtype=np.int64)
    losers = np.array([local[int(r)] for r in np.where(chose_a, b, a)], dtype=np.int64)
    n = present.size
    point = fit_strengths(win_matrix(n, winners, losers, np.ones((1, winners.size)))[0])
    matrices = win_matrix(n, winners, losers, weights[:, mask])
    iterator = bar(range(len(matrices)), desc="Bradley-Terry", unit="replicate", leave=False) if progress \
        else range(len(matrices))
    replicates = np.empty((len(matrices), n))
    for k in iterator:
        replicates[k] = fit_strengths(matrices[k], point)
    return point, replicates, present


def bradley_terry(judgements, weights: np.ndarray, reference: str | None, progress: bool = True) -> dict:
    """Per question: each compared row's log-strength relative to ``reference`` (else the first
    row compared) with its 95 % interval, and the probability it is preferred to the reference."""
    out = {}
    for q, question in enumerate(judgements.questions):
        if not np.any(judgements.question == q):
            continue
        point, replicates, present = strength_replicates(judgements, weights, q, progress)
        if present.size < 3:
            continue
        names = [judgements.rows[r] for r in present]
        anchor = names.index(reference) if reference in names else 0
        relative = point - point[anchor]
        relative_replicates = replicates - replicates[:, [anchor]]
        low, high = percentile_interval(relative_replicates)
        out[question] = {
            "reference": names[anchor], "model": "Bradley-Terry (choix.ilsr_pairwise_dense, alpha=%g)" % ALPHA,
            "strengths": [{"row": name, "log_strength": float(relative[k]), "ci95": [float(low[k]), float(high[k])],
                           "p_preferred_to_reference": float(1 / (1 + np.exp(-relative[k])))}
                          for k, name in enumerate(names)],
        }
    return out
