"""Facial regions of a FLAME-topology neutral face, derived from its geometry.

The motion model needs to know which vertices follow the jaw, which belong to
the lips, the eyelids and the brows. Everything here is computed from the mesh
and the 68 iBUG landmarks (asset ``flame-landmarks``), never painted by hand:

- jaw weights are *harmonic* (Laplace equation on the surface, libigl): 1 on the
  lower half of the mouth opening's boundary loop and around the chin, 0 on its
  upper half, above the nose base, behind the jaw hinge and down the neck. The
  mouth is a hole in FLAME, so the two lips are only joined at the corners and
  the harmonic weights separate them cleanly while fading smoothly over the
  cheeks;
- lip, eyelid and brow weights are smooth bumps around their landmarks;
- the jaw hinge is placed in front of the ears (between contour landmarks 0-2
  and 14-16), slightly behind them, as the temporomandibular joint is.
"""

from __future__ import annotations

from dataclasses import dataclass

import igl
import numpy as np


@dataclass(frozen=True)
class FaceRegions:
    """Per-vertex weights ``(V,) float64`` in [0, 1] and anchor points ``(3,)``."""

    jaw: np.ndarray
    lips: np.ndarray
    upper_lid: np.ndarray
    lower_lid: np.ndarray
    brows: np.ndarray
    hinge: np.ndarray
    mouth_center: np.ndarray
    mouth_width: float
    lid_gap: float


def _main_component(faces: np.ndarray, num_vertices: int) -> np.ndarray:
    labels = igl.vertex_components(faces)
    if len(labels) < num_vertices:  # isolated vertices are their own pieces
        labels = np.concatenate([labels, np.arange(len(labels), num_vertices) + labels.max() + 1])
    return labels == np.argmax(np.bincount(labels))


def _mouth_loop(vertices: np.ndarray, faces: np.ndarray, mouth_center: np.ndarray) -> np.ndarray:
    loops = [np.asarray(loop, dtype=np.int64) for loop in igl.boundary_loop_all(faces)]
    if not loops:
        raise ValueError("face_regions: the mesh has no boundary loops; expected FLAME's open mouth")
    dist = [np.linalg.norm(vertices[loop].mean(axis=0) - mouth_center) for loop in loops]
    best = int(np.argmin(dist))
    if dist[best] > 0.03:
        raise ValueError(
            f"face_regions: no boundary loop within 3 cm of the mouth landmarks (nearest {dist[best] * 100:.1f} cm); "
            "expected a FLAME-topology head whose mouth is a hole"
        )
    return loops[best]


