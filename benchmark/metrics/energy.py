"""The energy score: a proper scoring rule for samplers (Gneiting & Raftery 2007).

For S samples ``x_1..x_S`` of one item and its observed outcome ``y``::

    ES = (1/S) sum_i d(x_i, y) - 1/(2 S (S-1)) sum_{i != j} d(x_i, x_j)

with ``d`` a Euclidean distance. The second term uses the fair (unbiased) estimator
of ``E d(X, X')``, so the expected score does not depend on S and rows with different
sample counts are comparable; with S = 1 only the first term remains (the distance
to the outcome). In expectation the score is lowest when the samples come from the
true conditional distribution of ``y``: a sampler that collapses to the mean loses
the second term, one that adds noise pays more in the first than it gains in the
second.

The benchmark scores per frame (vertex spaces: ``d`` = the RMS vertex distance in mm)
and per 120-frame window (the VAE latents), averaging over the frames or windows of
a sentence (:mod:`benchmark.evaluation`).
"""

from __future__ import annotations

import numpy as np

from benchmark.metrics.vertex import MM

__all__ = ["BLOCK_FRAMES", "energy_scores", "vertex_energy_score"]

#: Frames per block of :func:`vertex_energy_score` (S x 16 x 3V floats: a few MB at S = 10).
BLOCK_FRAMES = 16


def energy_scores(samples, truth) -> np.ndarray:
    """Energy score of each of M items with Euclidean ``d``.

    Parameters
    ----------
    samples : (S, M, D) array_like
        S >= 1 samples of each of the M items.
    truth : (M, D) array_like
        The observed outcome of each item.

    Returns
    -------
    (M,) float64 ndarray
    """
    samples = np.asarray(samples, dtype=np.float64)
    truth = np.asarray(truth, dtype=np.float64)
    if samples.ndim != 3 or samples.shape[0] < 1 or truth.shape != samples.shape[1:]:
        raise ValueError(f"energy_scores: expected samples (S >= 1, M, D) and truth (M, D), got {samples.shape} "
                         f"and {truth.shape}")
    s = samples.shape[0]
    to_truth = np.sqrt(np.einsum("smd,smd->sm", samples - truth, samples - truth)).mean(axis=0)
    if s == 1:
        return to_truth
    # Pair distances from the Gram matrix of the samples centred per item: centring
    # keeps the subtraction ``|a|^2 + |b|^2 - 2 a.b`` at the scale of the distances
    # themselves (no cancellation of large positions), and the Gram product is one
    # batched matrix product instead of S^2 / 2 differences of (M, D) arrays.
    centred = np.ascontiguousarray((samples - samples.mean(axis=0)).transpose(1, 0, 2))  # (M, S, D)
    gram = centred @ centred.transpose(0, 2, 1)  # (M, S, S)
    norms = np.einsum("mii->mi", gram)
    squared = np.maximum(norms[:, :, None] + norms[:, None, :] - 2.0 * gram, 0.0)
    idx = np.arange(s)
    squared[:, idx, idx] = 0.0
    between = np.sqrt(squared).sum(axis=(1, 2)) / (2.0 * s * (s - 1))
    return to_truth - between


def vertex_energy_score(samples, truth) -> float:
    """Energy score of one mesh sequence, per frame with ``d`` the RMS vertex distance
    (mm), averaged over frames.

    Parameters
    ----------
    samples : (S, T, V, 3) array_like, metres
    truth : (T', V, 3) array_like, metres
        Both are cut to the shorter length.

    Returns
    -------
    float, mm
    """
    samples = np.asarray(samples, dtype=np.float64)
    truth = np.asarray(truth, dtype=np.float64)
    if samples.ndim != 4 or samples.shape[3] != 3 or truth.ndim != 3 or truth.shape[1:] != samples.shape[2:]:
        raise ValueError(f"vertex_energy_score: expected samples (S, T, V, 3) and truth (T, V, 3) with equal V, "
                         f"got {samples.shape} and {truth.shape}")
    t = min(samples.shape[1], truth.shape[0])
    if t == 0:
        raise ValueError("vertex_energy_score: empty sequence")
    v = samples.shape[2]
    # RMS over the V vertices = Euclidean distance of the flattened frame / sqrt(V). The frames'
    # scores are independent: computed BLOCK_FRAMES at a time, the temporaries of the pairwise
    # distances (several copies of S x frames x 3V positions, hundreds of MB for ten samples of
    # a sentence) stay small, which is most of the time; the mean over all frames is the same.
    per_frame = np.concatenate([
        energy_scores(samples[:, i:min(i + BLOCK_FRAMES, t)].reshape(samples.shape[0], -1, 3 * v),
                      truth[i:min(i + BLOCK_FRAMES, t)].reshape(-1, 3 * v))
        for i in range(0, t, BLOCK_FRAMES)])
    return float(per_frame.mean() * MM / np.sqrt(v))
