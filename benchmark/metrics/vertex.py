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


def vertices_at(array, idx, axis: int) -> np.ndarray:
    """``array`` at the vertices ``idx`` of its axis ``axis`` (e.g. ``x[:, idx]`` for axis 1).

    The same values and the same memory layout (indexed axis outermost) as that
    indexing, so reductions over the result add in the same order, but several
    times faster: np.take plus one contiguous copy instead of numpy's general
    fancy-indexing path.
    """
    taken = np.moveaxis(np.take(array, idx, axis=axis), axis, 0)
    return np.moveaxis(np.ascontiguousarray(taken), 0, axis)


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
    # (np.take: the values of pred[:, lip_idx], faster; a maximum is order-free.)
    per_frame = _sq_norm(np.take(pred, lip_idx, axis=1) - np.take(gt, lip_idx, axis=1)).max(axis=1) * MM**2
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
        pred, gt = vertices_at(pred, idx, 1), vertices_at(gt, idx, 1)
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
    # Squared displacements laid out (U, T), each vertex's frames contiguous,
    # as vertices[:, idx] would leave them: the standard deviation over time
    # then adds in that order (np.take and the transpose of the small (T, U)
    # array are several times faster than that indexing).
    sq = np.ascontiguousarray(_sq_norm(np.take(vertices, idx, axis=1) - neutral[idx]).T) * MM**2
    return float(sq.std(axis=1).mean())


def upper_face_dynamics_deviation(pred, gt, neutral, upper_idx) -> float:
    """FDD of one sequence (CodeTalker): ground-truth upper-face dynamics minus
    the prediction's (signed, mm^2); the evaluation averages it over sequences.

    Parameters
    ----------
    pred, gt : (T, V, 3) metres; neutral : (V, 3); upper_idx : (U,) int
    """
    pred, gt = _pair(pred, gt, "upper_face_dynamics_deviation")
    return motion_dynamics(gt, neutral, upper_idx) - motion_dynamics(pred, neutral, upper_idx)


def _check_samples(samples, where: str) -> np.ndarray:
    samples = np.asarray(samples, dtype=np.float64)
    if samples.ndim != 4 or samples.shape[3] != 3 or samples.shape[0] < 2 or samples.shape[1] < 1:
        raise ValueError(f"{where}: expected samples (S >= 2, T >= 1, V, 3) in metres, got {samples.shape}")
    return samples


def sequence_distance(a, b, idx=None) -> float:
    """Length-normalised distance between two mesh sequences (mm).

    ``||A - B||_F / sqrt(T N)``: the root mean square, over the T frames and the
    N vertices of ``idx``, of the per-vertex Euclidean distance. The paper's
    unnormalised norm ``||A - B||`` (Frobenius over all T x N x 3 entries) is this
    value times ``sqrt(T N)``.

    Parameters
    ----------
    a, b : (T, V, 3) array_like, metres
    idx : (N,) int array_like, optional
        Vertex subset (default all V).

    Returns
    -------
    float, mm
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.ndim != 3 or a.shape[2] != 3 or a.shape != b.shape or a.shape[0] < 1:
        raise ValueError(f"sequence_distance: expected two (T >= 1, V, 3) sequences of one shape, got {a.shape} and {b.shape}")
    return float(pairwise_distances(np.stack([a, b]), idx)[0, 1])


def pairwise_distances(samples, idx=None) -> np.ndarray:
    """Distances between every two of S samples of one sequence (mm).

    Entry ``(i, j)`` is :func:`sequence_distance` of samples i and j:
    ``||X_i - X_j||_F / sqrt(T N)`` over the vertices of ``idx``.

    Parameters
    ----------
    samples : (S, T, V, 3) array_like, metres
    idx : (N,) int array_like, optional
        Vertex subset (default all V).

    Returns
    -------
    (S, S) float64 ndarray, mm, symmetric with a zero diagonal.
    """
    samples = np.asarray(samples, dtype=np.float64)
    if samples.ndim != 4 or samples.shape[3] != 3 or samples.shape[1] < 1:
        raise ValueError(f"pairwise_distances: expected samples (S, T >= 1, V, 3) in metres, got {samples.shape}")
    if idx is not None:
        idx = np.asarray(idx, dtype=np.int64)
        if idx.ndim != 1 or idx.size == 0 or idx.min() < 0 or idx.max() >= samples.shape[2]:
            raise ValueError(f"pairwise_distances: expected a non-empty vertex index list in [0, {samples.shape[2]}), "
                             f"got {idx.size} indices" + (f" in [{idx.min()}, {idx.max()}]" if idx.size else ""))
        samples = vertices_at(samples, idx, 2)
    s, t, n, _ = samples.shape
    out = np.zeros((s, s))
    for i, j in combinations(range(s), 2):
        diff = samples[i] - samples[j]
        out[i, j] = out[j, i] = np.sqrt(np.einsum("tvc,tvc->", diff, diff) / (t * n)) * MM
    return out


def average_pairwise_distance(samples, idx=None) -> float:
    """APD of S samples of one sequence (Eq. 18 of CDFace), mm.

    ``1 / (S (S - 1)) sum_i sum_{j != i} d(X_i, X_j)`` = the mean over the
    S (S - 1) / 2 unordered pairs, with ``d`` the length-normalised distance of
    :func:`sequence_distance`. On the upper-face vertices it is UPD, on the lip
    vertices LPD (``blendvoca.rig_regions``).

    Parameters
    ----------
    samples : (S, T, V, 3) array_like, metres, S >= 2
    idx : (N,) int array_like, optional
        Vertex subset (default all V).

    Returns
    -------
    float, mm
    """
    dists = pairwise_distances(_check_samples(samples, "average_pairwise_distance"), idx)
    return float(dists[np.triu_indices(len(dists), 1)].mean())


def minimum_pairwise_distance(samples, idx=None) -> float:
    """MPD of S samples of one sequence (Eq. 19 of CDFace), mm.

    ``min_{i != j} d(X_i, X_j)``: the distance of the two most similar samples
    (lower means two samples nearly repeat each other), with ``d`` as in
    :func:`sequence_distance`. Parameters and return as in :func:`average_pairwise_distance`.
    """
    dists = pairwise_distances(_check_samples(samples, "minimum_pairwise_distance"), idx)
    return float(dists[np.triu_indices(len(dists), 1)].min())


def diversity_metrics(samples, upper_idx, lip_idx) -> dict:
    """APD, UPD, LPD and MPD of S samples of one sequence at once (mm).

    Parameters
    ----------
    samples : (S, T, V, 3) array_like, metres, S >= 2
    upper_idx, lip_idx : (N,) int array_like
        Upper-face and lip vertices.

    Returns
    -------
    dict with ``apd`` (all vertices), ``upd`` (upper face), ``lpd`` (lips) and
    ``mpd`` (minimum pairwise distance over all vertices), each a float in mm.
    """
    samples = _check_samples(samples, "diversity_metrics")
    upper = np.triu_indices(samples.shape[0], 1)
    full = pairwise_distances(samples)[upper]
    return {
        "apd": float(full.mean()),
        "upd": float(pairwise_distances(samples, upper_idx)[upper].mean()),
        "lpd": float(pairwise_distances(samples, lip_idx)[upper].mean()),
        "mpd": float(full.min()),
    }
