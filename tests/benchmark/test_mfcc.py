import numpy as np
import pytest

from benchmark.lipsync.mfcc import mel_filterbank, mfcc


def test_matches_python_speech_features():
    psf = pytest.importorskip("python_speech_features")
    rng = np.random.default_rng(0)
    t = np.arange(16000) / 16000
    x = (8000 * np.sin(2 * np.pi * 220 * t) * (1 + np.sin(2 * np.pi * 3 * t)) + 500 * rng.normal(size=t.size))
    ours = mfcc(x, 16000)
    ref = psf.mfcc(x, 16000)
    assert ours.shape == ref.shape == (99, 13)  # 1 + ceil((16000 - 400) / 160)
    np.testing.assert_allclose(ours, ref, rtol=1e-8, atol=1e-8)


def test_frame_rate_and_filterbank():
    assert mfcc(np.ones(16000 * 2), 16000).shape == (199, 13)
    bank = mel_filterbank()
    assert bank.shape == (26, 257)
    assert np.all(bank >= 0) and np.all(bank.max(axis=1) <= 1)
