"""Closure-aware masking (CDFace Eq. 6).

``m_t = 1`` when the distance ``D_t`` between an upper-lip and a lower-lip vertex of
the ground-truth frame exceeds ``epsilon`` (the lips are open: diversity allowed),
``0`` otherwise (the lips are closed, as on /p/, /b/, /m/ and in silence: every sample
must follow the ground truth). On FLAME meshes the pair is the inner-lip midpoints,
landmarks 62 and 66 of the 68-point scheme (asset ``flame-landmarks``), the same pair
the BlendVOCA build reports its lip aperture with.
"""

from __future__ import annotations

import numpy as np

from blendvoca.assets import load_index_list
from blendvoca.errors import UserError

__all__ = ["FLAME_NUM_VERTICES", "LIP_PAIR_LANDMARKS", "closure_mask", "flame_lip_pair", "lip_distance", "lip_pair_for"]

#: Vertex count of the FLAME topology (VOCASET, BlendVOCA).
FLAME_NUM_VERTICES = 5023

#: Inner upper-lip and lower-lip midpoints in the 68-point landmark scheme.
LIP_PAIR_LANDMARKS = (62, 66)


def flame_lip_pair() -> tuple[int, int]:
    """FLAME vertex indices of the inner-lip midpoints (from the ``flame-landmarks`` asset)."""
    landmarks = load_index_list("flame-landmarks")
    return int(landmarks[LIP_PAIR_LANDMARKS[0]]), int(landmarks[LIP_PAIR_LANDMARKS[1]])


def lip_pair_for(template, lip_vertices) -> tuple[int, int]:
    """The upper/lower lip vertex pair of a topology.

    FLAME (5023 vertices): :func:`flame_lip_pair`. Any other mesh: among the lip
    vertices near the mid-sagittal plane (within a tenth of the lips' width of
    their median x), the highest and the lowest (+y up).

    Parameters
    ----------
    template : (V, 3) array_like
    lip_vertices : (L,) int array_like

    Returns
    -------
    (int, int)
    """
    template = np.asarray(template, dtype=np.float64)
    if template.shape[0] == FLAME_NUM_VERTICES:
        return flame_lip_pair()
    lips = np.asarray(lip_vertices, dtype=np.int64)
    if lips.size < 2:
        raise ValueError(f"lip_pair_for: expected at least 2 lip vertices, got {lips.size}")
    x = template[lips, 0]
    near = lips[np.abs(x - np.median(x)) <= 0.1 * max(np.ptp(x), 1e-12)]
    if near.size < 2:
        near = lips
    y = template[near, 1]
    return int(near[np.argmax(y)]), int(near[np.argmin(y)])


def lip_distance(vertices, pair) -> np.ndarray:
    """Per-frame distance ``D_t`` between the two lip vertices of ``pair``.

    Parameters
    ----------
    vertices : (T, V, 3) array_like
    pair : (int, int)
        Upper-lip and lower-lip vertex indices.

    Returns
    -------
    (T,) float64 ndarray, in the vertices' unit.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    if vertices.ndim != 3 or vertices.shape[2] != 3:
        raise ValueError(f"lip_distance: expected vertices (T, V, 3), got {vertices.shape}")
    upper, lower = (int(i) for i in pair)
    if not (0 <= upper < vertices.shape[1] and 0 <= lower < vertices.shape[1]):
        raise ValueError(f"lip_distance: lip pair {pair} outside the {vertices.shape[1]} vertices")
    return np.linalg.norm(vertices[:, upper] - vertices[:, lower], axis=1)


def closure_mask(vertices, pair, epsilon: float) -> np.ndarray:
    """Eq. 6: ``m_t = 1 if D_t > epsilon else 0``.

    Parameters
    ----------
    vertices : (T, V, 3) array_like
        Ground-truth meshes (metres).
    pair : (int, int)
        Upper-lip and lower-lip vertex indices.
    epsilon : float
        Threshold in the vertices' unit (the paper: 0.005 m on VOCASET, 0.01 on BIWI).

    Returns
    -------
    (T,) float32 ndarray of 0 and 1.
    """
    if not np.isfinite(epsilon) or epsilon < 0:
        raise UserError(f"closure_mask: expected epsilon >= 0, got {epsilon}")
    return (lip_distance(vertices, pair) > float(epsilon)).astype(np.float32)
