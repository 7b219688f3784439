"""The processed layout and the synthetic sidecar refuse malformed content with a
``DataError`` naming the file (whole-file faults at open time, one bad item as a
``VocasetError`` of that item, the rest still readable), never another exception."""

from __future__ import annotations

import io
import pickle
import time

import numpy as np
import pytest

from blendvoca.errors import DataError
from blendvoca.vocaset import open_vocaset
from blendvoca.vocaset.base import read_sidecar
from blendvoca.vocaset.checks import frame_gaps
from blendvoca.vocaset.errors import Problem, VocasetError
from blendvoca.vocaset.processed import open_rows

V = 4  # vertices of the tiny corpora below
RATE = 16000


def _npy_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def _npy_header(shape, descr="<f4", body=b"") -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": descr, "fortran_order": False, "shape": shape})
    return buffer.getvalue() + body


def _write(root, *, verts=None, index=None, audio=None, templates=None):
    """A processed corpus of speakers A and B, one sentence of 3 frames each, with any file replaced."""
    if verts is None:
        verts = np.arange(6 * V * 3, dtype=np.float32).reshape(6, V, 3)
    if index is None:
        index = {s: {"sentence01": {f: 3 * k + f for f in range(3)}} for k, s in enumerate(("A", "B"))}
    if audio is None:
        audio = {s: {"sentence01": {"audio": np.zeros(800, dtype=np.int16), "sample_rate": RATE}} for s in ("A", "B")}
    if templates is None:
        templates = {s: np.zeros((V, 3)) for s in ("A", "B")}
    (root / "data_verts.npy").write_bytes(verts if isinstance(verts, bytes) else _npy_bytes(verts))
    for name, value in (("subj_seq_to_idx.pkl", index), ("raw_audio_fixed.pkl", audio), ("templates.pkl", templates)):
        (root / name).write_bytes(pickle.dumps(value, protocol=2))
    return root


def _open(root, **files):
    return open_vocaset(_write(root, **files), num_vertices=V)


# ---------------------------------------------------------------------------- data_verts.npy


@pytest.mark.parametrize("content, what", [
    (_npy_header(()), "holds a single number (shape ())"),
    (_npy_header((0,)), "holds an array of shape (0,); expected vertices (N, 4, 3) or (N, 12)"),
    (_npy_header((1,), body=bytes(4)), "holds an array of shape (1,)"),
    (_npy_bytes(np.zeros((6, 5, 3), dtype=np.float32)),
     "holds an array of shape (6, 5, 3); expected vertices (N, 4, 3)"),
    (_npy_header((6, 2, 3, 2), body=bytes(6 * 48)), "holds an array of shape (6, 2, 3, 2)"),
    (_npy_header((-1, V, 3)), "negative dimension"),
    (_npy_header((3, 2 ** 62, 3), body=bytes(64)), "which numpy cannot map"),
    (b"\x93NUMPY\x01\x00\x10\x00{'descr': '<f4'\n", "not a readable .npy file"),
    (b"\x93NUMPY\x01\x00\x10\x00{'descr': (((", "not a readable .npy file"),
])
def test_data_verts_of_the_wrong_shape_or_header_is_refused_at_open(tmp_path, content, what):
    with pytest.raises(DataError) as caught:
        _open(tmp_path, verts=content)
    assert str(tmp_path / "data_verts.npy") in str(caught.value) and what in str(caught.value), caught.value


def test_data_verts_flattened_rows_are_still_read(tmp_path):
    flat = np.arange(6 * V * 3, dtype=np.float32).reshape(6, V * 3)
    corpus = _open(tmp_path, verts=flat)
    assert corpus.frames("B", "sentence01").shape == (3, V, 3)


def test_open_rows_reads_only_the_header_of_a_large_file(tmp_path):
    """The shape checks read the header, not the data: opening stays a memory map."""
    path = tmp_path / "data_verts.npy"
    np.save(path, np.zeros((2000, V, 3), dtype=np.float32))
    rows, declared = open_rows(path)
    assert isinstance(rows, np.memmap) and declared == 2000


# ---------------------------------------------------------------------------- subj_seq_to_idx.pkl


