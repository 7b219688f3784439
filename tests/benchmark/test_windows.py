import numpy as np
import pytest

from benchmark.metrics import cut_windows, slice_windows, window_starts


def test_window_counts_follow_protocol():
    assert window_starts(120).tolist() == [0]
    assert len(window_starts(200)) == 81
    assert len(window_starts(200, drop_last=2)) == 79
    assert len(window_starts(119)) == 0
    assert len(window_starts(121, drop_last=2)) == 0
    assert window_starts(250, stride=60).tolist() == [0, 60, 120]


def test_slice_windows_content():
    track = np.arange(130 * 2, dtype=float).reshape(130, 2)
    w = slice_windows(track, np.array([0, 5]), 120)
    assert w.shape == (2, 120, 2)
    np.testing.assert_array_equal(w[1], track[5:125])
    with pytest.raises(ValueError, match="exceed"):
        slice_windows(track, np.array([20]), 120)


def test_generated_windows_filtered_to_ground_truth():
    rng = np.random.default_rng(0)
    gt = {("s", "a"): rng.uniform(size=(130, 3)), ("s", "b"): rng.uniform(size=(100, 3))}
    gen = {("s", "a"): rng.uniform(size=(2, 140, 3)), ("s", "b"): rng.uniform(size=(1, 140, 3)),
           ("s", "c"): rng.uniform(size=(1, 140, 3))}
    w = cut_windows(gt, gen)
    assert len(w.real) == 130 - 120 + 1 - 2
    assert {k for k, _ in w.real_keys} == {("s", "a")}
    # generated 'a' has 21 starts, only the 9 of the ground truth are kept, for both samples
    assert len(w.fake) == 2 * 9
    assert {(k, s) for k, s, _ in w.fake_keys} == set(w.real_keys)
    np.testing.assert_array_equal(w.fake[0], gen[("s", "a")][0, :120])


def test_channel_mismatch_raises():
    with pytest.raises(ValueError, match="channels"):
        cut_windows({"a": np.zeros((130, 3))}, {"a": np.zeros((1, 130, 4))})
