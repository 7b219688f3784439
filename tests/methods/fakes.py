"""The dataset of the method tests (``benchmark.testing.FakeBlendVOCA``, whose motion is
a known function of its audio) with the subjects and lengths they name, and a fake
evaluate function."""

from __future__ import annotations

import numpy as np

from benchmark.methods.contract import FPS
from benchmark.testing import FakeBlendVOCA


def speech_dataset(seed=0, sentences=3, seconds=2.0, train=("A", "B"), val=("C",), test=("D", "E")) -> FakeBlendVOCA:
    """Subjects per split as named; ``sentences`` sentences of 0.8 to 1.2 x ``seconds`` each
    whose jawOpen follows the loudness of noise-burst speech (mouthClose its opposite) and
    whose other coefficients are 0.05; rigs on a small ellipsoid head."""
    frames = (round(0.8 * seconds * FPS), round(1.2 * seconds * FPS) + 1)
    return FakeBlendVOCA(seed, train=list(train), val=list(val), test=list(test), sentences=sentences,
                         frames=frames, noise=0.0)


def fake_evaluate(generated, dataset, split="test", metrics=None):
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


def fake_evaluate_split(generated, dataset, split="test", settings=None, metrics=None):
    """:func:`fake_evaluate` with ``benchmark.evaluation.evaluate_split``'s signature (what the
    runner's scoring calls), for tests that replace the runner's evaluation."""
    return fake_evaluate(getattr(generated, "tracks", generated), dataset, split)
