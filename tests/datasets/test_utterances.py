"""Cutting long takes into utterances (blendvoca.datasets.utterances): ground truth from synthetic takes
whose pauses are known, the length limits, the user's cut list and its refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

from blendvoca.datasets.utterances import (
    MAX_S,
    MIN_S,
    CutListError,
    ShortTakeError,
    Span,
    check_cut_list,
    motion_speed,
    read_cut_list,
    speech_activity,
    take_spans,
)
from blendvoca.errors import DataError

RATE, FPS = 16000, 60.0


def synthetic_take(seed: int, sentences: int = 8, lengths=(4.0, 8.0), pause=(0.6, 0.9)):
    """A take of ``sentences`` sentences of syllables (noise bursts, 0.2-0.35 s, 0.05-0.12 s apart: not
    pauses) with long pauses between them; the jaw follows each syllable and rests in the pauses.

    Returns ``(track (T, 3), samples (N,), pauses [(start_s, end_s)])``: the pauses between sentences,
    the ground truth a cut must fall in.
    """
    rng = np.random.default_rng(seed)
    events, t = [], 0.8  # (start, end) of every syllable, leading silence 0.8 s
    pauses = []
    for k in range(sentences):
        end_of_sentence = t + rng.uniform(*lengths)
        while t < end_of_sentence:
            length = rng.uniform(0.2, 0.35)
            events.append((t, t + length))
            t += length + rng.uniform(0.05, 0.12)
        if k < sentences - 1:
            gap = rng.uniform(*pause)
            pauses.append((events[-1][1], events[-1][1] + gap))
            t = events[-1][1] + gap
    seconds = events[-1][1] + 0.7
    samples = 1e-4 * rng.standard_normal(int(seconds * RATE))
    frames = int(seconds * FPS)
    jaw = np.zeros(frames)
    for start, end in events:
        a, b = int(start * RATE), int(end * RATE)
        samples[a:b] += 0.3 * rng.standard_normal(b - a) * np.hanning(b - a)
        fa, fb = int(start * FPS), int(np.ceil(end * FPS))
        jaw[fa:fb] = np.maximum(jaw[fa:fb], np.sin(np.linspace(0, np.pi, fb - fa)) * rng.uniform(0.3, 0.8))
    track = np.stack([jaw, 0.5 * jaw, 0.2 * jaw], axis=1)
    return track, samples.astype(np.float32), pauses


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cuts_fall_in_the_known_pauses_and_every_pause_is_cut(seed):
    track, samples, pauses = synthetic_take(seed)
    spans = take_spans(track, samples, RATE, FPS, where="synthetic")
    cuts = [s.end for s in spans[:-1]]
    assert [s.start for s in spans[1:]] == cuts and spans[0].start == 0 and spans[-1].end == len(track)
    inside = [[a * FPS <= c <= b * FPS for a, b in pauses] for c in cuts]
    assert all(any(row) for row in inside), (cuts, pauses)  # every cut is in a pause
    assert all(any(row[k] for row in inside) for k in range(len(pauses)))  # every pause (4-8 s apart) is cut
    assert {s.cut for s in spans[:-1]} == {"pause"} and spans[-1].cut == "end"
    lengths = [(s.end - s.start) / FPS for s in spans]
    assert MIN_S <= min(lengths) and max(lengths) <= MAX_S


def test_speech_activity_finds_the_syllables_and_bridges_the_gaps_between_them():
    track, samples, pauses = synthetic_take(3)
    active = speech_activity(samples, RATE, FPS, len(track))
    for a, b in pauses:  # silent through each pause, less a frame at each edge (window)
        assert not active[int(a * FPS) + 2: int(b * FPS) - 2].any()
    spoken = track[:, 0] > 0.05
    assert active[spoken].mean() > 0.99  # where the jaw moves, the audio speaks


def test_the_cut_is_where_the_motion_is_still_within_the_pause():
    track, samples, pauses = synthetic_take(4, sentences=3, lengths=(5.0, 6.0), pause=(0.8, 0.8))
    a, b = (int(x * FPS) for x in pauses[0])
    # the mouth keeps closing through the first 60 % of the first pause, silent audio
    closing = int(0.6 * (b - a))
    track[a:a + closing, 0] = np.linspace(0.6, 0.0, closing)
    spans = take_spans(track, samples, RATE, FPS, where="synthetic")
    first = spans[0].end
    assert a + closing - 2 <= first <= b
    assert motion_speed(track, FPS)[first] < 1e-9


def test_speech_without_pauses_is_cut_at_forced_points_within_the_limits():
    rng = np.random.default_rng(5)
    seconds = 25.0
    samples = (0.3 * rng.standard_normal(int(seconds * RATE))).astype(np.float32)
    track = rng.random((int(seconds * FPS), 3))
    spans = take_spans(track, samples, RATE, FPS, where="continuous")
    lengths = [(s.end - s.start) / FPS for s in spans]
    assert len(spans) >= 3 and MIN_S <= min(lengths) and max(lengths) <= MAX_S
    assert {s.cut for s in spans[:-1]} == {"forced"}


def test_short_takes_fail_in_a_corpus_of_long_takes_and_stay_whole_otherwise():
    track, samples = np.zeros((90, 3)), np.zeros(24000, dtype=np.float32)
    with pytest.raises(ShortTakeError, match=r"short\.npy: 1\.50 s long, shorter than one utterance \(2 s\)"):
        take_spans(track, samples, RATE, FPS, where="short.npy")
    assert take_spans(track, samples, RATE, FPS, where="short.npy", long_take=False) == [Span(0, 90, "end")]
    whole = take_spans(np.zeros((480, 3)), np.zeros(128000, dtype=np.float32), RATE, FPS, where="8 s")
    assert [(s.start, s.end, s.cut) for s in whole] == [(0, 480, "end")]


def test_a_user_cut_list_is_honoured(tmp_path):
    path = tmp_path / "cuts.json"
    path.write_text(json.dumps({"take_a": [1.5, 4.25, 12.0], "take_b": []}))
    cuts = read_cut_list(path)
    assert cuts == {"take_a": (1.5, 4.25, 12.0), "take_b": ()}
    check_cut_list(cuts, ["take_a", "take_b", "take_c"], path=path)
    track, samples, _ = synthetic_take(6, sentences=3)
    spans = take_spans(track, samples, RATE, FPS, where="a", cuts_s=cuts["take_a"])
    assert [(s.start, s.end, s.cut) for s in spans] == [
        (0, 90, "user"), (90, 255, "user"), (255, 720, "user"), (720, len(track), "end")]
    assert [(s.start, s.end) for s in take_spans(track, samples, RATE, FPS, where="b", cuts_s=())] == [
        (0, len(track))]


@pytest.mark.parametrize("content, message", [
    ("{not json", "not JSON"),
    ("[1.0, 2.0]", "a JSON list; expected a JSON object of take name"),
    ('{"a": "1.0"}', "take 'a': '1.0' is not a list of numbers"),
    ('{"a": [true]}', "is not a list of numbers"),
    ('{"a": [3.0, 2.0]}', "are not positive and increasing"),
    ('{"a": [-1.0]}', "are not positive and increasing"),
    ('{"a": [1.0, 1.0]}', "are not positive and increasing"),
])
def test_bad_cut_lists_are_refused_naming_the_file(tmp_path, content, message):
    path = tmp_path / "cuts.json"
    path.write_text(content)
    with pytest.raises(CutListError, match="cuts.json") as info:
        read_cut_list(path)
    assert message in str(info.value)


def test_a_cut_list_naming_an_unknown_take_or_cutting_outside_one_is_refused(tmp_path):
    with pytest.raises(CutListError, match=r"takes not in the corpus: \['nope'\]; its takes are \['a', 'b'\]"):
        check_cut_list({"nope": (1.0,)}, ["a", "b"], path="cuts.json")
    with pytest.raises(CutListError, match="not readable"):
        read_cut_list(tmp_path / "missing.json")
    track, samples = np.zeros((300, 3)), np.zeros(80000, dtype=np.float32)
    with pytest.raises(DataError, match=r"take\.npy: the cut list cuts at 6\.0 s, outside the take \(0 to 5\.00 s\)"):
        take_spans(track, samples, RATE, FPS, where="take.npy", cuts_s=(2.0, 6.0))
    with pytest.raises(DataError, match="two cuts of the cut list fall on the same frame"):
        take_spans(track, samples, RATE, FPS, where="take.npy", cuts_s=(2.0, 2.001))
