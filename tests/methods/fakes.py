"""An in-memory stand-in for ``benchmark.data.open_blendvoca(...)`` whose motion is
a known function of its audio, and a fake evaluate function."""

from __future__ import annotations

import numpy as np

from blendvoca.names import BLENDVOCA_NAMES

RATE = 16000
FPS = 60


def envelope_audio(rng, seconds):
    """Noise bursts at syllable rate: the 60 fps target is their smoothed envelope.

    Returns (audio (N,) float32, envelope (T,) in [0, 1]).
    """
    n_frames = round(seconds * FPS)
    # piecewise syllables of random length and loudness
    env = np.zeros(n_frames)
    t = 0
    while t < n_frames:
        length = int(rng.integers(8, 25))
        if rng.random() < 0.7:
            env[t:t + length] = np.sin(np.linspace(0, np.pi, min(length, n_frames - t))) * rng.uniform(0.4, 1.0)
        t += length
    samples_per_frame = RATE / FPS
    n = round(n_frames * samples_per_frame)
    amp = np.interp(np.arange(n) / samples_per_frame, np.arange(n_frames), env)
    audio = (amp * rng.standard_normal(n) * 0.3).astype(np.float32)
    return audio, env


class FakeDataset:
    """Subjects, splits, 32-coefficient tracks and audio; jawOpen follows the audio envelope."""

    def __init__(self, seed=0, n_sentences=3, seconds=2.0, train=("A", "B"), val=("C",), test=("D", "E"),
                 manifest_hash="fakehash0123456789"):
        rng = np.random.default_rng(seed)
        self.names = BLENDVOCA_NAMES
        self._splits = {"train": list(train), "val": list(val), "test": list(test)}
        self.subjects = [s for split in self._splits.values() for s in split]
        self.manifest_hash = manifest_hash
        self._data = {}
        jaw = self.names.index("jawOpen")
        close = self.names.index("mouthClose")
        for subject in self.subjects:
            for i in range(n_sentences):
                audio, env = envelope_audio(rng, seconds * rng.uniform(0.8, 1.2))
                coeffs = np.full((env.shape[0], 32), 0.05)
                coeffs[:, jaw] = 0.8 * env
                coeffs[:, close] = 0.3 * (1 - env)
                self._data[(subject, f"sentence{i + 1:02d}")] = (audio, coeffs)

    def split(self, name):
        return list(self._splits[name])

    def sentences(self, subject):
        return sorted(s for (subj, s) in self._data if subj == subject)

    def coeffs(self, subject, sentence):
        return self._data[(subject, sentence)][1].copy()

    def audio(self, subject, sentence):
        return self._data[(subject, sentence)][0].copy(), RATE


def fake_evaluate(generated, dataset, split="test"):
    """Mean squared coefficient error (lower is better) and a made-up 'sync' score."""
    errors = []
    for (subject, sentence), tracks in generated.items():
        truth = dataset.coeffs(subject, sentence)
        errors.append(((tracks - truth[None]) ** 2).mean(axis=(1, 2)))
    errors = np.concatenate(errors)
    return {
        "coeff_mse": {"mean": float(errors.mean()), "std": float(errors.std()), "higher_is_better": False,
                      "unit": ""},
        "sync": {"mean": float(-errors.mean()), "std": 0.0, "higher_is_better": True, "unit": ""},
    }
