"""Property-based fuzzing of the PLY, OBJ and WAV readers: any bytes give either a
valid result or the reader's own error type (never an IndexError, KeyError, ...)."""

from __future__ import annotations

import io
import struct

import numpy as np
import soundfile
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from blendvoca.io.audio import AudioFormatError, read_wav
from blendvoca.io.mesh import MeshFormatError, parse_obj, ply_face_block, ply_header, read_ply, read_ply_vertices

FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

_VALID_PLY = ply_header(4, 2) + np.arange(12, dtype="<f4").tobytes() + ply_face_block([[0, 1, 2], [0, 2, 3]])
_ASCII_PLY = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
             b"element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"


def _check_mesh(V, F=None):
    assert isinstance(V, np.ndarray) and V.dtype == np.float64 and V.ndim == 2 and V.shape[1] == 3
    if F is not None:
        assert F.dtype == np.int64 and F.ndim == 2 and F.shape[1] == 3
        assert F.size == 0 or (F.min() >= 0 and F.max() < len(V))


def _ply(tmp_path, data):
    path = tmp_path / "fuzz.ply"
    path.write_bytes(data)
    return path


@st.composite
def mutated(draw, base: bytes):
    """``base`` with a few bytes flipped, cut or inserted (header and body both)."""
    data = bytearray(base)
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "cut", "insert", "truncate"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if op == "flip" and data:
            data[at] = draw(st.integers(0, 255))
        elif op == "cut":
            del data[at:at + draw(st.integers(1, 8))]
        elif op == "insert":
            data[at:at] = draw(st.binary(min_size=1, max_size=8))
        else:
            del data[at:]
    return bytes(data)


header_lines = st.lists(st.sampled_from([
    b"format binary_little_endian 1.0", b"format ascii 1.0", b"format binary_big_endian 1.0", b"format",
    b"element vertex 3", b"element vertex -1", b"element vertex x", b"element face 1", b"element",
    b"property float x", b"property float y", b"property float z", b"property flaot x", b"property",
    b"property list uchar int vertex_indices", b"property list uchar", b"comment hi", b"obj_info",
]), max_size=10)


@FUZZ
@given(data=st.one_of(st.binary(max_size=300), mutated(_VALID_PLY), mutated(_ASCII_PLY),
                      st.tuples(header_lines, st.binary(max_size=80)).map(
                          lambda hb: b"ply\n" + b"\n".join(hb[0]) + b"\nend_header\n" + hb[1])))
@example(data=_VALID_PLY.replace(b"property float x", b"property flaot x"))
def test_ply_reader_gives_a_mesh_or_its_own_error(tmp_path, data):
    path = _ply(tmp_path, data)
    for read in (read_ply, read_ply_vertices):
        try:
            result = read(path)
        except MeshFormatError as error:
            assert str(path) in str(error)
            continue
        if read is read_ply:
            _check_mesh(*result)
        else:
            _check_mesh(result)


def test_ply_header_typo_names_file_and_line(tmp_path):
    path = _ply(tmp_path, _VALID_PLY.replace(b"property float x", b"property flaot x"))
    try:
        read_ply(path)
    except MeshFormatError as error:
        assert str(path) in str(error) and "flaot" in str(error) and "line 4" in str(error)
    else:  # pragma: no cover
        raise AssertionError("a header typo was accepted")


obj_lines = st.lists(st.one_of(
    st.sampled_from(["v 0 0 0", "v 1 0 0", "v 0 1 0", "v 1 2", "v a b c", "f 1 2 3", "f 1/1/1 2/2/2 3/3/3",
                     "f -1 -2 -3", "f 0 1 2", "f 1 2", "f x y z", "f 1 2 9", "vt 0 0", "# c", ""]),
    st.text(max_size=20)), max_size=12)


@FUZZ
@given(lines=obj_lines)
def test_obj_reader_gives_a_mesh_or_its_own_error(lines):
    try:
        V, F = parse_obj("\n".join(lines), where="fuzz.obj")
    except MeshFormatError as error:
        assert "fuzz.obj" in str(error)
        return
    _check_mesh(V, F)


def _valid_wav() -> bytes:
    buffer = io.BytesIO()
    soundfile.write(buffer, np.linspace(-0.5, 0.5, 64, dtype=np.float32), 16000, format="WAV", subtype="PCM_16")
    return buffer.getvalue()


@FUZZ
@given(data=st.one_of(st.binary(max_size=200), mutated(_valid_wav()),
                      st.binary(max_size=40).map(lambda b: b"RIFF" + struct.pack("<I", len(b) + 4) + b"WAVE" + b)))
def test_wav_reader_gives_audio_or_its_own_error(tmp_path, data):
    path = tmp_path / "fuzz.wav"
    path.write_bytes(data)
    try:
        samples, rate = read_wav(path)
    except AudioFormatError as error:
        assert str(path) in str(error)
        return
    assert isinstance(samples, np.ndarray) and samples.dtype == np.float32 and samples.ndim in (1, 2)
    assert isinstance(rate, int) and rate > 0
