import numpy as np
import pytest

from baselines.regression.features import resampled_features
from baselines.regression.mel import (
    hz_to_mel,
    log_mel_spectrogram,
    mel_filterbank,
    mel_to_hz,
)
from baselines.regression.training import window_batch
from benchmark.methods import Budget, TrainingRequest, Utterance, get_method
from benchmark.protocol import generated_tracks

from .fakes import fake_evaluate, speech_dataset

SMALL = {"steps": 100, "channels": 16, "hidden": 16, "batch": 8, "window": 40}


def test_mel_filterbank_matches_transformers_reference():
    audio_utils = pytest.importorskip("transformers.audio_utils")
    ours = mel_filterbank(40, 512, 16000, fmin=0.0, fmax=8000.0)
    ref = audio_utils.mel_filter_bank(num_frequency_bins=257, num_mel_filters=40, min_frequency=0.0,
                                      max_frequency=8000.0, sampling_rate=16000, norm=None, mel_scale="htk")
    np.testing.assert_allclose(ours, ref, atol=1e-10)


def test_mel_scale_round_trip():
    hz = np.array([0.0, 100.0, 1000.0, 7999.0])
    np.testing.assert_allclose(mel_to_hz(hz_to_mel(hz)), hz)
    assert hz_to_mel(1000.0) == pytest.approx(1000.0, abs=0.5)  # HTK: 1 kHz ~ 1000 mel


def test_log_mel_of_a_tone_peaks_in_its_band():
    rate, f0 = 16000, 1000.0
    t = np.arange(rate) / rate
    spec = log_mel_spectrogram(np.sin(2 * np.pi * f0 * t), rate=rate, n_mels=40)
    assert spec.shape == (1 + rate // 160, 40)
    centres = mel_to_hz(np.linspace(hz_to_mel(0), hz_to_mel(rate / 2), 42))[1:-1]
    assert spec[10:-10].mean(axis=0).argmax() == np.abs(centres - f0).argmin()
    with pytest.raises(ValueError, match="mono"):
        log_mel_spectrogram(np.zeros((2, 100)))


def test_resampled_features_exact_on_linear_signal():
    src = np.arange(101, dtype=np.float64)[:, None] * np.array([[1.0, -2.0]])  # value = 100 * time
    out = resampled_features(src, 60, feature_fps=100, fps=60)
    np.testing.assert_allclose(out[:, 0], 100 * np.arange(60) / 60, rtol=1e-6)
    # held at the edge beyond the last feature frame
    assert resampled_features(src[:2], 5, feature_fps=100)[-1, 0] == pytest.approx(1.0)


def test_window_batch_aligned():
    rng = np.random.default_rng(0)
    feats = [np.arange(50.0)[:, None].repeat(3, 1), np.arange(10.0)[:, None].repeat(3, 1)]
    targets = [f[:, :2] * 2 for f in feats]
    x, y = window_batch(rng, feats, targets, batch=6, window=20)
    assert x.shape == (6, 20, 3) and y.shape == (6, 20, 2)
    np.testing.assert_array_equal(y, 2 * x[..., :2])


@pytest.fixture(scope="module")
def dataset():
    return speech_dataset(seed=2, sentences=3, seconds=1.5, train=("A", "B", "C"), val=("F",), test=("D", "E"))


@pytest.fixture(scope="module")
def trained(dataset):
    method = get_method("regression")(**SMALL)
    method.train(dataset, TrainingRequest(seed=0, budget=Budget()))
    return method


def test_regression_learns_speech_driven_motion(dataset, trained):
    """jawOpen follows the audio envelope: the regression must beat the mean baseline."""
    mean = get_method("mean")()
    mean.train(dataset, TrainingRequest(seed=0, budget=Budget()))
    reg_out, _ = generated_tracks(trained, dataset)
    mean_out, _ = generated_tracks(mean, dataset)
    assert fake_evaluate(reg_out, dataset)["coeff_mse"]["mean"] < 0.5 * fake_evaluate(mean_out, dataset)["coeff_mse"]["mean"]
    assert trained.history["steps"] == SMALL["steps"]


def test_regression_deterministic_with_seed_and_budget(dataset):
    runs = []
    for seed in (0, 0, 1):
        method = get_method("regression")(**SMALL)
        method.train(dataset, TrainingRequest(seed=seed, budget=Budget(max_steps=5)))
        assert method.history["steps"] == 5
        runs.append([v.numpy().copy() for v in method.model.state_dict().values()])
    assert all(np.array_equal(a, b) for a, b in zip(runs[0], runs[1]))
    assert not all(np.array_equal(a, b) for a, b in zip(runs[0], runs[2]))


def test_regression_save_load_same_output(dataset, trained, tmp_path):
    trained.save(tmp_path)
    loaded = get_method("regression").load(tmp_path)
    audio, _ = dataset.audio("D", "sentence01")
    utterance = Utterance(subject="D", sentence="sentence01", split="test", audio=audio, num_frames=90)
    a = trained.generate(utterance, samples=2)
    b = loaded.generate(utterance, samples=2)
    assert a.shape == (2, 90, 32) and (a >= 0).all() and (a <= 1).all()
    np.testing.assert_array_equal(a, b)
