import numpy as np
import pytest

from blendvoca.names import ARKIT_NAMES, BLENDVOCA_NAMES
from blendvoca.rig import Rig, load_arkit_reference


@pytest.fixture()
def rig():
    rng = np.random.default_rng(1)
    neutral = rng.normal(size=(30, 3))
    deltas = rng.normal(scale=0.01, size=(4, 30, 3))
    faces = rng.integers(0, 30, size=(40, 3))
    return Rig(neutral, deltas, ("jawOpen", "jawLeft", "jawRight", "mouthClose"), faces)


def test_compact_save_load_is_identical(tmp_path, rig):
    rig.save(tmp_path / "rig.npz")
    loaded = Rig.load(tmp_path / "rig.npz")
    assert loaded == rig
    assert loaded.names == rig.names and loaded.deltas.dtype == np.float64


def test_said_folder_round_trip(tmp_path, rig):
    rig.save_said_folder(tmp_path / "rig")
    assert sorted(p.name for p in (tmp_path / "rig").iterdir()) == sorted(
        ["Neutral.obj"] + [f"{n}.obj" for n in rig.names]
    )
    loaded = Rig.load_said_folder(tmp_path / "rig", names=rig.names)
    np.testing.assert_allclose(loaded.neutral, rig.neutral, rtol=1e-8)
    np.testing.assert_allclose(loaded.deltas, rig.deltas, atol=1e-8)
    np.testing.assert_array_equal(loaded.faces, rig.faces)
    # Without names: every ARKit name present, in ARKit order.
    assert Rig.load_said_folder(tmp_path / "rig").names == ("jawLeft", "jawOpen", "jawRight", "mouthClose")


def test_evaluate_is_linear(rig):
    u = np.array([[0.0, 0, 0, 0], [1, 0, 0, 0], [0.5, 0.25, 0, 1]])
    V = rig.evaluate(u)
    np.testing.assert_allclose(V[0], rig.neutral)
    np.testing.assert_allclose(V[1], rig.neutral + rig.deltas[0])
    np.testing.assert_allclose(V[2], rig.neutral + 0.5 * rig.deltas[0] + 0.25 * rig.deltas[1] + rig.deltas[3])
    B = rig.delta_matrix()
    np.testing.assert_allclose((B @ u[2]).reshape(-1, 3), V[2] - rig.neutral)


def test_select_and_validation(rig):
    sub = rig.select(["mouthClose", "jawOpen"])
    np.testing.assert_array_equal(sub.deltas[0], rig.deltas[3])
    with pytest.raises(ValueError, match="no shapes"):
        rig.select(["cheekPuff"])
    with pytest.raises(ValueError, match="unknown blendshape names"):
        Rig(rig.neutral, rig.deltas[:1], ("notAShape",), rig.faces)
    with pytest.raises(ValueError, match="deltas must be"):
        Rig(rig.neutral, rig.deltas[:2], ("jawOpen",), rig.faces)
    bad = rig.deltas.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        Rig(rig.neutral, bad, rig.names, rig.faces)


def test_arkit_reference_from_the_asset(assets_dir):
    speech = load_arkit_reference()
    assert speech.names == BLENDVOCA_NAMES
    assert speech.neutral.shape == (1220, 3) and speech.faces.shape == (2304, 3)
    full = load_arkit_reference("all")
    assert full.names == ARKIT_NAMES and full.deltas.shape == (51, 1220, 3)
    np.testing.assert_array_equal(full.select(BLENDVOCA_NAMES).deltas, speech.deltas)
    # jawOpen moves the chin by centimetres, in metres.
    jaw = np.linalg.norm(speech.deltas[BLENDVOCA_NAMES.index("jawOpen")], axis=1).max()
    assert 0.005 < jaw < 0.1
