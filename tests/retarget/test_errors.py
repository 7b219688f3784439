"""Bad input raises ValueError / TypeError that names what was expected and what arrived."""

import numpy as np
import pytest
import trimesh

from blendvoca.retarget import (
    reattached_deltas,
    retarget_rig,
    similarity_transform,
    transfer_system,
    transferred_deltas,
    triangle_correspondence,
)
from blendvoca.rig import Rig


@pytest.fixture(scope="module")
def small():
    m = trimesh.creation.icosphere(subdivisions=2)
    V, F = np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)
    deltas = np.stack([0.05 * np.sin(3 * V), 0.05 * np.cos(2 * V)])
    rig = Rig(V, deltas, ("jawOpen", "mouthClose"), F)
    landmarks = np.arange(0, 68 * 2, 2)
    return rig, V, F, landmarks


def test_retarget_rig_rejects_bad_input(small):
    rig, V, F, lm = small
    with pytest.raises(TypeError, match="Rig"):
        retarget_rig((V, F), V, F, lm, lm)
    with pytest.raises(ValueError, match="no shapes"):
        retarget_rig(rig, V, F, lm, lm, shapes=["jawLeft"])
    with pytest.raises(ValueError, match="68 source landmarks but 67"):
        retarget_rig(rig, V, F, lm, lm[:-1], shapes=["jawOpen"])
    with pytest.raises(ValueError, match="outside the crop"):
        retarget_rig(rig, V, F, lm, lm, shapes=["jawOpen"], crop=np.arange(1, len(V)))
    with pytest.raises(ValueError, match=r"target_vertices of shape \(V, 3\)"):
        retarget_rig(rig, V[:, :2], F, lm, lm, shapes=["jawOpen"])
    with pytest.raises(TypeError, match="integer target_faces"):
        retarget_rig(rig, V, F.astype(float), lm, lm, shapes=["jawOpen"])
    with pytest.raises(ValueError, match="target_landmarks range"):
        retarget_rig(rig, V, F, lm, lm + len(V), shapes=["jawOpen"])


def test_retarget_rig_onto_itself_small(small):
    rig, V, F, lm = small
    out = retarget_rig(rig, V * 2.0, F, lm, lm, shapes=["jawOpen", "mouthClose"])
    assert out.names == ("jawOpen", "mouthClose")
    rel = np.linalg.norm(out.deltas - 2.0 * rig.deltas, axis=2).max() / np.linalg.norm(2 * rig.deltas, axis=2).max()
    assert rel < 1e-6


def test_step_functions_reject_bad_input(small):
    _rig, V, F, _lm = small
    with pytest.raises(ValueError, match="source_points"):
        similarity_transform(np.zeros((4, 2)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"pairs of shape \(P, 2\)"):
        transfer_system(V, F, np.zeros((3, 3), dtype=int), len(F))
    with pytest.raises(ValueError, match="pairs index source faces"):
        transfer_system(V, F, np.array([[len(F), 0]]), len(F))
    system = transfer_system(V, F, np.stack([np.arange(len(F))] * 2, axis=1), len(F))
    with pytest.raises(ValueError, match="source gradients of shape"):
        transferred_deltas(system, np.zeros((1, len(F) + 1, 3, 3)))
    with pytest.raises(ValueError, match="positive max_distance"):
        triangle_correspondence(V, F, V, F, 0.0)
    with pytest.raises(ValueError, match="non-negative finite falloff"):
        reattached_deltas(np.zeros((1, 3, 3)), np.arange(3), V, F, falloff=-1.0)
