"""Face regions of a rig, derived openly from the rig itself.

* lip vertices: the vertices that the lip blendshapes move most. Each vertex gets
  the score ``sum_k |delta_k(v)|`` over the lip shapes (mouth shapes that move the
  lips themselves: funnel, pucker, roll, press, close, shrug, lower-down, upper-up);
  a vertex is a lip vertex when its score is at least ``fraction`` (0.3) of the
  largest score. The set follows the mouth of every speaker rig without a
  hand-made FLAME mask.
* upper face: vertices above the nose tip (the neutral's most forward vertex
  unless the caller gives a nose-tip index, e.g. iBUG landmark 30) and in front
  of the head's mid-depth (the back of the head does not move with speech).
* lower face: the same front vertices at or below the nose tip.

The rig's up axis is +y and it faces +z (FLAME, ARKit and BlendVOCA rigs).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Name prefixes of the shapes that move the mouth and jaw (ARKit's jaw, mouth and tongue
#: groups): what speech drives.
MOUTH_PREFIXES = ("jaw", "mouth", "tongue")

LIP_SHAPES = (
    "mouthFunnel", "mouthPucker", "mouthRollLower", "mouthRollUpper", "mouthPressLeft",
    "mouthPressRight", "mouthClose", "mouthShrugLower", "mouthShrugUpper",
    "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight",
)


def _neutral(neutral) -> np.ndarray:
    neutral = np.asarray(neutral, dtype=np.float64)
    if neutral.ndim != 2 or neutral.shape[1] != 3:
        raise ValueError(f"expected neutral vertices (V, 3), got {neutral.shape}")
    return neutral


def lip_vertices(deltas, names: Sequence[str], shapes: Sequence[str] = LIP_SHAPES, fraction: float = 0.3) -> np.ndarray:
    """Indices of the lip vertices of a rig.

    Parameters
    ----------
    deltas : (K, V, 3) array_like
        Blendshape offsets from the neutral.
    names : sequence of K str
    shapes : sequence of str
        Lip shapes to score with (those absent from ``names`` are ignored).
    fraction : float
        Threshold relative to the highest score.

    Returns
    -------
    (L,) int64 ndarray, sorted.
    """
    deltas = np.asarray(deltas, dtype=np.float64)
    if deltas.ndim != 3 or deltas.shape[2] != 3 or len(names) != deltas.shape[0]:
        raise ValueError(f"lip_vertices: expected deltas (K, V, 3) with K={len(names)} names, got {deltas.shape}")
    chosen = [i for i, n in enumerate(names) if n in set(shapes)]
    if not chosen:
        raise ValueError(f"lip_vertices: none of the lip shapes {tuple(shapes)} is in the rig names {tuple(names)}")
    score = np.linalg.norm(deltas[chosen], axis=2).sum(axis=0)
    top = score.max()
    if top <= 0:
        raise ValueError("lip_vertices: the lip shapes move no vertex")
    return np.flatnonzero(score >= fraction * top).astype(np.int64)


def mouth_shape_indices(names: Sequence[str], prefixes: Sequence[str] = MOUTH_PREFIXES) -> np.ndarray:
    """Indices of the jaw, mouth and tongue shapes among ``names`` ((M,) int64, sorted)."""
    return np.array([i for i, n in enumerate(names) if str(n).startswith(tuple(prefixes))], dtype=np.int64)


def nose_tip_index(neutral) -> int:
    """Index of the most forward (+z) vertex of a neutral face (the nose tip)."""
    neutral = _neutral(neutral)
    return int(np.argmax(neutral[:, 2]))


def _front(neutral) -> np.ndarray:
    z = neutral[:, 2]
    return z >= 0.5 * (z.min() + z.max())


def upper_face_vertices(neutral, nose_tip: int | None = None) -> np.ndarray:
    """Indices of front vertices above the nose tip.

    Parameters
    ----------
    neutral : (V, 3) array_like
    nose_tip : int, optional
        Vertex index of the nose tip; default :func:`nose_tip_index`.

    Returns
    -------
    (U,) int64 ndarray
    """
    neutral = _neutral(neutral)
    tip = nose_tip_index(neutral) if nose_tip is None else int(nose_tip)
    return np.flatnonzero(_front(neutral) & (neutral[:, 1] > neutral[tip, 1])).astype(np.int64)


def lower_face_vertices(neutral, nose_tip: int | None = None) -> np.ndarray:
    """Indices of front vertices at or below the nose tip, (W,) int64."""
    neutral = _neutral(neutral)
    tip = nose_tip_index(neutral) if nose_tip is None else int(nose_tip)
    return np.flatnonzero(_front(neutral) & (neutral[:, 1] <= neutral[tip, 1])).astype(np.int64)
