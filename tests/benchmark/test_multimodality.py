import numpy as np
import pytest

from benchmark.metrics import multimodality, paired_samples


def test_identical_samples_zero_and_known_value():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(20, 8))
    assert multimodality(a, a) == 0.0
    b = a.copy()
    b[:, 0] += 3.0
    assert multimodality(a, b) == pytest.approx(3.0)


def test_pairs_first_half_with_second_half():
    feats = np.arange(10, dtype=float)[:, None]
    groups = ["w1"] * 6 + ["w2"] * 3 + ["w3"]
    a, b = paired_samples(feats, groups, pairs_per_window=36)
    assert a.ravel().tolist() == [0, 1, 2, 6]
    assert b.ravel().tolist() == [3, 4, 5, 7]
    a, b = paired_samples(feats, groups, pairs_per_window=1)
    assert a.ravel().tolist() == [0, 6] and b.ravel().tolist() == [3, 7]


def test_shape_mismatch_raises():
    with pytest.raises(ValueError, match="equal shape"):
        multimodality(np.zeros((3, 2)), np.zeros((4, 2)))
