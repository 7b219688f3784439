import numpy as np
import pytest

from benchmark.metrics import lip_vertices, lower_face_vertices, nose_tip_index, upper_face_vertices
from tests.benchmark.fakes import fake_rig, flame_head


def test_regions_on_flame(assets_dir):
    neutral, faces = flame_head(assets_dir)
    rig = fake_rig(neutral, faces)
    lips = lip_vertices(rig.deltas, rig.names)
    upper = upper_face_vertices(neutral)
    lower = lower_face_vertices(neutral)
    tip = nose_tip_index(neutral)
    assert 10 < len(lips) < 1000
    # the fake rig's mouth shapes are centred 4 cm below the nose tip
    centre = neutral[lips].mean(axis=0)
    assert np.linalg.norm(centre - (neutral[tip] + [0, -0.04, -0.015])) < 0.01
    assert np.all(neutral[upper, 1] > neutral[tip, 1]) and np.all(neutral[lower, 1] <= neutral[tip, 1])
    assert not set(upper) & set(lower)
    assert set(lips) <= set(lower)
    # back of the head is in neither
    back = np.argmin(neutral[:, 2])
    assert back not in set(upper) | set(lower)


@pytest.mark.slow
def test_regions_on_a_built_rig_agree_with_flame_landmarks(built_dataset, assets_dir, monkeypatch):
    """On a real BlendVOCA rig the derived regions agree with the independent iBUG
    landmarks: the nose tip is landmark 30 and every mouth landmark (48-67) is a lip vertex."""
    from benchmark.data import open_blendvoca
    from blendvoca.assets import load_index_list

    monkeypatch.setenv("BLENDVOCA_ASSETS", str(assets_dir))
    landmarks = load_index_list("flame-landmarks")
    ds = open_blendvoca(built_dataset)
    rig = ds.rig(ds.split("test")[0])
    lips = lip_vertices(rig.deltas, rig.names)
    assert nose_tip_index(rig.neutral) == landmarks[30]
    assert np.isin(landmarks[48:68], lips).all()
    assert len(lips) < 0.15 * rig.num_vertices
    assert set(lips) <= set(lower_face_vertices(rig.neutral))


def test_mouth_shape_indices():
    from blendvoca.rig_regions import mouth_shape_indices
    from blendvoca.names import BLENDVOCA_NAMES

    idx = mouth_shape_indices(BLENDVOCA_NAMES)
    assert [BLENDVOCA_NAMES[i] for i in idx] == [n for n in BLENDVOCA_NAMES if n.startswith(("jaw", "mouth"))]
    assert len(idx) == 27 and idx.dtype == np.int64
    assert list(mouth_shape_indices(["browInnerUp", "tongueOut", "eyeBlinkLeft", "jawOpen"])) == [1, 3]
    assert mouth_shape_indices(["cheekPuff"]).size == 0
