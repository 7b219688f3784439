"""Property-based fuzzing of the coefficient adapters' readers (issue 56, deliverable 7): BEAT's
facial JSON, UniTalker's layout (its split JSON and .npy files), FACEGOOD's names and values and
the Live Link Face CSV.

Any bytes give either a valid result or an error of the project's tree (``DataError`` /
``UserError``; never an IndexError, OverflowError, AttributeError, ...); a result the build
takes on (:func:`blendvoca.datasets.coefficients.take_track`) is then a track or a tree error too.
Derandomized, few examples, no deadline per example (a cold import or file system is not a
failure), a pytest-timeout per test.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

from blendvoca.datasets.coefficients import FPS_RANGE, take_track
from tests.faults.test_fuzz_readers import TREE_ERRORS, json_files, mutated, outcome, structured_csv

FUZZ = settings(max_examples=60, deadline=None, derandomize=True, phases=list(Phase),
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large])


def _npy(array) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    return buffer.getvalue()


def _built(result, where) -> None:
    """A reader's ``(weights, names, fps)`` as the build takes it on: a track or a tree error."""
    weights, names, fps = result
    assert isinstance(weights, np.ndarray) and weights.ndim == 2 and len(names) == weights.shape[1]
    track = outcome(take_track, weights, names, fps, where=where)
    if not isinstance(track, Exception):
        coeffs, columns, _ = track
        assert FPS_RANGE[0] <= float(fps) <= FPS_RANGE[1]
        assert coeffs.shape[1] == len(columns) and np.all(np.isfinite(coeffs))


# ---------------------------------------------------------------------------- BEAT facial JSON

_BEAT = {"names": ["jawOpen", "mouthClose", "eyeBlinkLeft"],
         "frames": [{"time": t / 60, "weights": [0.1 * t, 0.2, 0.0]} for t in range(4)]}


@FUZZ
@given(data=json_files(_BEAT))
@example(data=json.dumps({**_BEAT, "frames": [{"time": 0, "weights": [[1, 2], [3, 4], [5, 6]]},
                                               {"time": 1, "weights": [[1, 2], [3, 4], [5, 6]]}]}).encode())
@example(data=b'{"names": ["jawOpen"], "frames": [{"time": 0, "weights": [1' + b"0" * 400 + b']}, '
              b'{"time": 1, "weights": [0]}]}')
@example(data=b'{"names": ["jawOpen"], "frames": [{"time": 0, "weights": [0]}, {"time": 1e-300, "weights": [0]}]}')
@example(data=b'{"names": ["jawOpen"], "frames": [{"time": true, "weights": [0]}, {"time": 2, "weights": [0]}]}')
@pytest.mark.timeout(120)
def test_beat_json_reader_gives_weights_or_a_tree_error(tmp_path, data):
    from blendvoca.datasets.beat import read_beat_json

    path = tmp_path / "1_wayne_0_1_1.json"
    path.write_bytes(data)
    result = outcome(read_beat_json, path)
    if isinstance(result, Exception):
        assert str(path) in str(result), result
    else:
        _built(result, str(path))


# ---------------------------------------------------------------------------- UniTalker's layout

_ITEM = {"annot_path": "annot/a_000.npy", "audio_path": "audio/a_000.npy", "id": 0,
         "annot_type": "inhouse_blendshape_weight", "dataset": "D6", "fps": 30}
_SPLIT = {"info": {"id_list": ["a", "b"]}, "data": [_ITEM, {**_ITEM, "id": 1}]}


def _unitalker_root(tmp_path) -> Path:
    root = tmp_path / "d6"
    (root / "annot").mkdir(parents=True, exist_ok=True)
    (root / "audio").mkdir(exist_ok=True)
    np.save(root / "annot" / "a_000.npy", np.full((30, 51), 0.25, dtype=np.float32))
    np.save(root / "audio" / "a_000.npy", np.zeros(16000, dtype=np.float32))
    return root


def _read_layout(root):
    from blendvoca.datasets.unitalker import unitalker_layout_takes

    takes = unitalker_layout_takes(root, annot_type="inhouse_blendshape_weight", convention="unitalker51")
    return [(take, outcome(take.weights), outcome(take.audio)) for take in takes[:3]]


@FUZZ
@given(data=json_files(_SPLIT))
@example(data=json.dumps({**_SPLIT, "data": [{**_ITEM, "annot_path": "."}]}).encode())
@example(data=json.dumps({**_SPLIT, "data": [{**_ITEM, "annot_path": "annot/\u0000.npy"}]}).encode())
@example(data=json.dumps({**_SPLIT, "data": [{**_ITEM, "fps": 1e400}]}).replace("Infinity", "1e999").encode())
@example(data=json.dumps({**_SPLIT, "data": [{**_ITEM, "id": 1e300}]}).encode())
@pytest.mark.timeout(120)
def test_unitalker_layout_reader_gives_takes_or_a_tree_error(tmp_path, data):
    root = _unitalker_root(tmp_path)
    (root / "train.json").write_bytes(data)
    result = outcome(_read_layout, root)
    if isinstance(result, Exception):
        assert str(root) in str(result), result
        return
    for take, weights, audio in result:
        assert take.subject and "/" not in take.subject
        if not isinstance(weights, Exception):
            _built(weights, take.source)
        if not isinstance(audio, Exception):
            assert audio[0].ndim == 1 and audio[1] == 16000


