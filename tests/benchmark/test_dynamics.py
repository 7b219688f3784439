"""The dynamics family against closed forms: a sine's RMS velocity, a scaled track's ratio
and closeness, static 0 and ground truth 1, silences of a synthetic utterance with
known spans, and vertex rows scored like coefficient rows."""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np
import pytest

from benchmark.evaluation import evaluate_split
from benchmark.evaluation.dynamics import METRICS, dynamics_metrics, utterance_silences
from benchmark.metrics.dynamics import (closeness, energy_ratio, motion_energy, mouth_columns, region_columns,
                                        silent_frames, silent_velocity_frames, squared_speed_sum)
from benchmark.testing import FakeBlendVOCA
from blendvoca.names import BLENDVOCA_NAMES

FPS = 60.0
RATE = 16000
NAMES = tuple(BLENDVOCA_NAMES)
DYNAMICS = list(METRICS)


def test_regions_are_the_arkit_coefficient_sets():
    regions = region_columns(NAMES)
    assert [NAMES[i] for i in regions["jaw"]] == ["jawForward", "jawLeft", "jawRight", "jawOpen"]
    assert all(NAMES[i].startswith("mouth") for i in regions["lips"]) and len(regions["lips"]) == 23
    assert [NAMES[i] for i in regions["upper"]] == ["cheekPuff", "cheekSquintLeft", "cheekSquintRight",
                                                    "noseSneerLeft", "noseSneerRight"]
    assert sorted(mouth_columns(NAMES)) == sorted([*regions["jaw"], *regions["lips"]])
    # ARKit's 52: brows and eyes are upper face; a region without a column is left out
    arkit = ("browInnerUp", "eyeBlinkLeft", "cheekPuff", "jawOpen")
    found = region_columns(arkit)
    assert [arkit[i] for i in found["upper"]] == ["browInnerUp", "eyeBlinkLeft", "cheekPuff"]
    assert "lips" not in found and [arkit[i] for i in found["jaw"]] == ["jawOpen"]


@pytest.mark.parametrize("amplitude, frequency", [(0.3, 2.0), (0.05, 7.5), (1.0, 12.0)])
def test_the_rms_velocity_of_a_sine_is_its_closed_form(amplitude, frequency):
    periods = 5
    frames = round(periods * FPS / frequency) + 1  # whole periods of velocity frames
    t = np.arange(frames)
    track = np.zeros((frames, 3))
    track[:, 1] = 0.5 + amplitude * np.sin(2 * np.pi * frequency * t / FPS)
    expected = FPS * np.sqrt(2) * amplitude * np.sin(np.pi * frequency / FPS)
    assert motion_energy(track, [1], FPS) == pytest.approx(expected, rel=1e-12)
    assert motion_energy(track, [0, 1, 2], FPS) == pytest.approx(expected, rel=1e-12)  # still columns add nothing
    assert motion_energy(track, [0, 2], FPS) == 0.0


def _split(rng, sentences=6):
    truth = {("S", f"sentence{i:02d}"): np.clip(0.3 + 0.2 * rng.standard_normal((120 + 10 * i, len(NAMES))), 0, 1)
             for i in range(sentences)}
    return truth


@pytest.mark.parametrize("a", [0.25, 0.5, 1.5, 3.0])
def test_a_scaled_track_has_ratio_a_and_closeness_one_minus_its_distance(a):
    truth = _split(np.random.default_rng(1))
    generated = {k: (0.5 + a * (v - 0.5))[None] for k, v in truth.items()}  # motion scaled by a
    entries, replicates = dynamics_metrics(truth, generated, NAMES, resamples=50)
    for region in ("lips", "jaw", "upper"):
        assert entries[f"motion_ratio_{region}"]["mean"] == pytest.approx(a, rel=1e-12)
        assert entries[f"motion_closeness_{region}"]["mean"] == pytest.approx(1 - abs(a - 1), rel=1e-12)
        # every resample sees the same scale: a zero-width interval, paired replicates all a
        assert np.allclose(replicates[f"motion_ratio_{region}"], a, rtol=1e-12)
        assert entries[f"motion_ratio_{region}"]["ci95"] == pytest.approx([a, a], rel=1e-12)
    if a > 2:
        assert entries["motion_closeness_lips"]["mean"] < 0  # not clipped at 0