@pytest.mark.parametrize("frames, at, what", [
    ({0: 99}, 0, "frame 0 is row 99 of data_verts.npy, which has 6 rows"),
    ({0: 0, 1: -1}, 1, "frame 1 is row -1 of data_verts.npy, which has 6 rows"),
    ({0: 0, 1: 2 ** 70}, 1, f"frame 1 is row {2 ** 70} of data_verts.npy"),
    ({-1: 0, 0: 1}, 0, "frame key -1 is outside 0 to"),
    ({0: 0, 2 ** 64: 1}, 1, f"frame key {2 ** 64} is outside 0 to"),
])
def test_an_index_entry_outside_data_verts_fails_its_sentence_only(tmp_path, frames, at, what):
    index = {"A": {"sentence01": frames}, "B": {"sentence01": {0: 3, 1: 4, 2: 5}}}
    corpus = _open(tmp_path, index=index)
    with pytest.raises(VocasetError) as caught:
        corpus.frames("A", "sentence01")
    assert (caught.value.kind, caught.value.frame) == ("unreadable", at)
    assert "subj_seq_to_idx.pkl" in str(caught.value) and what in str(caught.value), caught.value
    assert corpus.frames("B", "sentence01").shape == (3, V, 3)
    assert ("A", "sentence01", at, "unreadable") in {(p.subject, p.sentence, p.frame, p.kind) for p in corpus.scan()}


def test_a_far_frame_key_reports_its_gap_without_building_the_range(tmp_path):
    corpus = _open(tmp_path, index={"A": {"sentence01": {0: 0, 10 ** 15: 1}}, "B": {"sentence01": {0: 3}}})
    with pytest.raises(VocasetError) as caught:
        corpus.frames("A", "sentence01")
    assert caught.value.kind == "missing_frame" and "[1, 2, 3, 4, 5] missing" in str(caught.value)


@pytest.mark.parametrize("entry", [np.arange(3), [0, 1, 2], "rows", {0: 1.5}, {0: True}])
def test_an_index_entry_that_is_not_a_dict_of_ints_is_a_problem(tmp_path, entry):
    corpus = _open(tmp_path, index={"A": {"sentence01": entry}, "B": {"sentence01": {0: 3, 1: 4, 2: 5}}})
    assert [(p.subject, p.kind) for p in corpus.problems if p.kind == "unreadable"] == [("A", "unreadable")]
    assert corpus.frames("B", "sentence01").shape == (3, V, 3)


def test_two_keys_naming_one_sentence_are_refused(tmp_path):
    index = {"A": {1: {0: 0}, "sentence01": {0: 1}}, "B": {"sentence01": {0: 3}}}
    with pytest.raises(DataError, match=r"subj_seq_to_idx\.pkl: keys 1 and 'sentence01' of 'A' both name sentence01"):
        _open(tmp_path, index=index)


def test_problems_of_one_sentence_with_and_without_a_frame_sort(tmp_path):
    """A sentence missing frame 0 (a problem at a frame) and its audio (a problem of the whole item)."""
    index = {"A": {"sentence01": {1: 0, 2: 1}}, "B": {"sentence01": {0: 3}}}
    audio = {"B": {"sentence01": {"audio": np.zeros(800, dtype=np.int16), "sample_rate": RATE}}}
    corpus = _open(tmp_path, index=index, audio=audio, templates={"B": np.zeros((V, 3))})
    kinds = [(p.subject, p.sentence, p.kind) for p in corpus.scan()]
    assert kinds == [("A", None, "missing_template"), ("A", "sentence01", "missing_audio"),
                     ("A", "sentence01", "missing_frame")]


def test_problem_order_puts_whole_items_first():
    problems = [Problem("A", "s2", 3, "nan", "x"), Problem("A", "s2", None, "missing_audio", "x"),
                Problem("A", None, None, "missing_template", "x"), Problem("A", "s1", 0, "truncated", "x")]
    assert [(p.sentence, p.frame) for p in sorted(problems)] == [(None, None), ("s1", 0), ("s2", None), ("s2", 3)]


def test_frame_gaps_limit():
    assert frame_gaps(np.array([0, 10 ** 15])[:2], limit=3) == [1, 2, 3]
    assert frame_gaps(np.array([0, 2, 5]), limit=2) == [1, 3]
    assert frame_gaps(np.array([0, 2, 5])) == [1, 3, 4]
    started = time.perf_counter()
    frame_gaps(np.array([0, 10 ** 15]), limit=5)
    assert time.perf_counter() - started < 1