def jaw_weights(vertices: np.ndarray, faces: np.ndarray, landmarks: np.ndarray, hinge: np.ndarray) -> np.ndarray:
    """Harmonic jaw weights ``(V,) float64`` in [0, 1] (see module docstring).

    Parameters
    ----------
    vertices : (V, 3) ndarray
    faces : (F, 3) int64 ndarray
    landmarks : (68,) int64 ndarray
        iBUG landmark vertex indices.
    hinge : (3,) ndarray
        Jaw hinge point.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    lm = V[landmarks]
    mouth_center = lm[48:68].mean(axis=0)
    loop = _mouth_loop(V, F, mouth_center)
    corners = lm[[48, 54]]
    # Side of the corner-to-corner chord: below it is lower lip.
    t = (V[loop, 0] - corners[0, 0]) / (corners[1, 0] - corners[0, 0])
    chord_y = corners[0, 1] + t * (corners[1, 1] - corners[0, 1])
    lower = loop[V[loop, 1] < chord_y]
    upper = loop[V[loop, 1] >= chord_y]
    # Leave the two corner-most loop vertices free so the lips blend at the corners.
    corner_ids = loop[np.argsort(V[loop, 0])[[0, -1]]]
    lower = np.setdiff1d(lower, corner_ids)
    upper = np.setdiff1d(upper, corner_ids)
    # The front of the mandible moves rigidly with the jaw: below the lower lip,
    # between the mouth corners, above the neck.
    half_width = 0.5 * abs(corners[1, 0] - corners[0, 0])
    chin = np.flatnonzero(
        (np.linalg.norm(V - lm[8], axis=1) < 0.02)
        | (np.min(np.linalg.norm(V[:, None, :] - lm[None, 5:12], axis=2), axis=1) < 0.012)
        | ((V[:, 1] < lm[57, 1]) & (np.abs(V[:, 0] - mouth_center[0]) < half_width)
           & (V[:, 1] > lm[8, 1] - 0.01) & (V[:, 2] > lm[[5, 11], 2].mean()))
    )
    main = _main_component(F, len(V))
    zero = np.flatnonzero(
        (V[:, 1] > lm[33, 1])                      # above the nose base
        | (V[:, 2] < hinge[2])                     # behind the hinge
        | (V[:, 1] < lm[8, 1] - 0.04)              # down the neck
        | ~main                                    # eyeballs
    )
    zero = np.setdiff1d(np.union1d(zero, upper), np.union1d(lower, chin))
    one = np.union1d(lower, chin)
    b = np.concatenate([one, zero]).astype(np.int64)
    bc = np.concatenate([np.ones(len(one)), np.zeros(len(zero))])[:, None]
    w = igl.harmonic(V, F, b, bc, 1)
    return np.clip(np.asarray(w, dtype=np.float64).reshape(-1), 0.0, 1.0)


def face_regions(vertices: np.ndarray, faces: np.ndarray, landmarks: np.ndarray) -> FaceRegions:
    """All motion regions of one neutral face.

    Parameters
    ----------
    vertices : (V, 3) ndarray
        Neutral face (FLAME frame: y up, z forward), metres.
    faces : (F, 3) int64 ndarray
    landmarks : (68,) int64 ndarray
        iBUG-68 landmark vertex indices.

    Returns
    -------
    FaceRegions
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    lm_idx = np.asarray(landmarks, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"face_regions: vertices must be (V, 3), got shape {V.shape}")
    if lm_idx.shape != (68,) or lm_idx.min() < 0 or lm_idx.max() >= len(V):
        raise ValueError(f"face_regions: landmarks must be 68 vertex indices in [0, {len(V)}), got shape {lm_idx.shape}")
    lm = V[lm_idx]
    main = _main_component(F, len(V)).astype(np.float64)
    hinge = np.array([
        lm[27, 0],  # the midline (nose bridge)
        0.5 * (lm[[0, 16], 1].mean() + lm[[2, 14], 1].mean()),
        lm[[0, 16], 2].mean() - 0.005,
    ])
    mouth_center = lm[48:68].mean(axis=0)
    mouth_width = float(np.linalg.norm(lm[54] - lm[48]))
    # Lips: a plateau (super-Gaussian) in an ellipse spanning the mouth corners.
    rel = V - mouth_center
    d = np.sqrt((rel[:, 0] / (0.5 * mouth_width)) ** 2 + (rel[:, 1] / 0.014) ** 2 + (rel[:, 2] / 0.025) ** 2)
    lips = np.exp(-((d / 1.25) ** 4)) * main

    def bump(points: np.ndarray, sigma: float) -> np.ndarray:
        w = np.zeros(len(V))
        for p in points:
            w = np.maximum(w, np.exp(-np.sum((V - p) ** 2, axis=1) / (2 * sigma * sigma)))
        return w * main

    lid_gap = float(np.mean([lm[[37, 38], 1].mean() - lm[[40, 41], 1].mean(),
                             lm[[43, 44], 1].mean() - lm[[46, 47], 1].mean()]))
    return FaceRegions(jaw=jaw_weights(V, F, lm_idx, hinge), lips=lips,
                       upper_lid=bump(np.stack([lm[[37, 38]].mean(0), lm[[43, 44]].mean(0)]), 0.006),
                       lower_lid=bump(np.stack([lm[[40, 41]].mean(0), lm[[46, 47]].mean(0)]), 0.005),
                       brows=bump(lm[17:27], 0.012), hinge=hinge, mouth_center=mouth_center,
                       mouth_width=mouth_width, lid_gap=lid_gap)