def test_static_scores_zero_and_the_ground_truth_one_exactly():
    truth = _split(np.random.default_rng(2))
    static, _ = dynamics_metrics(truth, {k: np.zeros((1, *v.shape)) for k, v in truth.items()}, NAMES)
    itself, _ = dynamics_metrics(truth, {k: v[None] for k, v in truth.items()}, NAMES)
    for region in ("lips", "jaw", "upper"):
        assert static[f"motion_ratio_{region}"]["mean"] == 0.0
        assert static[f"motion_closeness_{region}"]["mean"] == 0.0
        assert itself[f"motion_ratio_{region}"]["mean"] == 1.0
        assert itself[f"motion_closeness_{region}"]["mean"] == 1.0
        assert itself[f"motion_closeness_{region}"]["ci95"] == [1.0, 1.0]
    assert closeness(0.0) == 0.0 and closeness(1.0) == 1.0 and closeness(2.5) == -0.5


def test_the_ratio_pools_sentences_and_samples():
    """Pooled: sqrt(sum of squared speeds / the truth's), so a sentence that barely moves
    does not dominate, and S samples count as their mean squared speed."""
    truth = {("S", "a"): np.zeros((50, len(NAMES))), ("S", "b"): np.zeros((50, len(NAMES)))}
    jaw = NAMES.index("jawOpen")
    truth[("S", "a")][::2, jaw] = 0.1   # squared speed 0.01 per velocity frame, 49 frames
    truth[("S", "b")][::2, jaw] = 0.01  # 0.0001
    generated = {("S", "a"): np.stack([truth[("S", "a")] * 2, truth[("S", "a")] * 0]),  # mean sq. 2 x truth's
                 ("S", "b"): truth[("S", "b")][None] * 10}                                # 100 x truth's
    with pytest.warns(UserWarning, match="does not move in the (lips|upper) region"):
        entries, _ = dynamics_metrics(truth, generated, NAMES, resamples=20)
    expected = np.sqrt((49 * 0.01 * 2 + 49 * 0.0001 * 100) / (49 * 0.01 + 49 * 0.0001))
    assert entries["motion_ratio_jaw"]["mean"] == pytest.approx(expected, rel=1e-12)
    assert energy_ratio([2.0, 1.0], [1.0, 1.0]) == pytest.approx(np.sqrt(1.5))
    # the truth never moves the lips here: no level to compare with, left out with a warning
    assert "motion_ratio_lips" not in entries and "motion_closeness_lips" not in entries


def _utterance(spans, seconds=3.0, seed=0):
    """Noise 'speech' of ``seconds`` with exact zeros in ``spans`` (seconds)."""
    rng = np.random.default_rng(seed)
    x = 0.3 * rng.standard_normal(int(seconds * RATE))
    for a, b in spans:
        x[int(a * RATE):int(b * RATE)] = 0.0
    return x.astype(np.float32)


def test_silences_of_a_synthetic_utterance_are_found_at_their_spans():
    spans = [(0.0, 0.4), (1.2, 1.5), (2.0, 2.1), (2.7, 3.0)]  # the 0.1 s gap is a closure, not a rest
    frames = int(3.0 * FPS)
    silent = utterance_silences(_utterance(spans), RATE, frames, FPS)
    centre = np.arange(frames) / FPS
    truth = np.zeros(frames, dtype=bool)
    for a, b in spans:
        if b - a >= 0.2:
            truth |= (centre >= a) & (centre < b)
    # the 40 ms envelope window blurs each edge by at most 20 ms, 2 frames at 60 fps
    near_edge = np.zeros(frames, dtype=bool)
    for a, b in spans:
        near_edge |= (np.abs(centre - a) <= 2 / FPS) | (np.abs(centre - b) <= 2 / FPS)
    assert np.array_equal(silent[~near_edge], truth[~near_edge])
    assert silent[int(2.05 * FPS)] == np.False_  # 0.1 s: too short
    # a quieter recording of the same utterance: the threshold is relative to its loudest frame
    assert np.array_equal(utterance_silences(_utterance(spans) * 0.01, RATE, frames, FPS), silent)
    assert not utterance_silences(np.zeros(RATE, np.float32), RATE, 60, FPS).any()  # nothing louder: no silence
    # the rule on an envelope: 40 dB below the loudest frame, runs of at least 0.2 s (12 frames)
    envelope = np.full(40, -10.0)
    envelope[0:12] = -55.0   # 12 frames: a rest
    envelope[20:31] = -70.0  # 11 frames: too short
    envelope[35:40] = -45.0  # 5 frames, and only 35 dB down
    assert np.flatnonzero(silent_frames(envelope, FPS)).tolist() == list(range(12))
    assert silent_frames(envelope, FPS, min_duration=0.1)[20:31].all()
    assert silent_frames(envelope, FPS, threshold_db=30, min_duration=0.05)[35:].all()
    assert np.array_equal(silent_velocity_frames([True, True, False, True, True, True]),
                          [True, False, False, True, True])


