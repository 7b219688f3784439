import numpy as np
import pytest

from blendvoca.errors import DataError, UserError
from blendvoca.names import ARKIT_NAMES, BLENDVOCA_NAMES
from blendvoca.rig import Rig, load_arkit_reference, load_rig
from tests.fixtures.paths import FsPath


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


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_a_rig_takes_any_float_dtype(rig, dtype):
    small = Rig(rig.neutral.astype(dtype), rig.deltas.astype(dtype), rig.names, rig.faces.astype(np.int32))
    assert small.neutral.dtype == small.deltas.dtype == np.float64 and small.faces.dtype == np.int64
    np.testing.assert_allclose(small.neutral, rig.neutral.astype(dtype).astype(np.float64), rtol=0)
    coeffs = np.full((2, len(rig.names)), 0.5, dtype=dtype)
    np.testing.assert_allclose(small.evaluate(coeffs), small.evaluate(coeffs.astype(np.float64)), rtol=0)
    # integral float faces (as some loaders give them) are indices too
    assert Rig(rig.neutral, rig.deltas, rig.names, rig.faces.astype(np.float32)) == rig


def test_a_rig_says_what_it_needs(rig):
    with pytest.raises(UserError, match=r"neutral as a \(V, 3\) array of real numbers"):
        Rig(np.full(rig.neutral.shape, "x"), rig.deltas, rig.names, rig.faces)
    with pytest.raises(UserError, match=r"deltas as a \(K, V, 3\) array of real numbers, got complex"):
        Rig(rig.neutral, rig.deltas.astype(complex), rig.names, rig.faces)
    with pytest.raises(UserError, match=r"faces as an \(F, 3\) array of vertex indices"):
        Rig(rig.neutral, rig.deltas, rig.names, rig.faces + 0.5)
    with pytest.raises(UserError, match=r"coeffs as a \(T, 4\) array of real numbers"):
        rig.evaluate([["a"] * 4])


def test_rig_files_through_any_path(tmp_path, rig):
    for path in (str(tmp_path / "a.npz"), FsPath(tmp_path / "b.npz"), tmp_path / "c.npz"):
        rig.save(path)
        assert Rig.load(path) == rig
    for folder in (str(tmp_path / "s"), FsPath(tmp_path / "f")):
        rig.save_said_folder(folder)
        loaded = Rig.load_said_folder(folder, names=rig.names)
        assert loaded.names == rig.names
        np.testing.assert_allclose(loaded.deltas, rig.deltas, atol=1e-8)
    moved = Rig.load_said_folder(FsPath(tmp_path / "f"), names=rig.names[:1],
                                 neutral_path=FsPath(tmp_path / "s" / "Neutral.obj"))
    assert moved.names == rig.names[:1]


def test_a_file_that_is_no_rig_names_the_file(tmp_path, rig):
    (tmp_path / "text.npz").write_text("not a zip")
    with pytest.raises(DataError, match=r"text\.npz: not a \.npz archive \(it is text, beginning 'not a zip'\)"):
        Rig.load(FsPath(tmp_path / "text.npz"))
    np.save(tmp_path / "array.npy", rig.neutral)
    with pytest.raises(DataError, match=r"array\.npy: not a BlendVOCA rig file: a single array"):
        Rig.load(tmp_path / "array.npy")
    np.savez(tmp_path / "partial.npz", neutral=rig.neutral)
    with pytest.raises(DataError, match=r"partial\.npz: not a BlendVOCA rig file, missing arrays"):
        Rig.load(tmp_path / "partial.npz")
    np.savez(tmp_path / "names.npz", neutral=rig.neutral, deltas=rig.deltas, names=np.array(["a", "b", "c", "d"]),
             faces=rig.faces)
    with pytest.raises(DataError, match=r"names\.npz: Rig: unknown blendshape names"):
        Rig.load(tmp_path / "names.npz")
    with pytest.raises(FileNotFoundError, match="rig file not found"):
        Rig.load(FsPath(tmp_path / "none.npz"))


@pytest.mark.parametrize("content, begins", [
    (b"neutral,deltas\n0.1,0.2\n", "it is text, beginning 'neutral,deltas"),
    (b"", "the file is empty"),
    (b"\x80\x04\x95\x10\x00", "it begins with the bytes"),
])
def test_a_file_that_is_no_archive_is_called_so_not_a_pickle(tmp_path, content, begins):
    """numpy takes any bytes that are no archive for a pickle; the error says what the file is instead."""
    path = tmp_path / "rig.npz"
    path.write_bytes(content)
    with pytest.raises(DataError) as caught:
        Rig.load(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: not a .npz archive") and begins in message, message
    assert "pickle" not in message, message


def test_load_rig_reads_either_file_kind(tmp_path, rig):
    rig.save(tmp_path / "rig.npz")
    rig.save_said_folder(tmp_path / "said")
    assert load_rig(tmp_path / "rig.npz") == rig
    from_folder = load_rig(str(tmp_path / "said")).select(rig.names)  # a folder loads in ARKit order
    np.testing.assert_allclose(from_folder.deltas, rig.deltas, atol=1e-8)
    np.testing.assert_array_equal(from_folder.faces, rig.faces)
    from blendvoca.export import load_rig as export_load_rig

    assert export_load_rig is load_rig