# ---------------------------------------------------------------------------- templates.pkl and raw_audio_fixed.pkl


@pytest.mark.parametrize("template, what", [
    ("x", "the entry is a str 'x' (dtype <U1), expected (4, 3) vertex coordinates"),
    ({"v": 1}, "the entry is a dict (dtype object)"),
    ([[0, 0, 0], [0, 0]], "templates.pkl: not an array of vertices"),
    (np.zeros((V, 3), dtype=np.complex64), "dtype complex64"),
])
def test_a_template_that_is_not_numbers_is_a_problem_of_its_speaker(tmp_path, template, what):
    corpus = _open(tmp_path, templates={"A": template, "B": np.zeros((V, 3))})
    with pytest.raises(VocasetError) as caught:
        corpus.template("A")
    assert caught.value.kind == "unreadable" and what in str(caught.value), caught.value
    assert corpus.template("B").shape == (V, 3)


@pytest.mark.parametrize("entry, what", [
    ({"audio": np.zeros(8), "sample_rate": "x"}, "sample_rate is a str 'x', expected a whole number of Hz"),
    ({"audio": np.zeros(8), "sample_rate": float("inf")}, "sample_rate is a float inf"),
    ({"audio": np.zeros(8), "sample_rate": 16000.5}, "sample_rate is a float 16000.5"),
    ({"audio": [[0.0], [0.0, 1.0]], "sample_rate": RATE}, "entry lacks 'audio'/'sample_rate'"),
    ([1, 2], "entry lacks 'audio'/'sample_rate'"),
])
def test_an_audio_entry_of_the_wrong_kind_is_a_problem_of_its_sentence(tmp_path, entry, what):
    audio = {"A": {"sentence01": entry},
             "B": {"sentence01": {"audio": np.zeros(800, dtype=np.int16), "sample_rate": RATE}}}
    corpus = _open(tmp_path, audio=audio)
    with pytest.raises(VocasetError) as caught:
        corpus.audio("A", "sentence01")
    assert caught.value.kind == "unreadable" and what in str(caught.value), caught.value
    assert corpus.audio("B", "sentence01")[1] == RATE


def test_a_whole_float_sample_rate_is_read(tmp_path):
    audio = {s: {"sentence01": {"audio": np.zeros(800, dtype=np.int16), "sample_rate": 16000.0}} for s in ("A", "B")}
    samples, rate = _open(tmp_path, audio=audio).audio("A", "sentence01")
    assert rate == 16000 and isinstance(rate, int)


# ---------------------------------------------------------------------------- synthetic.json


@pytest.mark.parametrize("content, what", [
    (b"NaN", "the synthetic-corpus sidecar is a number, expected a JSON object"),
    (b"[1]", "the synthetic-corpus sidecar is a list"),
    (b"1" * 5000, "a number with more digits than Python reads"),
    (b"[" * 5000, "nested too deeply"),
    (b"\xff{}", "not a readable synthetic-corpus sidecar"),
    (b'{"splits": 5}', "'splits' is a number, expected an object"),
    (b'{"splits": null}', "'splits' is null"),
    (b'{"splits": {"train": 5}}', "split 'train' is a number, expected a list of speaker names"),
    (b'{"splits": {"train": ["A", 1]}}', "split 'train' is a list holding a number"),
    (b'{"splits": {"val": ["A", null]}}', "split 'val' is a list holding null"),
])
def test_a_malformed_sidecar_is_refused_naming_it(tmp_path, content, what):
    (tmp_path / "synthetic.json").write_bytes(content)
    with pytest.raises(DataError) as caught:
        _open(tmp_path)
    assert str(tmp_path / "synthetic.json") in str(caught.value) and what in str(caught.value), caught.value


def test_a_sidecar_with_lists_of_names_gives_its_splits(tmp_path):
    (tmp_path / "synthetic.json").write_text('{"seed": 1, "splits": {"train": ["A"], "val": ["B"], "test": []}}')
    assert read_sidecar(tmp_path / "synthetic.json")["seed"] == 1
    assert _open(tmp_path).splits == {"train": ["A"], "val": ["B"], "test": []}
