"""Multimodality: mean feature distance between two samples for the same audio."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Hashable, Sequence

import numpy as np

PAIRS_PER_WINDOW = 36


def multimodality(a, b) -> float:
    """Mean Euclidean distance between paired latents.

    Parameters
    ----------
    a, b : (N, D) array_like
        Row i of ``a`` and of ``b`` are features of two samples generated for the
        same audio window.

    Returns
    -------
    float
        ``mean_i |a_i - b_i|``; 0.0 when there are no pairs.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape or (a.size and a.ndim != 2):
        raise ValueError(f"multimodality: expected paired features (N, D) of equal shape, got {a.shape} and {b.shape}")
    if a.shape[0] == 0:
        return 0.0
    return float(np.linalg.norm(a - b, axis=1).mean())


def paired_samples(features, groups: Sequence[Hashable], pairs_per_window: int = PAIRS_PER_WINDOW):
    """Pairs of features of different samples of the same audio window.

    Within each group (same subject, sentence and window start) the samples, in
    order, are split in halves and sample i is paired with sample i + S // 2
    (the published protocol), taking at most ``pairs_per_window`` pairs.

    Parameters
    ----------
    features : (N, D) array_like
    groups : sequence of N hashables
    pairs_per_window : int

    Returns
    -------
    a, b : (P, D) ndarrays
    """
    features = np.asarray(features, dtype=np.float64)
    if len(groups) != len(features):
        raise ValueError(f"paired_samples: {len(features)} features but {len(groups)} group labels")
    members = defaultdict(list)
    for i, g in enumerate(groups):
        members[g].append(i)
    left, right = [], []
    for idx in members.values():
        half = min(len(idx) // 2, pairs_per_window)
        left.extend(idx[:half])
        right.extend(idx[len(idx) // 2 : len(idx) // 2 + half])
    d = features.shape[1] if features.ndim == 2 else 0
    if not left:
        return np.zeros((0, d)), np.zeros((0, d))
    return features[left], features[right]
