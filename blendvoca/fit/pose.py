"""Head-pose removal: rigidly align posed mesh frames to the neutral before fitting.

A blendshape rig has no head rotation, so a sequence that carries one (method
outputs, VOCASET's registered data, captures) must be unposed first or the fit
explains the rotation with mouth shapes. Each frame is aligned by a rigid
transform (rotation + translation, no scale) estimated on *stable* vertices,
those that do not move with speech, by iteratively re-weighted least squares
(weighted Kabsch/Procrustes with Cauchy weights), so vertices that do move (jaw,
lips, lids, brows) lose their influence.

Convention: ``frames[t] ~= neutral_deformed @ rotations[t].T + translations[t]``
(row vectors), i.e. the pose maps the unposed head to the posed one;
``aligned[t] = (frames[t] - translations[t]) @ rotations[t]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blendvoca.assets import load_index_list
from blendvoca.errors import UserError

from ._checks import as_float_array, region_indices

#: Vertex count of the FLAME topology (and its eyeballs: vertices 3931-5022).
FLAME_NUM_VERTICES = 5023
_FLAME_EYEBALLS = slice(3931, 5023)


@dataclass(frozen=True)
class HeadPose:
    """Frames with the head pose removed, and the pose that was removed.

    Attributes
    ----------
    frames : (T, V, 3) ndarray
        Frames rigidly aligned to the neutral.
    rotations : (T, 3, 3) ndarray
        Per-frame rotation of the posed head (``posed = R x + t``).
    translations : (T, 3) ndarray
        Per-frame translation (mesh units).
    stable : (S,) ndarray of int
        Vertices the alignment was estimated on.
    weights : (T, S) ndarray
        Final robust weight of each stable vertex in each frame (1: fully trusted).
    """

    frames: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray
    stable: np.ndarray
    weights: np.ndarray

    @property
    def angles_deg(self) -> np.ndarray:
        """(T,) rotation angle of each frame in degrees."""
        trace = np.trace(self.rotations, axis1=1, axis2=2)
        return np.degrees(np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0)))

    @property
    def translations_mm(self) -> np.ndarray:
        """(T,) translation length of each frame in millimetres (vertices in metres)."""
        return 1000.0 * np.linalg.norm(self.translations, axis=1)

    def summary(self) -> dict:
        """The removed pose in words: mean and max rotation (degrees) and translation (mm)."""
        angles, mm = self.angles_deg, self.translations_mm
        return {"rotation_deg_mean": float(angles.mean()), "rotation_deg_max": float(angles.max()),
                "translation_mm_mean": float(mm.mean()), "translation_mm_max": float(mm.max()),
                "stable_vertices": int(len(self.stable))}


def flame_stable_vertices(neutral, landmarks=None) -> np.ndarray:
    """FLAME's stable region: the skull above the nose base, away from the face.

    Vertices of the head (eyeballs excluded) above the nose base (landmark 33)
    and more than 3.5 cm from every brow, eye, nose and mouth landmark (17-67):
    scalp, upper forehead, temples, ears and the back of the head, which move
    rigidly with the skull.

    Parameters
    ----------
    neutral : (5023, 3) array_like
        A FLAME-topology neutral (metres, y up).
    landmarks : (68,) array_like of int, optional
        iBUG-68 landmark vertices; default the asset ``flame-landmarks``.

    Returns
    -------
    (S,) int64 ndarray
    """
    V = as_float_array(neutral, "neutral", 2, "flame_stable_vertices")
    if V.shape != (FLAME_NUM_VERTICES, 3):
        raise UserError(f"flame_stable_vertices: expected a FLAME neutral ({FLAME_NUM_VERTICES}, 3), got {V.shape}")
    if landmarks is None:
        landmarks = load_index_list("flame-landmarks")
    lm = V[np.asarray(landmarks, dtype=np.int64)]
    face = lm[17:68]
    dist = np.min(np.linalg.norm(V[:, None, :] - face[None], axis=2), axis=1)
    keep = (V[:, 1] > lm[33, 1]) & (dist > 0.035)
    keep[_FLAME_EYEBALLS] = False
    return np.flatnonzero(keep)


def _weighted_kabsch(src: np.ndarray, dst: np.ndarray, w: np.ndarray):
    """Per-frame rigid fit ``dst ~ src R^T + t``: src (S, 3), dst (T, S, 3), w (T, S)."""
    # Batched matrix products on (T, 3, S) operands: a three-operand einsum is a naive
    # loop. The weighted cross-covariance sum_s wn (x_s - cs)(y_s - cd)^T equals
    # sum_s wn x_s y_s^T - cs cd^T (the weights sum to 1), so nothing is centred.
    wsum = w.sum(axis=1, keepdims=True)
    wn = w / wsum
    cs = wn @ src                                   # (T, 3)
    cd = np.matmul(wn[:, None, :], dst)[:, 0]       # (T, 3)
    h = np.matmul(wn[:, None, :] * src.T[None], dst) - cs[:, :, None] * cd[:, None, :]  # (T, 3, 3)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.einsum("tij,tjk->tik", u, vt)))
    fix = np.ones((len(h), 3))
    fix[:, 2] = d
    rot = np.einsum("tji,tj,tkj->tik", vt, fix, u)  # V diag(1,1,d) U^T
    trans = cd - np.einsum("tij,tj->ti", rot, cs)
    return rot, trans


def _robust_fit(src, dst, iterations: int, tol: float):
    """IRLS rigid fit; returns rotations, translations, weights."""
    w = np.ones(dst.shape[:2])
    rot, trans = _weighted_kabsch(src, dst, w)
    for _ in range(iterations):
        diff = dst - (np.matmul(src[None], rot.transpose(0, 2, 1)) + trans[:, None])
        res = np.sqrt(np.einsum("tsi,tsi->ts", diff, diff))
        scale = 1.4826 * np.median(res, axis=1, keepdims=True)
        scale = np.maximum(2.5 * scale, tol)
        w = 1.0 / (1.0 + (res / scale) ** 2)
        new_rot, new_trans = _weighted_kabsch(src, dst, w)
        change = np.abs(new_rot - rot).max() + np.abs(new_trans - trans).max()
        rot, trans = new_rot, new_trans
        if change < 1e-12:
            break
    return rot, trans, w


def least_moving_vertices(frames, neutral, fraction: float = 0.3) -> np.ndarray:
    """The ``fraction`` of vertices that move least once the rigid motion is removed.

    A robust rigid fit on all vertices, then each vertex's RMS residual over
    time; the smallest ones are the stable set (an automatic choice for
    topologies without a known stable region).

    Returns
    -------
    (S,) int64 ndarray, sorted
    """
    frames = np.asarray(frames, dtype=np.float64)
    neutral = np.asarray(neutral, dtype=np.float64)
    rot, trans, _ = _robust_fit(neutral, frames, 10, 1e-9)
    aligned = np.matmul(frames - trans[:, None], rot)
    motion = np.sqrt(np.mean(np.sum((aligned - neutral) ** 2, axis=2), axis=0))
    count = max(3, int(round(fraction * len(neutral))))
    return np.sort(np.argsort(motion, kind="stable")[:count])


def remove_head_pose(frames, neutral, *, stable=None, iterations: int = 20, tol: float = 1e-6) -> HeadPose:
    """Rigidly align every frame to the neutral on stable vertices.

    Parameters
    ----------
    frames : (T, V, 3) array_like
        Posed mesh sequence (same topology as ``neutral``).
    neutral : (V, 3) array_like
        The unposed neutral the frames are aligned to.
    stable : (S,) array_like of int, optional
        Vertices to estimate the pose on (at least 3, not collinear). Default:
        FLAME's stable region (:func:`flame_stable_vertices`) for 5023-vertex
        FLAME meshes, otherwise the 30 % least-moving vertices
        (:func:`least_moving_vertices`).
    iterations : int
        Re-weighting iterations of the robust (Cauchy) Procrustes fit.
    tol : float
        Smallest residual scale of the robust weights (mesh units; 1 micrometre
        for metres), so that exactly rigid frames keep uniform weights.

    Returns
    -------
    HeadPose
        ``.frames`` (T, V, 3) aligned, ``.rotations`` (T, 3, 3), ``.translations`` (T, 3).
    """
    where = "remove_head_pose"
    frames = as_float_array(frames, "frames", 3, where)
    neutral = as_float_array(neutral, "neutral", 2, where)
    if neutral.shape[1] != 3 or frames.shape[1:] != neutral.shape or len(frames) == 0:
        raise UserError(f"{where}: expected frames (T>0, V, 3) and neutral (V, 3) of one topology, "
                         f"got {frames.shape} and {neutral.shape}")
    if stable is None:
        if len(neutral) == FLAME_NUM_VERTICES:
            stable = flame_stable_vertices(neutral)
        else:
            stable = least_moving_vertices(frames, neutral)
    stable = region_indices(stable, len(neutral), "stable", where)
    src = neutral[stable]
    if np.linalg.matrix_rank(src - src.mean(axis=0), tol=1e-9) < 2:
        raise UserError(f"{where}: the {len(stable)} stable vertices are collinear; a rotation is not determined")
    rot, trans, w = _robust_fit(src, frames[:, stable], int(iterations), float(tol))
    aligned = np.matmul(frames - trans[:, None], rot)
    return HeadPose(frames=aligned, rotations=rot, translations=trans, stable=stable, weights=w)
