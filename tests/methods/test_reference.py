import numpy as np
import pytest

from baselines.common.track_lookup import fit_track_length
from baselines.bounds.mean import mean_coefficients
from baselines.bounds.random_walk import random_tracks
from benchmark.methods import Budget, TrainingRequest, Utterance, get_method
from benchmark.protocol import generated_tracks

from .fakes import speech_dataset


@pytest.fixture(scope="module")
def dataset():
    return speech_dataset(seed=1, sentences=2, seconds=1.0)


def test_ground_truth_returns_the_dataset_tracks_and_round_trips(dataset, tmp_path):
    gt = get_method("ground-truth")()
    gt.train(dataset, TrainingRequest(seed=0, budget=Budget()))
    generated, _ = generated_tracks(gt, dataset)
    for (subject, sentence), tracks in generated.items():
        np.testing.assert_array_equal(tracks[0], dataset.coeffs(subject, sentence))
    gt.save(tmp_path)
    loaded = get_method("ground-truth").load(tmp_path)
    again, _ = generated_tracks(loaded, dataset)
    assert all(np.array_equal(again[k], generated[k]) for k in generated)


def _utterance(subject="D", sentence="sentence01", num_frames=5):
    return Utterance(subject=subject, sentence=sentence, split="test", audio=np.zeros(100, np.float32),
                     num_frames=num_frames)


def test_ground_truth_unknown_sentence_is_explained(dataset):
    gt = get_method("ground-truth")()
    gt.train(dataset, TrainingRequest(seed=0, budget=Budget()))
    with pytest.raises(KeyError, match="no stored track for D/sentence99"):
        gt.generate(_utterance(sentence="sentence99"))


def test_mean_is_frame_weighted_mean(dataset, tmp_path):
    tracks = [np.ones((2, 3)), np.zeros((6, 3))]
    np.testing.assert_allclose(mean_coefficients(tracks), np.full(3, 0.25))
    mean = get_method("mean")()
    mean.train(dataset, TrainingRequest(seed=0, budget=Budget()))
    all_train = np.concatenate([dataset.coeffs(s, q) for s in dataset.split("train") for q in dataset.sentences(s)])
    np.testing.assert_allclose(mean.mean_, all_train.mean(axis=0))
    out = mean.generate(_utterance(num_frames=4), samples=1)
    assert out.shape == (1, 4, 32)
    mean.save(tmp_path)
    np.testing.assert_allclose(get_method("mean").load(tmp_path).mean_, mean.mean_)


def test_static_is_zero():
    out = get_method("static")().generate(_utterance(num_frames=4), samples=2)
    assert out.shape == (2, 4, 32) and not out.any()


def test_random_tracks_bounds_and_seed():
    a = random_tracks(np.random.default_rng(0), 3, 50, 32, scale=0.3)
    b = random_tracks(np.random.default_rng(0), 3, 50, 32, scale=0.3)
    assert a.shape == (3, 50, 32) and a.min() >= 0 and a.max() <= 0.3
    np.testing.assert_array_equal(a, b)


def test_length_fitting():
    t = np.arange(10.0)[:, None]
    assert fit_track_length(t, 8, max_mismatch=2, where="w").shape == (8, 1)
    padded = fit_track_length(t, 12, max_mismatch=2, where="w")
    assert padded.shape == (12, 1) and padded[-1, 0] == 9
    with pytest.raises(ValueError, match="w: track has 10 frames, expected 13"):
        fit_track_length(t, 13, max_mismatch=2, where="w")
