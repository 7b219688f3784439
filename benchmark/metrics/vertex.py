"""Vertex-space metrics of mesh sequences (through a speaker's rig).

All inputs are in metres, all outputs in millimetres (or mm^2 where squared).
Per-sequence functions return one number; the evaluation averages over sequences.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

MM = 1000.0


def _pair(pred, gt, where: str):
    pred = np.asarray(pred, dtype=np.float64)
    gt = np.asarray(gt, dtype=np.float64)
    if pred.ndim != 3 or pred.shape[2] != 3 or gt.ndim != 3 or gt.shape[1:] != pred.shape[1:]:
        raise ValueError(f"{where}: expected pred and gt (T, V, 3) with equal V, got {pred.shape} and {gt.shape}")
    t = min(len(pred), len(gt))
    if t == 0:
        raise ValueError(f"{where}: empty sequence")
    return pred[:t], gt[:t]


def _sq_norm(diff: np.ndarray) -> np.ndarray:
    """Squared L2 norm over the last axis without temporaries of the full size."""
    return np.einsum("...c,...c->...", diff, diff)


def rig_vertices(neutral, deltas, coeffs) -> np.ndarray:
    """Vertices of a linear blendshape rig driven by coefficients.

    Parameters
    ----------
    neutral : (V, 3), deltas : (K, V, 3), coeffs : (T, K)

    Returns
    -------
    (T, V, 3) ndarray ``neutral + sum_k coeffs[:, k] deltas[k]``.
    """
    neutral = np.asarray(neutral, dtype=np.float64)
    deltas = np.asarray(deltas, dtype=np.float64)
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.ndim != 2 or deltas.ndim != 3 or coeffs.shape[1] != deltas.shape[0] or deltas.shape[1:] != neutral.shape:
        raise ValueError(
            f"rig_vertices: expected neutral (V, 3), deltas (K, V, 3), coeffs (T, K); got "
            f"{neutral.shape}, {deltas.shape}, {coeffs.shape}"
        )
    k, v, _ = deltas.shape
    return neutral[None] + (coeffs @ deltas.reshape(k, 3 * v)).reshape(-1, v, 3)


def lip_vertex_error(pred, gt, lip_idx, squared: bool = False) -> float:
    """Lip vertex error (LVE) of one sequence.

    For each frame the largest distance over the lip vertices, averaged over
    frames (FaceFormer / CodeTalker). Those papers take the squared L2 distance
    (``squared=True``, mm^2); the default is the plain L2 distance in mm.

    Parameters
    ----------
    pred, gt : (T, V, 3) array_like, metres
        Sequences are truncated to the shorter length.
    lip_idx : (L,) int array_like
    squared : bool

    Returns
    -------
    float, mm (or mm^2 when ``squared``)
    """
    pred, gt = _pair(pred, gt, "lip_vertex_error")
    lip_idx = np.asarray(lip_idx, dtype=np.int64)
    per_frame = _sq_norm(pred[:, lip_idx] - gt[:, lip_idx]).max(axis=1) * MM**2
    return float(per_frame.mean() if squared else np.sqrt(per_frame).mean())


def mean_vertex_error(pred, gt, idx=None) -> float:
    """Mean L2 vertex distance over frames and vertices (mm).

    Parameters
    ----------
    pred, gt : (T, V, 3) array_like, metres
    idx : (N,) int array_like, optional
        Vertex subset (default all).
    """
    pred, gt = _pair(pred, gt, "mean_vertex_error")
    if idx is not None:
        idx = np.asarray(idx, dtype=np.int64)
        pred, gt = pred[:, idx], gt[:, idx]
    return float(np.sqrt(_sq_norm(pred - gt)).mean() * MM)


def motion_dynamics(vertices, neutral, idx) -> float:
    """Upper-face dynamics of one sequence (CodeTalker): for each vertex of ``idx``
    the temporal standard deviation of its squared displacement from the neutral,
    averaged over the vertices. mm^2.

    Parameters
    ----------
    vertices : (T, V, 3), neutral : (V, 3), idx : (U,) int
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    neutral = np.asarray(neutral, dtype=np.float64)
    idx = np.asarray(idx, dtype=np.int64)
    return float((_sq_norm(vertices[:, idx] - neutral[idx]) * MM**2).std(axis=0).mean())


def upper_face_dynamics_deviation(pred, gt, neutral, upper_idx) -> float:
    """FDD of one sequence (CodeTalker): ground-truth upper-face dynamics minus
    the prediction's (signed, mm^2); the evaluation averages it over sequences.

    Parameters
    ----------
    pred, gt : (T, V, 3) metres; neutral : (V, 3); upper_idx : (U,) int
    """
    pred, gt = _pair(pred, gt, "upper_face_dynamics_deviation")
    return motion_dynamics(gt, neutral, upper_idx) - motion_dynamics(pred, neutral, upper_idx)


def pairwise_distance_by_region(samples, regions: dict) -> dict:
    """Average pairwise distance of S samples over several vertex subsets at once.

    Parameters
    ----------
    samples : (S, T, V, 3) array_like, metres, S >= 2
    regions : dict name -> (N,) int indices, or None for all vertices

    Returns
    -------
    dict name -> float (mm), each as :func:`average_pairwise_distance`.
    """
    samples = np.asarray(samples, dtype=np.float64)
    if samples.ndim != 4 or samples.shape[3] != 3 or samples.shape[0] < 2:
        raise ValueError(f"pairwise_distance_by_region: expected samples (S >= 2, T, V, 3), got {samples.shape}")
    sums = {name: 0.0 for name in regions}
    pairs = list(combinations(range(samples.shape[0]), 2))
    for i, j in pairs:
        per_vertex = np.sqrt(_sq_norm(samples[i] - samples[j])).mean(axis=0) * MM  # (V,)
        for name, idx in regions.items():
            sums[name] += float(per_vertex.mean() if idx is None else per_vertex[np.asarray(idx, dtype=np.int64)].mean())
    return {name: total / len(pairs) for name, total in sums.items()}


def average_pairwise_distance(samples, idx=None) -> float:
    """Diversity of S samples of one sequence (mm).

    Mean over unordered sample pairs of the mean (over frames and vertices of
    ``idx``) L2 distance between the two samples. With ``idx`` = all vertices this
    is APD; upper-face, lower-face and lip vertices give UPD, LPD and MPD.

    Parameters
    ----------
    samples : (S, T, V, 3) array_like, metres, S >= 2
    idx : (N,) int array_like, optional

    Returns
    -------
    float, mm
    """
    samples = np.asarray(samples, dtype=np.float64)
    if samples.ndim != 4 or samples.shape[3] != 3 or samples.shape[0] < 2:
        raise ValueError(f"average_pairwise_distance: expected samples (S >= 2, T, V, 3), got {samples.shape}")
    if idx is not None:
        samples = samples[:, :, np.asarray(idx, dtype=np.int64)]
    dists = [np.sqrt(_sq_norm(samples[i] - samples[j])).mean() * MM
             for i, j in combinations(range(samples.shape[0]), 2)]
    return float(np.mean(dists))
