"""The two facial parts of CDFace: lips (everything below the upper face) and upper face.

The paper splits the face in two ("dual-partitioned") and gives each part its own
VQ prior. Here the upper part is the front of the face above the nose tip
(:func:`blendvoca.rig_regions.upper_face_vertices` of the mean training
template, minus any lip vertex), and the lip part is every other vertex (mouth,
jaw, chin, cheeks below the nose, and the rest of the head), so every lip vertex
of the metrics lies in the lip part: with the lip codes fixed, the lip vertices
of all samples are equal.

Optionally only the vertices that move in the training data are modelled
(``active``); the others keep the template position in every output (on
FLAME heads about 1900 of 5023 vertices move at all during speech).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blendvoca.rig_regions import upper_face_vertices

__all__ = ["FaceParts", "face_parts"]


@dataclass(frozen=True)
class FaceParts:
    """Vertex indices of the two modelled parts (sorted, disjoint); the other
    vertices of the ``num_vertices`` keep the template position.

    Attributes
    ----------
    lips : (V_l,) int64 ndarray
    upper : (V_u,) int64 ndarray
    num_vertices : int
    """

    lips: np.ndarray
    upper: np.ndarray
    num_vertices: int

    def __post_init__(self):
        lips = np.asarray(self.lips, dtype=np.int64)
        upper = np.asarray(self.upper, dtype=np.int64)
        both = np.concatenate([lips, upper])
        if (len(lips) == 0 or len(upper) == 0 or len(np.unique(both)) != len(both) or both.min() < 0
                or both.max() >= self.num_vertices):
            raise ValueError(f"FaceParts: expected two non-empty disjoint index sets within {self.num_vertices} "
                             f"vertices, got {len(lips)} + {len(upper)} indices ({len(np.unique(both))} distinct)")
        object.__setattr__(self, "lips", np.sort(lips))
        object.__setattr__(self, "upper", np.sort(upper))

    def split(self, displacement):
        """``(..., V, 3)`` -> lip ``(..., 3 V_l)`` and upper ``(..., 3 V_u)`` flattened parts."""
        displacement = np.asarray(displacement)
        lead = displacement.shape[:-2]
        return (displacement[..., self.lips, :].reshape(*lead, -1),
                displacement[..., self.upper, :].reshape(*lead, -1))

    def compose(self, lips, upper) -> np.ndarray:
        """Inverse of :meth:`split`: full ``(..., V, 3)`` from the flattened parts."""
        lips = np.asarray(lips)
        upper = np.asarray(upper)
        lead = lips.shape[:-1]
        out = np.zeros((*lead, self.num_vertices, 3), dtype=np.result_type(lips, upper))
        out[..., self.lips, :] = lips.reshape(*lead, -1, 3)
        out[..., self.upper, :] = upper.reshape(*lead, -1, 3)
        return out


def face_parts(template, lip_vertices=None, active=None) -> FaceParts:
    """Partition a face topology into the lip and upper-face parts.

    Parameters
    ----------
    template : (V, 3) array_like
        A neutral mesh of the topology (e.g. the mean training template).
    lip_vertices : (L,) int array_like, optional
        Lip vertices that must fall in the lip part (e.g. the union of every
        rig's :func:`blendvoca.rig_regions.lip_vertices`).
    active : (V,) bool array_like, optional
        Vertices to model (default all).

    Returns
    -------
    FaceParts
    """
    template = np.asarray(template, dtype=np.float64)
    upper = upper_face_vertices(template)
    if lip_vertices is not None:
        upper = np.setdiff1d(upper, np.asarray(lip_vertices, dtype=np.int64))
    lips = np.setdiff1d(np.arange(template.shape[0]), upper)
    if active is not None:
        active = np.asarray(active, dtype=bool)
        if active.shape != (template.shape[0],):
            raise ValueError(f"face_parts: expected an active mask ({template.shape[0]},), got {active.shape}")
        lips, upper = lips[active[lips]], upper[active[upper]]
    return FaceParts(lips=lips, upper=upper, num_vertices=template.shape[0])
