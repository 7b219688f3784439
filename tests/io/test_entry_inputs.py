"""The readers and writers take ``str`` or any ``os.PathLike`` path and arrays of any
real dtype, and say what they need when they cannot convert."""

import numpy as np
import pytest

from blendvoca.errors import DataError, UserError
from blendvoca.io.audio import load_audio, read_wav, write_wav
from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
from blendvoca.io.mesh import (
    read_index_list,
    read_mesh,
    read_obj,
    read_ply,
    read_ply_sequence,
    read_ply_vertices,
    write_mesh,
    write_obj,
    write_ply,
)
from tests.fixtures.paths import FsPath


def _paths(tmp_path, name):
    return [str(tmp_path / f"str-{name}"), FsPath(tmp_path / f"fs-{name}"), tmp_path / f"path-{name}"]


TRIANGLE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.5, 0.25]])
FACES = np.array([[0, 1, 2]])


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64, np.int64])
@pytest.mark.parametrize("suffix", [".obj", ".ply"])
def test_meshes_round_trip_through_any_path_and_float_dtype(tmp_path, suffix, dtype):
    vertices = TRIANGLE.astype(dtype)
    for path in _paths(tmp_path, f"m{suffix}"):
        write_mesh(path, vertices, FACES.astype(np.int32))
        V, F = read_mesh(path)
        assert V.dtype == np.float64 and F.dtype == np.int64
        np.testing.assert_allclose(V, vertices.astype(np.float64), rtol=1e-6)
        np.testing.assert_array_equal(F, FACES)
    path = FsPath(tmp_path / "t.ply")
    write_ply(path, vertices, FACES)
    np.testing.assert_allclose(read_ply(path)[0], read_ply_vertices(path), rtol=0)
    assert read_ply_sequence([path, str(tmp_path / "t.ply")]).shape == (2, 3, 3)
    write_obj(FsPath(tmp_path / "t.obj"), vertices, FACES)
    assert read_obj(FsPath(tmp_path / "t.obj"))[0].shape == (3, 3)


@pytest.mark.parametrize("bad, what", [
    ([["a", "b", "c"]], "could not convert"),
    (np.zeros((3, 3), dtype=complex), "complex"),
    ([[0.0, 1.0, 2.0], [0.0, 1.0]], "inhomogeneous"),
    ({"x": 1}, "dict"),
])
def test_vertices_that_are_not_numbers_say_what_is_needed(tmp_path, bad, what):
    for writer in (write_ply, write_obj):
        with pytest.raises(UserError, match=r"vertices as a \(V, 3\) array of real numbers") as caught:
            writer(tmp_path / "x.ply", bad, FACES)
        assert what in str(caught.value)
    with pytest.raises(UserError, match=r"vertices must be \(V, 3\)"):
        write_ply(tmp_path / "x.ply", np.zeros((3, 2), dtype=np.float32))


def test_unsupported_mesh_suffix_is_a_user_error(tmp_path):
    with pytest.raises(UserError, match="unsupported mesh format '.stl'"):
        read_mesh(FsPath(tmp_path / "a.stl"))
    with pytest.raises(UserError, match="expected .obj or .ply"):
        write_mesh(tmp_path / "a.stl", TRIANGLE, FACES)


def test_index_lists_from_any_path_and_bad_content_names_the_file(tmp_path):
    for path in _paths(tmp_path, "idx.txt"):
        with open(path, "w") as f:
            f.write("3 1\n4\n")
        assert read_index_list(path).tolist() == [3, 1, 4]
    (tmp_path / "words.txt").write_text("1 two 3")
    with pytest.raises(DataError, match=r"words\.txt: expected whitespace-separated integer"):
        read_index_list(FsPath(tmp_path / "words.txt"))
    (tmp_path / "binary.txt").write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(DataError, match=r"binary\.txt: expected a text file"):
        read_index_list(tmp_path / "binary.txt")


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_audio_round_trips_through_any_path_and_float_dtype(tmp_path, dtype):
    samples = (0.25 * np.sin(np.linspace(0, 200, 8000))).astype(dtype)
    for path in _paths(tmp_path, "a.wav"):
        write_wav(path, samples, 16000)
        back, rate = read_wav(path)
        assert rate == 16000 and back.dtype == np.float32
        np.testing.assert_allclose(back, samples.astype(np.float32), atol=1e-3)
        assert load_audio(path, rate=8000).shape == (4000,)


def test_audio_samples_that_are_not_numbers_say_what_is_needed(tmp_path):
    with pytest.raises(UserError, match=r"samples as a \(N,\) or \(N, C\) array of real numbers"):
        write_wav(FsPath(tmp_path / "a.wav"), ["loud", "quiet"], 16000)
    with pytest.raises(UserError, match="NaN or infinite"):
        write_wav(tmp_path / "a.wav", np.array([0.0, np.nan], dtype=np.float32), 16000)


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_coefficient_csvs_through_any_path_and_float_dtype(tmp_path, dtype):
    coeffs = np.array([[0.0, 0.5], [0.25, 1.0]], dtype=dtype)
    for path in _paths(tmp_path, "c.csv"):
        write_coeffs_csv(path, coeffs, ("jawOpen", "mouthClose"))
        back, names = read_coeffs_csv(path)
        assert names == ("jawOpen", "mouthClose") and back.dtype == np.float64
        np.testing.assert_array_equal(back, coeffs.astype(np.float64))


def test_coefficients_that_are_not_numbers_say_what_is_needed(tmp_path):
    with pytest.raises(UserError, match=r"coeffs as a \(T, 2\) array of real numbers"):
        write_coeffs_csv(tmp_path / "c.csv", [["a", "b"]], ("jawOpen", "mouthClose"))


def test_a_binary_file_read_as_coefficients_names_the_file(tmp_path):
    (tmp_path / "c.csv").write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    with pytest.raises(DataError, match=r"c\.csv: not a UTF-8 text CSV"):
        read_coeffs_csv(FsPath(tmp_path / "c.csv"))
