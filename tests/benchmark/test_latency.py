"""Latency in the protocol: measured by the runner, stored beside the metrics (not compared
by reruns), shown as the tables' and the site's RTF column."""

import json
import time

import numpy as np
import pytest

from benchmark.methods import Budget, Method
from benchmark.protocol import RunSpec, run
from benchmark.protocol.generation import measure_latency
from benchmark.results import LATENCY_FIELDS, LOOKAHEAD_FIELDS, build_result, check
from tests.methods.fakes import fake_evaluate, speech_dataset


class ChunkedSleeper(Method):
    """Zeros after a sleep of ``base + per_second * audio seconds``; declares a look-ahead."""

    name = "chunked-sleeper"
    lookahead_s = 0.5

    def __init__(self, base=0.02, per_second=0.05):
        super().__init__()
        self.base, self.per_second, self.calls = base, per_second, []

    contract = 3

    def train(self, dataset, request):
        pass

    def generate(self, utterance, *, samples=1, seed=0):
        self.calls.append((utterance.num_frames, utterance.audio.shape[0], samples, seed))
        time.sleep(self.base + self.per_second * utterance.duration)
        return np.zeros((samples, utterance.num_frames, 32))


def test_measure_latency_times_the_first_chunk_and_whole_sentences():
    dataset = speech_dataset(seed=1, sentences=2, seconds=1.0)
    method = ChunkedSleeper()
    latency = measure_latency(method, dataset, split="test", seed=0, sentences=2)
    assert tuple(latency) == LATENCY_FIELDS + LOOKAHEAD_FIELDS and latency["lookahead_s"] == 0.5
    # first: the first 0.5 s (30 frames, 8000 samples) alone; then the two whole sentences, one sample each
    assert method.calls[0][:3] == (30, 8000, 1)
    assert [c[0] for c in method.calls[1:3]] == [dataset.coeffs("D", s).shape[0] for s in dataset.sentences("D")]
    # then the look-ahead probe: the first sentence again, then two calls per cut (one cut per sentence)
    assert len(method.calls) == 3 + latency["lookahead_probe"]["generate_calls"] == 3 + 1 + 2 * 2
    assert all(c[2] == 1 for c in method.calls)
    assert method.calls[0][3] == method.calls[1][3]  # the run's seed for the sentence
    assert 0.02 + 0.05 * 0.5 <= latency["first_frame_s"] < 0.02 + 0.05 * 1.2 + 0.5
    # wall time per audio second: at least the sleep's, and a sleeping process spends little CPU
    assert latency["rtf"] >= 0.05 + 0.02 / 1.2 - 1e-3
    assert latency["compute_per_audio_s"] < latency["rtf"]


def test_a_method_that_does_not_say_needs_the_whole_utterance():
    dataset = speech_dataset(seed=1, sentences=1, seconds=1.0)
    method = ChunkedSleeper(base=0.0, per_second=0.0)
    method.lookahead_s = None
    latency = measure_latency(method, dataset, sentences=1)
    assert latency["lookahead_s"] is None
    assert method.calls[0][0] == method.calls[1][0] == dataset.coeffs("D", "sentence01").shape[0]


def test_the_runner_stores_latency_and_reruns_compare_without_it(tmp_path):
    dataset = speech_dataset(seed=1, sentences=2, seconds=1.0)
    paths = [run(RunSpec("random", data_root="unused", samples=2, seed=3, budget=Budget(max_steps=2),
                         results_dir=tmp_path / name),
                 evaluate=fake_evaluate, open_dataset=lambda root: dataset) for name in ("a", "b")]
    a, b = (json.loads(p.read_text()) for p in paths)
    for result in (a, b):
        assert set(result["latency"]) == set(LATENCY_FIELDS + LOOKAHEAD_FIELDS)
        assert result["latency"]["lookahead_s"] is None  # the random walk takes the utterance whole
        assert result["latency"]["measured_lookahead_s"] == 0.0  # ... and listens to none of it
        assert result["latency"]["rtf"] >= 0 and result["latency"]["first_frame_s"] >= 0
    # what a rerun must reproduce is the same; the latency is the machine's and may differ
    assert a["metrics"] == b["metrics"] and a["per_sentence"] == b["per_sentence"]


def test_result_files_check_the_latency_record():
    base = {"method": {"name": "m", "config": {}}, "dataset": {"manifest_hash": "h"}, "protocol": {},
            "metrics": {"fd": {"mean": 1.0, "std": 0.0, "higher_is_better": False, "unit": ""}}, "timings": {},
            "provenance": {}}
    assert "latency" not in build_result(**base).to_json()  # results written before it have none, and stay valid
    result = build_result(**base, latency={"lookahead_s": None, "first_frame_s": 0.123456, "compute_per_audio_s": 1,
                                           "rtf": 0.5}).to_json()
    assert result["latency"] == {"lookahead_s": None, "first_frame_s": 0.1235, "compute_per_audio_s": 1.0, "rtf": 0.5}
    for bad in ({"rtf": -1.0}, {"rtf": "fast"}, {"speed": 1.0}, [0.5]):
        with pytest.raises(ValueError, match="latency"):
            check({**result, "latency": bad})


def test_tables_show_a_real_time_factor_column(tmp_path):
    from leaderboard.build import build_leaderboard
    from tests.leaderboard.test_build import _result, write_result

    old = _result("old", "h1", {"fd": (2.0, 0.1, False, "latent^2", (1.9, 2.1))})
    new = _result("new", "h1", {"fd": (1.0, 0.1, False, "latent^2", (0.9, 1.1))})
    new["latency"] = {"lookahead_s": 10.0, "first_frame_s": 1.5, "compute_per_audio_s": 0.9, "rtf": 0.4567}
    for result in (old, new):
        write_result(result, tmp_path / "results")
    md, tex = (p.read_text() for p in build_leaderboard(tmp_path / "results", tmp_path / "tables"))
    header = next(line for line in md.splitlines() if line.startswith("| Method"))
    assert header.endswith("| S | RTF |")
    assert any(line.startswith("| new |") and line.endswith("| 1 | 0.457 |") for line in md.splitlines())
    assert any(line.startswith("| old |") and line.endswith("| 1 | - |") for line in md.splitlines())
    assert r"$S$ & RTF \\" in tex and r"& 1 & 0.457 \\" in tex and r"& 1 & - \\" in tex
