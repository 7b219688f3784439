"""Property-based fuzzing of every reader of a file a user brings: PLY, OBJ, WAV,
coefficient CSV, result JSON, manifest and splits, rigs, torch checkpoints, the
processed VOCASET layout, the synthetic sidecar and the exported tracks.

Any bytes give either a valid result or an error of the project's tree
(``DataError`` / ``UserError``; never an IndexError, KeyError, ...). Every test runs
derandomized (the same examples in every run, so CI is reproducible) with a
deadline per example and a pytest-timeout per test, so a hang fails instead of
stalling the suite.
"""

from __future__ import annotations

import io
import json
import pickle
import shutil
import struct
import subprocess
import sys
import tempfile
import zipfile
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
import soundfile
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

from blendvoca.errors import DataError, UserError
from blendvoca.format.items import read_coeffs_file
from blendvoca.io.audio import AudioFormatError, load_audio, read_wav
from blendvoca.io.coeffs import format_coeffs_csv, missing_columns, read_coeffs_csv
from blendvoca.io.mesh import (MeshFormatError, parse_obj, ply_face_block, ply_header, read_index_list, read_obj,
                               read_ply, read_ply_vertices)

FUZZ = settings(max_examples=150, deadline=timedelta(seconds=1), derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

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


@pytest.mark.timeout(60)
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


@pytest.mark.timeout(60)
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


@pytest.mark.timeout(60)
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


# ============================================================================ the other readers
#
# Each reader below is given random bytes, mutations of a file the project's own
# writer made, and structured junk (the right container with the wrong content).
# The contract: a result, or an error of the project's tree (DataError / UserError,
# which the CLI layer turns into one `error:` line and exit 2). Anything else,
# an IndexError, a KeyError, a numpy error, is an internal bug and fails the test.

#: What a reader may raise for a file a user brings.
TREE_ERRORS = (DataError, UserError)


def quick(examples: int, deadline_ms: int = 1000, *, shrink: bool = True) -> settings:
    """Settings of a fuzz test: ``examples`` examples, each within ``deadline_ms``, reproducible.

    ``shrink=False`` for a test that is a known failure (a strict xfail): it stops at the
    first failing example instead of spending seconds minimising it.
    """
    phases = list(Phase) if shrink else [Phase.explicit, Phase.reuse, Phase.generate]
    return settings(max_examples=examples, deadline=timedelta(milliseconds=deadline_ms), derandomize=True,
                    phases=phases,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                           HealthCheck.data_too_large])


def outcome(read, *args, **kwargs):
    """``read(*args, **kwargs)``, or the tree error it raised; any other exception propagates."""
    try:
        return read(*args, **kwargs)
    except TREE_ERRORS as error:
        return error


def json_values(max_leaves: int = 8):
    """Any JSON value (NaN and infinities included, as Python's json writes them)."""
    scalars = (st.none() | st.booleans() | st.integers(-2 ** 70, 2 ** 70)
               | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=6))
    return st.recursive(scalars, lambda inner: st.lists(inner, max_size=3)
                        | st.dictionaries(st.text(max_size=6), inner, max_size=3), max_leaves=max_leaves)


def _paths(value, prefix=()):
    yield prefix
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _paths(item, prefix + (key,))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from _paths(item, prefix + (index,))


@st.composite
def reshaped(draw, document):
    """``document`` (a JSON value) with a few of its values replaced by junk or removed."""
    document = json.loads(json.dumps(document))
    for _ in range(draw(st.integers(1, 3))):
        paths = list(_paths(document))
        path = draw(st.sampled_from(paths))
        if not path:
            document = draw(json_values())
            continue
        parent = document
        for key in path[:-1]:
            parent = parent[key]
        if isinstance(parent, dict) and draw(st.booleans()):
            del parent[path[-1]]
        else:
            parent[path[-1]] = draw(json_values())
    return document


#: JSON texts that parse into what Python's json cannot hold or that break it.
HOSTILE_JSON = [b"1" * 5000, b"[" * 5000 + b"]" * 5000, b'{"a":' * 3000 + b"1" + b"}" * 3000,
                b"NaN", b"-Infinity", b"1e999", b"\xef\xbb\xbf{}", b"\xff\xfe{\x00}\x00", b"", b"null"]