@FUZZ
@given(data=st.one_of(mutated(_npy(np.full((4, 51), 0.5, dtype=np.float32))), st.binary(max_size=120)),
       which=st.sampled_from(["annot", "audio"]))
@example(data=b"PK\x03\x04" + bytes(40), which="annot")
@example(data=_npy(np.array(["x"] * 51)[None]), which="annot")
@example(data=_npy(np.zeros((2, 51), dtype=complex)), which="annot")
@pytest.mark.timeout(120)
def test_unitalker_npy_files_give_arrays_or_a_tree_error(tmp_path, data, which):
    from blendvoca.datasets.unitalker import read_audio, read_weights
    from blendvoca.names import convention_names

    path = tmp_path / f"{which}.npy"
    path.write_bytes(data)
    if which == "annot":
        result = outcome(read_weights, path, convention_names("unitalker51"), 30.0)
    else:
        result = outcome(read_audio, path)
    if isinstance(result, Exception):
        assert str(path) in str(result), result
    elif which == "annot":
        _built(result, str(path))
    else:
        assert result[0].ndim == 1 and result[0].dtype == np.float32


# ---------------------------------------------------------------------------- FACEGOOD


@FUZZ
@given(data=st.data(), which=st.sampled_from(["names", "values"]))
@pytest.mark.timeout(120)
def test_facegood_readers_give_controls_or_a_tree_error(tmp_path, data, which):
    from blendvoca.datasets.facegood import read_names, read_values
    from blendvoca.names import FACEGOOD116

    names_path, values_path = tmp_path / "bs_names_1015.npy", tmp_path / "bs_value_x.npy"
    names_file = _npy(np.array(FACEGOOD116))
    values_file = _npy(np.full((3, len(FACEGOOD116)), 0.5))
    base = names_file if which == "names" else values_file
    content = data.draw(st.one_of(mutated(base), st.binary(max_size=120)), label="file")
    names_path.write_bytes(content if which == "names" else names_file)
    values_path.write_bytes(content if which == "values" else values_file)
    names = outcome(read_names, names_path)
    if isinstance(names, Exception):
        assert str(names_path) in str(names), names
        return
    assert all(isinstance(n, str) for n in names) and len(set(names)) == len(names)
    result = outcome(read_values, values_path, names, names_path)
    if isinstance(result, Exception):
        assert "bs_value_x.npy" in str(result) or "bs_names_1015.npy" in str(result), result
    else:
        _built(result, str(values_path))


# ---------------------------------------------------------------------------- Live Link Face CSV


def _livelink_csv() -> bytes:
    from blendvoca.io.livelink import format_livelink_csv
    from blendvoca.names import ARKIT_FACE_ORDER

    t = np.arange(70)[:, None] / 60
    return format_livelink_csv(0.5 + 0.4 * np.sin(t + np.arange(52)), ARKIT_FACE_ORDER, 60.0).encode()


@FUZZ
@given(data=st.one_of(mutated(_livelink_csv()), structured_csv, st.binary(max_size=120)))
@example(data=_livelink_csv().replace(b",0.", b",9" + b"9" * 400 + b".", 1))
@pytest.mark.timeout(120)
def test_livelink_reader_gives_a_take_or_a_tree_error(tmp_path, data):
    from blendvoca.io.livelink import read_livelink_take

    path = tmp_path / "take.csv"
    path.write_bytes(data)
    for fps in (None, 60.0):
        take = outcome(read_livelink_take, path, fps=fps)
        if isinstance(take, Exception):
            assert str(path) in str(take), take
        else:
            assert take.weights.ndim == 2 and take.weights.shape[1] == len(take.names) and take.fps > 0
            _built((take.weights, take.names, take.fps), str(path))


def test_the_seeds_of_the_fuzzing_read(tmp_path):
    """The valid files the fuzzing mutates read to tracks (the properties test results, not only refusals)."""
    from blendvoca.datasets.beat import read_beat_json
    from blendvoca.io.livelink import read_livelink_take

    (tmp_path / "b.json").write_text(json.dumps(_BEAT))
    weights, names, fps = read_beat_json(tmp_path / "b.json")
    assert weights.shape == (4, 3) and fps == 60.0
    (take, (weights, names, fps), (audio, rate)), = _read_layout(_write_split(tmp_path, _SPLIT))[:1]
    assert weights.shape == (30, 51) and fps == 30.0 and len(audio) == rate == 16000 and take.subject == "a"
    (tmp_path / "t.csv").write_bytes(_livelink_csv())
    assert read_livelink_take(tmp_path / "t.csv").weights.shape == (70, 52)


def _write_split(tmp_path, doc) -> Path:
    root = _unitalker_root(tmp_path)
    (root / "train.json").write_text(json.dumps(doc))
    return root