@pytest.mark.filterwarnings("ignore:dynamics. the ground truth does not move")
def test_the_silent_lip_ratio_reads_mouth_motion_in_the_silences_only():
    spans = [(0.0, 0.5), (1.5, 2.0)]
    frames = int(2.5 * FPS)
    audio = {("S", "a"): (_utterance(spans, 2.5), RATE)}
    silent = utterance_silences(audio[("S", "a")][0], RATE, frames, FPS)
    jaw, cheek = NAMES.index("jawOpen"), NAMES.index("cheekPuff")
    t = np.arange(frames)
    truth = np.zeros((frames, len(NAMES)))
    truth[:, jaw] = 0.4 + 0.3 * np.sin(2 * np.pi * 4 * t / FPS) * ~silent + 0.01 * np.sin(t) * silent
    row = truth.copy()
    row[silent, jaw] += 0.02 * np.sin(t[silent])  # three times the truth's small motion in the silences
    row[:, cheek] = np.sin(t)  # upper face: not the mouth
    entries, _ = dynamics_metrics({("S", "a"): truth}, {("S", "a"): row[None]}, NAMES, audio)
    frames_v = silent_velocity_frames(silent)
    mouth = mouth_columns(NAMES)
    expected = np.sqrt(squared_speed_sum(row, mouth, frames_v) / squared_speed_sum(truth, mouth, frames_v))
    assert entries["silent_lip_ratio"]["mean"] == pytest.approx(expected, rel=1e-12)
    assert entries["silent_lip_ratio"]["mean"] == pytest.approx(3.0, rel=0.02)
    assert "silent_lip_ratio" not in dynamics_metrics({("S", "a"): truth}, {("S", "a"): row[None]}, NAMES)[0]


def test_evaluate_split_scores_the_dynamics_with_registry_entries():
    ds = FakeBlendVOCA(seed=3, test=2, sentences=3)
    keys = [(s, q) for s in ds.split("test") for q in ds.sentences(s)]
    truth = {k: ds.coeffs(*k) for k in keys}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        own = evaluate_split({k: v[None] for k, v in truth.items()}, ds, "test", metrics=DYNAMICS)
        half = evaluate_split({k: (0.5 * v)[None] for k, v in truth.items()}, ds, "test", metrics=DYNAMICS)
    assert set(own) == set(DYNAMICS) and list(own) == DYNAMICS
    for name in DYNAMICS:
        assert own[name]["mean"] == 1.0 and own[name]["group"] == "dynamics" and own[name]["n"] == len(keys)
        assert len(own[name]["replicates"]) > 0
        assert half[name]["mean"] == pytest.approx(0.5, rel=1e-12)


def test_vertex_rows_and_coefficient_rows_score_the_same_motion_alike():
    """A vertex row is scored through its rig fit (the tracks of ``Generated``), the
    representation both kinds share: the rig's vertices of a scaled track, fitted back,
    give the coefficient row's values."""
    from blendvoca.fit.vertex_tracks import fitted_sample_tracks

    ds = FakeBlendVOCA(seed=5, test=1, sentences=3, tracks="smooth", rig="random")
    keys = [(s, q) for s in ds.split("test") for q in ds.sentences(s)]
    coefficient_row = {k: (0.5 + 0.7 * (ds.coeffs(*k) - 0.5))[None] for k in keys}
    vertices, fits = {}, {}
    for k, tracks in coefficient_row.items():
        rig = ds.rig(k[0]).select(ds.names)
        vertices[k] = rig.neutral[None, None] + np.einsum("stk,kvd->stvd", tracks, rig.deltas)
        fits[k] = fitted_sample_tracks(vertices[k], ds.rig(k[0]), ds.names)
    wanted = [n for n in DYNAMICS if n != "silent_lip_ratio"]  # noise audio: no silences
    coefficients = evaluate_split(coefficient_row, ds, "test", metrics=wanted)
    vertex_row = evaluate_split(SimpleNamespace(tracks=fits, vertices=vertices), ds, "test", metrics=wanted)
    for name in wanted:
        assert vertex_row[name]["mean"] == pytest.approx(coefficients[name]["mean"], abs=1e-4)
    assert coefficients["motion_ratio_jaw"]["mean"] == pytest.approx(0.7, rel=1e-12)