def json_files(document):
    """Bytes of a JSON file: ``document`` reshaped, mutated, random, or hostile."""
    valid = json.dumps(document).encode()
    return st.one_of(
        reshaped(document).map(lambda d: json.dumps(d).encode()),
        mutated(valid),
        st.binary(max_size=200),
        st.sampled_from(HOSTILE_JSON),
    )


# ---------------------------------------------------------------------------- OBJ files and index lists


@quick(100)
@given(data=st.one_of(st.binary(max_size=200), obj_lines.map(lambda lines: "\n".join(lines).encode("utf-8", "replace")),
                      mutated(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")))
@pytest.mark.timeout(60)
def test_obj_and_index_files_give_a_result_or_a_tree_error(tmp_path, data):
    path = tmp_path / "fuzz.obj"
    path.write_bytes(data)
    result = outcome(read_obj, path)
    if not isinstance(result, Exception):
        _check_mesh(*result)
    indices = outcome(read_index_list, path)
    if isinstance(indices, Exception):
        assert str(path) in str(indices)
    else:
        assert indices.dtype == np.int64 and indices.ndim == 1


# ---------------------------------------------------------------------------- WAV, resampled


@quick(80)
@given(data=st.one_of(mutated(_valid_wav()), st.binary(max_size=40).map(
    lambda b: b"RIFF" + struct.pack("<I", len(b) + 4) + b"WAVE" + b)),
    rate=st.sampled_from([16000, 8000, 22050]))
@pytest.mark.timeout(60)
def test_load_audio_gives_mono_audio_or_a_tree_error(tmp_path, data, rate):
    path = tmp_path / "fuzz.wav"
    path.write_bytes(data)
    samples = outcome(load_audio, path, rate)
    if not isinstance(samples, Exception):
        assert isinstance(samples, np.ndarray) and samples.ndim == 1


# ---------------------------------------------------------------------------- coefficient CSV

_CSV_NAMES = ("jawOpen", "mouthClose", "mouthFunnel")


def _valid_csv() -> bytes:
    buffer = io.StringIO()
    buffer.write(format_coeffs_csv(np.linspace(0, 1, 12).reshape(4, 3), _CSV_NAMES))
    return buffer.getvalue().encode()


csv_cells = st.sampled_from(["0.5", "1", "-0", "nan", "NaN", "inf", "-inf", "1e999", "1" * 400, "", " ", "x",
                             '"0.25"', '"', "0x10", "1_0", "\x00", "１", "0.1.2"])
header_cells = st.sampled_from(["jawOpen", "JAWOPEN", "JawOpen", "mouthClose", "mouthFunnel", "Timecode",
                                "BlendShapeCount", "HeadYaw", "jawopen ", "", "frame", '"jawOpen"', "\ufeffjawOpen"])
structured_csv = st.tuples(st.lists(header_cells, max_size=5),
                           st.lists(st.lists(csv_cells, max_size=6), max_size=5)).map(
    lambda hr: ("\n".join([",".join(hr[0])] + [",".join(row) for row in hr[1]]) + "\n").encode("utf-8"))


@quick(150)
@given(data=st.one_of(st.binary(max_size=120), mutated(_valid_csv()), structured_csv))
@example(data=b"jawOpen\n" + b"1" * 400 + b"\n")
@example(data=b"\xff\xfejawOpen\n")
@pytest.mark.timeout(60)
def test_coefficient_csv_readers_give_a_track_or_a_tree_error(tmp_path, data):
    path = tmp_path / "take.csv"
    path.write_bytes(data)
    for read in (lambda: read_coeffs_csv(path), lambda: read_coeffs_csv(path, names=_CSV_NAMES, missing="zero"),
                 lambda: read_coeffs_file(tmp_path, "take.csv", names=_CSV_NAMES)):
        result = outcome(read)
        if isinstance(result, Exception):
            assert str(path) in str(result), result
            continue
        coeffs, names = result
        assert coeffs.dtype == np.float64 and coeffs.shape == (len(coeffs), len(names))
    absent = outcome(missing_columns, path, _CSV_NAMES)
    if isinstance(absent, Exception):
        assert str(path) in str(absent)
    else:
        assert set(absent) <= set(_CSV_NAMES)


# ---------------------------------------------------------------------------- result JSON


def _valid_result() -> dict:
    from benchmark.results import build_result

    return build_result(
        method={"name": "mean", "label": "Mean", "class": "x:Y", "stochastic": False, "reference": True, "config": {}},
        dataset={"manifest_hash": "ab" * 32, "split": "test", "num_sentences": 4},
        protocol={"samples": 1, "seed": 0},
        metrics={"mse": {"mean": 0.5, "std": 0.1, "higher_is_better": False, "unit": "", "ci95": [0.4, 0.6]},
                 "fd": {"mean": 2.0, "std": None, "higher_is_better": None}},
        timings={"generate": 1.0}, provenance={"date": "2024-01-01"}).to_json()


@quick(150)
@given(data=json_files(_valid_result()))
@example(data=b'{"schema_version": 1, "mean": ' + b"1" * 400 + b"}")
@pytest.mark.timeout(60)
def test_result_files_give_a_checked_result_or_a_tree_error(tmp_path, data):
    from benchmark.results import Result, read
    from leaderboard.collect import load_results, tables_by_manifest

    results = tmp_path / "results"
    results.mkdir(exist_ok=True)
    path = results / "run.json"
    path.write_bytes(data)
    result = outcome(read, path)
    if isinstance(result, Exception):
        assert str(path) in str(result), result
    else:
        assert isinstance(result, Result)
    shutil.copyfile(path, results / "other.json")
    (results / "valid.json").write_text(json.dumps(_valid_result()))
    loaded = outcome(load_results, results)
    if not isinstance(loaded, Exception):
        tables = outcome(tables_by_manifest, loaded)
        assert isinstance(tables, (list, Exception))


# ---------------------------------------------------------------------------- manifest.json and splits.json

_VALID_MANIFEST = {"tool": "blendvoca.build", "version": "0.1.0", "inputs": {"vocaset": {"path": "/data/vocaset"}},
                   "files": {"coeffs/FaceTalk_A/sentence01.csv": "0" * 64, "splits.json": "1" * 64}}


@quick(150)
@given(data=json_files(_VALID_MANIFEST))
@pytest.mark.timeout(60)
def test_manifest_readers_give_listings_or_a_tree_error(tmp_path, data):
    from blendvoca.format.manifest import listed_files, manifest_hash, read_manifest, recorded_vocaset, written_by_build

    (tmp_path / "manifest.json").write_bytes(data)
    manifest = outcome(read_manifest, tmp_path)
    assert isinstance(manifest, (dict, Exception))
    files = outcome(listed_files, tmp_path)
    if not isinstance(files, Exception):
        assert all(isinstance(k, str) and isinstance(v, str) for k, v in files.items())
    digest = outcome(manifest_hash, tmp_path)
    assert isinstance(digest, Exception) or len(digest) == 64
    vocaset = outcome(recorded_vocaset, tmp_path)
    assert vocaset is None or isinstance(vocaset, (str, Exception))
    assert isinstance(outcome(written_by_build, tmp_path), (bool, Exception))


@quick(100)
@given(data=json_files({"train": ["FaceTalk_A", "FaceTalk_B"], "val": ["FaceTalk_C"], "test": []}))
@pytest.mark.timeout(60)
def test_splits_reader_gives_lists_of_subjects_or_a_tree_error(tmp_path, data):
    from blendvoca.format.items import read_splits

    (tmp_path / "splits.json").write_bytes(data)
    splits = outcome(read_splits, tmp_path)
    if isinstance(splits, Exception):
        assert "splits.json" in str(splits)
    else:
        assert all(isinstance(k, str) and isinstance(v, list) and all(isinstance(s, str) for s in v)
                   for k, v in splits.items())


# ---------------------------------------------------------------------------- rigs (.npz and zip of OBJ)


def _tiny_rig():
    from blendvoca.rig import Rig

    neutral = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=np.float64)
    deltas = np.stack([np.full((4, 3), 0.1), np.full((4, 3), -0.2)])
    return Rig(neutral, deltas, ("jawOpen", "mouthClose"), np.array([[0, 1, 2], [1, 3, 2]]))


def _rig_bytes() -> bytes:
    buffer = io.BytesIO()
    rig = _tiny_rig()
    np.savez_compressed(buffer, neutral=rig.neutral, deltas=rig.deltas, names=np.array(rig.names), faces=rig.faces)
    return buffer.getvalue()


junk_arrays = st.one_of(
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=12).map(np.array),
    st.tuples(st.integers(0, 3), st.integers(0, 5), st.integers(0, 4)).map(lambda s: np.ones(s)),
    st.lists(st.integers(-2 ** 62, 2 ** 62), max_size=9).map(lambda v: np.array(v, dtype=np.int64)),
    st.lists(st.text(max_size=5), max_size=4).map(lambda v: np.array(v, dtype=str)),
    st.sampled_from([np.array(1.5), np.zeros((0, 3)), np.array([1 + 2j]), np.array([b"jawOpen"]),
                     np.array(["jawOpen", "jawOpen"]), np.array([[0, 1, 9]]), np.array([[0.5, 1, 2]]),
                     np.array([True]), np.array(["2020-01-01"], dtype="datetime64[D]"),
                     np.array([{"a": 1}], dtype=object)]),
)


@st.composite
def rig_archives(draw) -> bytes:
    """An ``.npz`` holding some of the rig's arrays, some replaced by junk."""
    rig = _tiny_rig()
    arrays = {"neutral": rig.neutral, "deltas": rig.deltas, "names": np.array(rig.names), "faces": rig.faces}
    for key in draw(st.lists(st.sampled_from(sorted(arrays)), max_size=3, unique=True)):
        if draw(st.booleans()):
            del arrays[key]
        else:
            arrays[key] = draw(junk_arrays)
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


@quick(150)
@given(data=st.one_of(st.binary(max_size=200), mutated(_rig_bytes()), rig_archives(),
                      st.sampled_from([b"neutral,deltas\n1,2\n", b"\x93NUMPY\x01\x00v\x00{'descr': '<f8'}"])))
@pytest.mark.timeout(60)
def test_rig_npz_gives_a_rig_or_a_tree_error(tmp_path, data):
    from blendvoca.rig import Rig

    path = tmp_path / "rig.npz"
    path.write_bytes(data)
    rig = outcome(Rig.load, path)
    if isinstance(rig, Exception):
        assert str(path) in str(rig), rig
    else:
        assert rig.deltas.shape == (len(rig.names), rig.num_vertices, 3)


@st.composite
def obj_zips(draw) -> bytes:
    """A zip of ``<folder>/<name>.obj`` members holding OBJ text, junk or nothing."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name in draw(st.lists(st.sampled_from(["Neutral", "jawOpen", "mouthClose", "other"]), max_size=4)):
            text = draw(st.one_of(st.just("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
                                  obj_lines.map("\n".join), st.text(max_size=30)))
            archive.writestr(f"rig/{name}.obj", text.encode("utf-8", "replace"))
    return buffer.getvalue()


@quick(100)
@given(data=st.one_of(obj_zips(), obj_zips().flatmap(mutated), st.binary(max_size=100)))
@pytest.mark.timeout(60)
def test_rig_zip_gives_a_rig_or_a_tree_error(tmp_path, data):
    from blendvoca.rig import read_rig_zip

    path = tmp_path / "rig.zip"
    path.write_bytes(data)
    rig = outcome(read_rig_zip, path, ("jawOpen", "mouthClose"))
    if isinstance(rig, Exception):
        assert str(path) in str(rig), rig
    else:
        assert rig.names == ("jawOpen", "mouthClose")


# ---------------------------------------------------------------------------- torch checkpoints


@pytest.fixture(scope="module")
def checkpoint_bytes() -> bytes:
    """A small checkpoint as the project writes them: a state_dict and a JSON config."""
    torch = pytest.importorskip("torch")
    from blendvoca.io.torch_file import write_torch_file

    folder = Path(tempfile.mkdtemp())
    path = write_torch_file(folder / "model.pt", {"state_dict": {"w": torch.arange(6.0).reshape(2, 3),
                                                                 "b": torch.zeros(2, dtype=torch.int64)},
                                                  "config": json.dumps({"layers": 2})})
    data = path.read_bytes()
    shutil.rmtree(folder)
    return data


@st.composite
def junk_zips(draw, real: bytes) -> bytes:
    """A zip laid out like a torch checkpoint whose members are junk (or a real member changed)."""
    with zipfile.ZipFile(io.BytesIO(real)) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    for name in draw(st.lists(st.sampled_from(sorted(members)), min_size=1, max_size=3, unique=True)):
        change = draw(st.sampled_from(["junk", "drop", "mutate"]))
        if change == "drop":
            del members[name]
        elif change == "junk":
            members[name] = draw(st.binary(max_size=60))
        else:
            members[name] = draw(mutated(members[name] or b"\x00"))
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, payload in members.items():
            archive.writestr(name, payload)
    return buffer.getvalue()


@quick(120, deadline_ms=3000)
@given(data=st.data())
@pytest.mark.timeout(120)
def test_torch_reader_gives_a_checkpoint_or_a_tree_error(tmp_path, checkpoint_bytes, data):
    from blendvoca.io.torch_file import read_torch_file

    content = data.draw(st.one_of(
        st.binary(max_size=200),
        st.integers(0, len(checkpoint_bytes) - 1).map(lambda n: checkpoint_bytes[:n]),
        mutated(checkpoint_bytes),
        junk_zips(checkpoint_bytes),
        st.sampled_from([pickle.dumps({"w": [1, 2]}), pickle.dumps(np.zeros(3)), b"PK\x05\x06" + bytes(18)]),
    ), label="checkpoint")
    path = tmp_path / "model.pt"
    path.write_bytes(content)
    result = outcome(read_torch_file, path, where="fuzz")
    if isinstance(result, Exception):
        assert str(path) in str(result), result


# ---------------------------------------------------------------------------- processed VOCASET layout

_V = 4  # vertices of the small processed corpora below


def _processed_files() -> dict:
    """The four files of a processed corpus of 3 speakers x 1 sentence x 3 frames of ``_V`` vertices."""
    buffer = io.BytesIO()
    np.save(buffer, np.arange(9 * _V * 3, dtype=np.float32).reshape(9, _V, 3))
    rate = 16000
    index = {f"FaceTalk_{s}": {"sentence01": {f: 3 * k + f for f in range(3)}} for k, s in enumerate("ABC")}
    audio = {s: {"sentence01": {"audio": np.zeros(800, dtype=np.int16), "sample_rate": rate}} for s in index}
    templates = {s: np.zeros((_V, 3)) for s in index}
    return {"data_verts.npy": buffer.getvalue(), "subj_seq_to_idx.pkl": pickle.dumps(index, protocol=2),
            "raw_audio_fixed.pkl": pickle.dumps(audio, protocol=2), "templates.pkl": pickle.dumps(templates, protocol=2)}


_PROCESSED = _processed_files()

pickle_values = st.recursive(
    st.none() | st.booleans() | st.integers(-5, 10) | st.text(max_size=4) | st.floats()
    | st.sampled_from([np.zeros(3), np.zeros((_V, 3)), np.int64(2), np.zeros(0, dtype=np.int16), b"\x00"]),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(
        st.one_of(st.text(max_size=10), st.integers(-2, 12), st.sampled_from(["FaceTalk_A", "sentence01", "../x"])),
        inner, max_size=3),
    max_leaves=8)


def _npy(shape, dtype, fortran, body: bytes) -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": np.lib.format.dtype_to_descr(np.dtype(dtype)),
                                                  "fortran_order": fortran, "shape": shape})
    return buffer.getvalue() + body


# Object dtypes are left out: a regression there segfaults the run (test_object_array_npy_is_refused_not_mapped).
npy_files = st.builds(_npy, st.lists(st.integers(0, 8), max_size=4).map(tuple),
                      st.sampled_from(["<f4", ">f8", "<i2", "u1", "<c8", "S3", "<M8[s]", [("x", "<f4")]]),
                      st.booleans(), st.binary(max_size=300))


@st.composite
def processed_folders(draw) -> dict:
    """The four files with one or two of them random bytes, mutated, or junk of the right type."""
    files = dict(_PROCESSED)
    for name in draw(st.lists(st.sampled_from(sorted(files)), min_size=1, max_size=2, unique=True)):
        if name == "data_verts.npy":
            files[name] = draw(st.one_of(npy_files, mutated(files[name][:200]), st.binary(max_size=100)))
        else:
            files[name] = draw(st.one_of(
                mutated(files[name]), st.binary(max_size=80),
                pickle_values.map(lambda value: pickle.dumps(value, protocol=2))))
    return files


def _read_corpus(root):
    """Open, scan and read every item of the corpus at ``root``; tree errors pass through."""
    from blendvoca.vocaset.corpus import open_vocaset

    corpus = open_vocaset(root, num_vertices=_V)
    corpus.scan()
    assert isinstance(corpus.splits, dict)
    for subject, sentence in corpus.items():
        outcome(corpus.frames, subject, sentence)
        outcome(corpus.audio, subject, sentence)
    return corpus


@quick(150)
@given(files=processed_folders())
@pytest.mark.timeout(90)
def test_processed_layout_gives_a_corpus_or_a_tree_error(tmp_path, files):
    for name, content in files.items():
        (tmp_path / name).write_bytes(content)
    outcome(_read_corpus, tmp_path)


def test_processed_layout_reads_its_own_files(tmp_path):
    """The fuzzed corpus is readable when left intact (so the fuzzing starts from a valid file)."""
    for name, content in _PROCESSED.items():
        (tmp_path / name).write_bytes(content)
    corpus = _read_corpus(tmp_path)
    assert corpus.items() == [(f"FaceTalk_{s}", "sentence01") for s in "ABC"]
    assert corpus.frames("FaceTalk_B", "sentence01").shape == (3, _V, 3)


# ---------------------------------------------------------------------------- synthetic.json sidecar

_VALID_SIDECAR = {"seed": 1, "generator_version": 3, "layout": "processed",
                  "splits": {"train": ["FaceTalk_A"], "val": ["FaceTalk_B"], "test": []},
                  "lags": {"FaceTalk_A": {"sentence01": 1}}}


@quick(120)
@given(data=json_files(_VALID_SIDECAR))
@pytest.mark.timeout(60)
def test_synthetic_sidecar_gives_splits_or_a_tree_error(tmp_path, data):
    for name, content in _PROCESSED.items():
        (tmp_path / name).write_bytes(content)
    (tmp_path / "synthetic.json").write_bytes(data)
    corpus = outcome(_read_corpus, tmp_path)
    if isinstance(corpus, Exception):
        assert "synthetic.json" in str(corpus), corpus
    else:
        assert all(isinstance(v, list) for v in corpus.splits.values())


# ---------------------------------------------------------------------------- exported tracks


@pytest.fixture(scope="module")
def exported() -> dict:
    """``{format: bytes}`` of a 3-frame track exported to each format (glb and usd on a 4-vertex rig;
    not fbx, whose reader is Blender in a subprocess: too slow for a fuzz test)."""
    from blendvoca.export import FORMATS, SUFFIX, export_track

    folder = Path(tempfile.mkdtemp())
    files = {}
    for fmt in (f for f in FORMATS if f != "fbx"):
        path = folder / f"track{SUFFIX[fmt]}"
        export_track(path, np.full((3, 2), 0.25), ("jawOpen", "mouthClose"), fmt, rig=_tiny_rig())
        files[fmt] = path.read_bytes()
    shutil.rmtree(folder)
    return files


_TRACK_JSON = {"arkit-json": {"frameRate": 60, "blendShapeNames": ["jawOpen"], "weights": [[0.5], [0.25]]},
               "a2f-json": {"exportFps": 60, "numPoses": 1, "numFrames": 2, "facsNames": ["jawOpen"],
                            "weightMat": [[0.5], [0.25]], "trackPath": ""}}


@quick(150, deadline_ms=2000)
@given(data=st.data(), fmt=st.sampled_from(["livelink", "arkit-json", "a2f-json", "glb", "csv", "usd"]))
@pytest.mark.timeout(120)
def test_export_readers_give_a_track_or_a_tree_error(tmp_path, exported, data, fmt):
    from blendvoca.export import SUFFIX, read_track

    choices = [mutated(exported[fmt]), st.binary(max_size=120)]
    if fmt in _TRACK_JSON:
        choices.append(json_files(_TRACK_JSON[fmt]))
    if fmt in ("livelink", "csv"):
        choices.append(structured_csv)
    content = data.draw(st.one_of(choices), label="file")
    path = tmp_path / f"track{SUFFIX[fmt]}"
    path.write_bytes(content)
    for given_format in (None, fmt):
        result = outcome(read_track, path, given_format)
        if isinstance(result, Exception):
            assert str(path) in str(result), result
        else:
            coeffs, names, fps = result
            assert np.asarray(coeffs).ndim == 2 and len(names) == np.asarray(coeffs).shape[1] and fps > 0


# ---------------------------------------------------------------------------- crashes found in the corpus readers
#
# The minimal inputs of the crashes the fuzzing above found in the processed VOCASET
# reader and the synthetic sidecar: each is a DataError naming the file and, in a
# few words, what is wrong with it.


def _corpus_with(folder: Path, **files) -> Path:
    for name, content in {**_PROCESSED, **files}.items():
        (folder / name).write_bytes(content)
    return folder


def _track(folder: Path, name: str, content: bytes, fmt=None):
    from blendvoca.export import read_track

    (folder / name).write_bytes(content)
    return read_track(folder / name, fmt)


def _open(folder: Path, **files):
    """Open the corpus of ``_PROCESSED`` with ``files`` replaced, and read every item."""
    return _read_corpus(_corpus_with(folder, **files))


def _first_frames(folder: Path, **files):
    """The frames of FaceTalk_A/sentence01 of that corpus."""
    return _open(folder, **files).frames("FaceTalk_A", "sentence01")


_INDEX_BEYOND = pickle.dumps({"FaceTalk_A": {"sentence01": {0: 99}}}, protocol=2)
VOCASET_REFUSALS = [
    pytest.param(_open, {"data_verts.npy": _npy((), "<f4", False, b"")}, "data_verts.npy", "single number (shape ())",
                 id="npy-0d"),
    pytest.param(_open, {"data_verts.npy": _npy((0,), "<f4", False, b"")}, "data_verts.npy",
                 "holds an array of shape (0,); expected vertices (N, 4, 3)", id="npy-empty"),
    pytest.param(_open, {"data_verts.npy": _npy((1,), "<f4", False, bytes(4))}, "data_verts.npy",
                 "holds an array of shape (1,); expected vertices (N, 4, 3)", id="npy-1d"),
    pytest.param(_first_frames, {"subj_seq_to_idx.pkl": _INDEX_BEYOND}, "subj_seq_to_idx.pkl",
                 "frame 0 is row 99 of data_verts.npy, which has 9 rows", id="index-row-beyond"),
    pytest.param(_open, {"data_verts.npy": b"\x93NUMPY\x01\x00\x10\x00{'descr': '<f4'\n"}, "data_verts.npy",
                 "not a readable .npy file", id="npy-header-unclosed"),
    pytest.param(lambda d, **files: _open(d, **files).template("FaceTalk_A"),
                 {"templates.pkl": pickle.dumps({"FaceTalk_A": "x"}, protocol=2)}, "templates.pkl",
                 "the entry is a str 'x' (dtype <U1), expected (4, 3) vertex coordinates", id="template-string"),
    pytest.param(_open, {"synthetic.json": b"NaN"}, "synthetic.json", "sidecar is a number, expected a JSON object",
                 id="sidecar-nan"),
    pytest.param(_open, {"synthetic.json": b"1" * 5000}, "synthetic.json", "a number with more digits than",
                 id="sidecar-long-int"),
    pytest.param(_open, {"synthetic.json": b"[" * 5000}, "synthetic.json", "nested too deeply", id="sidecar-deep"),
    pytest.param(_open, {"synthetic.json": b'{"splits": 5}'}, "synthetic.json",
                 "'splits' is a number, expected an object", id="sidecar-splits-int"),
    pytest.param(_open, {"synthetic.json": b'{"splits": {"train": 5}}'}, "synthetic.json",
                 "split 'train' is a number, expected a list of speaker names", id="sidecar-split-int"),
]


@pytest.mark.timeout(60)
@pytest.mark.parametrize("read, files, name, what", VOCASET_REFUSALS)
def test_vocaset_reader_refuses_a_bad_file_with_a_data_error(tmp_path, read, files, name, what):
    from blendvoca.vocaset.errors import VocasetError

    with pytest.raises(DataError) as caught:
        read(tmp_path, **files)
    # a whole file is named by its path, one bad item of it (a VocasetError) by subject, sentence and file name
    named = name if isinstance(caught.value, VocasetError) else str(tmp_path / name)
    assert named in str(caught.value) and what in str(caught.value), caught.value


# The minimal inputs of the crashes the fuzzing found in the export readers: each is a
# DataError naming the file and, in a word or two, what is wrong with it.
_ARKIT = b'{"frameRate": 60, "blendShapeNames": ["jawOpen"], '
EXPORT_REFUSALS = [
    pytest.param("t.csv", b"\x80", "not a UTF-8", id="csv-not-utf8"),
    pytest.param("t.glb", b"glTF", "not a readable GLB", id="glb-short"),
    pytest.param("t.glb", bytes(20), "GLB", id="glb-zeros"),
    pytest.param("t.json", b"1", "the document is a number", id="json-number"),
    pytest.param("t.json", b"1" * 5000, "more digits than Python reads", id="json-long-int"),
    pytest.param("t.json", b"[" * 5000, "nested too deeply", id="json-deep"),
    pytest.param("t.json", _ARKIT + b'"weights": 5}', "'weights' is a number", id="arkit-weights-int"),
    pytest.param("t.json", b'{"frameRate": null, "blendShapeNames": [], "weights": []}', "'frameRate' is None",
                 id="arkit-fps-null"),
    pytest.param("t.json", _ARKIT + b'"weights": [["x"]]}', "frame 0, 'jawOpen': weight 'x' is not a finite",
                 id="arkit-weight-string"),
    pytest.param("t.json", b'{"exportFps": 60, "numPoses": "x", "numFrames": 0, "facsNames": [], "weightMat": []}',
                 "'numPoses' is 'x'", id="a2f-poses-string"),
    pytest.param("t.usda", b"#usda 1.0\n(", "not a readable USD stage", id="usda-unparsable"),
    pytest.param("t.json", _ARKIT + b'"weights": [[' + b"9" * 400 + b"]]}", "not a finite number",
                 id="arkit-weight-beyond-float"),
    pytest.param("t.json", _ARKIT + b'"weights": [[NaN]]}', "not a finite number", id="arkit-weight-nan"),
    pytest.param("t.json", b'{"frameRate": 60, "blendShapeNames": [1], "weights": []}', "entry 0 is a number",
                 id="arkit-name-int"),
]


@pytest.mark.timeout(60)
@pytest.mark.parametrize("name, content, what", EXPORT_REFUSALS)
def test_export_reader_refuses_a_bad_file_with_a_data_error(tmp_path, name, content, what):
    for fmt in (None, {".csv": "csv", ".glb": "glb", ".usda": "usd"}.get(Path(name).suffix)):
        with pytest.raises(DataError) as caught:
            _track(tmp_path, name, content, fmt)
        assert str(tmp_path / name) in str(caught.value) and what in str(caught.value), caught.value


@pytest.mark.timeout(60)
@pytest.mark.parametrize("fmt, old, new, what", [
    ("glb", b'"count":6,"type":"SCALAR"}]', b'"count":9,"type":"SCALAR"}]', "lies outside the GLB's 204-byte buffer"),
    ("glb", b'"targetNames":["jawOpen","mouthClose"]', b'"targetNames":["jawOpen",{"m":"mout"}]',
     "extras.targetNames is not a list of 2 names"),
    ("usd", b"timeCodesPerSecond = 60", b"timeCodesPerSecond = -6", "expected a positive frame rate"),
])
def test_an_exported_file_edited_into_nonsense_is_a_data_error(tmp_path, exported, fmt, old, new, what):
    """An exported file with one value changed so that it no longer holds: a DataError saying which value."""
    assert exported[fmt].count(old) == 1 and len(new) == len(old)  # a GLB's chunk lengths stay right
    with pytest.raises(DataError) as caught:
        _track(tmp_path, f"t.{'glb' if fmt == 'glb' else 'usda'}", exported[fmt].replace(old, new))
    assert str(tmp_path / "t.") in str(caught.value) and what in str(caught.value), caught.value


@pytest.mark.timeout(60)
def test_object_array_npy_is_refused_not_mapped(tmp_path):
    """Mapping an object array's bytes as pointers segfaults; it is refused instead (in a child process,
    so that a regression fails this test rather than killing the run)."""
    path = tmp_path / "data_verts.npy"
    np.save(path, np.array([[1, "a"]], dtype=object), allow_pickle=True)
    code = ("import sys\nfrom blendvoca.errors import DataError\nfrom blendvoca.vocaset.processed import open_rows\n"
            "try:\n    open_rows(sys.argv[1])[0].sum()\nexcept DataError:\n    sys.exit(0)\nsys.exit(1)\n")
    run = subprocess.run([sys.executable, "-c", code, str(path)], cwd=Path(__file__).parents[2], timeout=50,
                         capture_output=True)
    assert run.returncode == 0, (run.returncode, run.stderr[-500:])
