"""Speaker stage: the ARKit reference rig transferred onto a speaker's FLAME head."""

from __future__ import annotations

import numpy as np

from blendvoca.retarget import retarget_rig
from blendvoca.rig import Rig


def speaker_rig(
    reference: Rig,
    template: np.ndarray,
    faces: np.ndarray,
    reference_landmarks: np.ndarray,
    template_landmarks: np.ndarray,
    head_index: np.ndarray,
    correspondence=None,
) -> Rig:
    """Return the speaker's full-topology rig (neutral = the template).

    Parameters
    ----------
    reference : Rig
        ARKit reference rig with the shapes wanted, in output order.
    template : (V, 3) ndarray
        The speaker's neutral FLAME mesh (V = 5023).
    faces : (F, 3) ndarray
        FLAME triangles.
    reference_landmarks : (68,) ndarray of int
        Landmarks on the reference mesh.
    template_landmarks : (68,) ndarray of int
        The same landmarks on the full FLAME mesh.
    head_index : (4580,) ndarray of int
        FLAME vertices that take part in the transfer (the head crop).
    correspondence : blendvoca.retarget.Correspondence, optional
        Computed once on another speaker of the same topology
        (`blendvoca.retarget.correspondence_for_target`); default: computed on ``template``.

    Returns
    -------
    Rig
        ``neutral == template``, one delta per ``reference.names``.
    """
    return retarget_rig(reference, template, faces, reference_landmarks, template_landmarks, crop=head_index,
                        shapes=list(reference.names), correspondence=correspondence)


def head_faces(faces: np.ndarray, head_index: np.ndarray, num_vertices: int) -> np.ndarray:
    """Return the triangles of the head crop, re-indexed into ``head_index`` order.

    Parameters
    ----------
    faces : (F, 3) ndarray of int
    head_index : (Vc,) ndarray of int
    num_vertices : int

    Returns
    -------
    (Fc, 3) ndarray of int64
        Faces whose three vertices are all in the crop.
    """
    position = np.full(num_vertices, -1, dtype=np.int64)
    position[np.asarray(head_index)] = np.arange(len(head_index))
    mapped = position[np.asarray(faces, dtype=np.int64)]
    return mapped[np.all(mapped >= 0, axis=1)]
