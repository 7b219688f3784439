"""The disturbances in closed form: what each does to a track, level by level."""

import numpy as np
import pytest

from blendvoca.rig_regions import mouth_shape_indices
from benchmark.sanity.disturbances import (
    DISTURBANCES,
    constant_offset,
    damping,
    disturb,
    iid_noise,
    mouth_damping,
    noisy_samples,
    sentence_swap,
    temporal_smoothing,
    time_shift,
)
from blendvoca.names import BLENDVOCA_NAMES
from tests.benchmark.fakes import smooth_track


@pytest.fixture
def track():
    return smooth_track(200, np.random.default_rng(0))


@pytest.mark.parametrize("k", [1, 2, 5, 17])
def test_time_shift_delays_by_k_and_holds_the_edge(track, k):
    out = time_shift(track, k)
    assert out.shape == track.shape
    np.testing.assert_array_equal(out[k:], track[:-k])  # out[t] = track[t - k]: the motion k frames late
    np.testing.assert_array_equal(out[:k], np.repeat(track[:1], k, axis=0))
    back = time_shift(track, -k)
    np.testing.assert_array_equal(back[:-k], track[k:])
    np.testing.assert_array_equal(back[-k:], np.repeat(track[-1:], k, axis=0))
    np.testing.assert_array_equal(time_shift(track, 0), track)


def test_smoothing_keeps_the_mean_and_lowers_the_roughness(track):
    assert np.array_equal(temporal_smoothing(track, 0), track)
    rough = [np.abs(np.diff(temporal_smoothing(track, s), axis=0)).mean() for s in (0, 1, 2, 4, 8)]
    assert np.all(np.diff(rough) < 0)
    out = temporal_smoothing(track, 3)
    np.testing.assert_allclose(out.mean(axis=0), track.mean(axis=0), atol=2e-3)  # reflected edges: almost exact
    assert out.min() >= 0 and out.max() <= 1  # a convex average stays in [0, 1]
    # a constant track is a fixed point
    np.testing.assert_allclose(temporal_smoothing(np.full((50, 3), 0.3), 4), 0.3)


def test_damping_scales_toward_the_neutral(track):
    for level in (0, 0.2, 0.5, 0.8, 1.0):
        np.testing.assert_allclose(damping(track, level), (1 - level) * track)
    with pytest.raises(ValueError):
        damping(track, 1.5)


def test_mouth_damping_scales_only_jaw_and_mouth_shapes(track):
    names = BLENDVOCA_NAMES
    out = mouth_damping(track, names, 0.6)
    mouth = mouth_shape_indices(names)
    rest = np.setdiff1d(np.arange(len(names)), mouth)
    assert {names[i] for i in rest} == {"cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft",
                                        "noseSneerRight"}
    np.testing.assert_allclose(out[:, mouth], 0.4 * track[:, mouth])
    np.testing.assert_array_equal(out[:, rest], track[:, rest])


def test_noise_is_one_pattern_scaled_by_the_level(track):
    key = ("S", "sentence01")
    a, b = iid_noise(track, 0.01, key=key), iid_noise(track, 0.02, key=key)
    inside = (a > 0) & (a < 1) & (b > 0) & (b < 1)  # where no clipping happened, b - x = 2 (a - x)
    np.testing.assert_allclose((b - track)[inside], 2 * (a - track)[inside], atol=1e-12)
    assert a.min() >= 0 and a.max() <= 1
    np.testing.assert_array_equal(iid_noise(track, 0.0, key=key), track)
    z = np.random.default_rng(1).standard_normal(track.shape)
    np.testing.assert_allclose(iid_noise(np.full((200, 32), 0.5), 0.01, z), 0.5 + 0.01 * z)


def test_constant_offset_lifts_and_clips(track):
    out = constant_offset(track, 0.05)
    np.testing.assert_allclose(out, np.clip(track + 0.05, 0, 1))
    assert np.all(out >= 0.05)


def test_noisy_samples_are_distinct_noisy_copies(track):
    samples = noisy_samples(track, 0.02, 3, key="k")
    assert samples.shape == (3, *track.shape)
    assert not np.allclose(samples[0], samples[1])
    np.testing.assert_array_equal(noisy_samples(track, 0.0, 3, key="k"), np.stack([track] * 3))
    with pytest.raises(ValueError):
        noisy_samples(track, 0.02, 1)


def test_sentence_swap_replaces_a_growing_share_with_other_sentences():
    rng = np.random.default_rng(3)
    tracks = {f"s{i}": smooth_track(100 + 20 * i, rng) for i in range(4)}
    assert all(np.array_equal(sentence_swap(tracks, 0)[k], v) for k, v in tracks.items())
    swapped = []
    for share, count in ((0.25, 1), (0.5, 2), (0.75, 3), (1.0, 4)):
        out = sentence_swap(tracks, share)
        changed = {k for k in tracks if not np.array_equal(out[k], tracks[k])}
        assert len(changed) == count and set(swapped) <= changed  # a larger share swaps a superset
        swapped = sorted(changed)
        for k in changed:
            assert out[k].shape == tracks[k].shape  # cut or wrapped to the sentence's own length
            donors = [d for d in tracks if d != k and np.array_equal(out[k][: min(len(tracks[d]), len(out[k]))],
                                                                     tracks[d][: len(out[k])])]
            assert donors, f"{k} is not another sentence's track"
    # wrapped: a shorter donor is repeated from its start
    short = {"a": np.arange(10.0)[:, None] * np.ones((1, 2)) / 10, "b": np.arange(4.0)[:, None] * np.ones((1, 2)) / 10}
    out = sentence_swap(short, 1.0)
    np.testing.assert_allclose(out["a"][:, 0], np.arange(10) % 4 / 10)
    np.testing.assert_allclose(out["b"][:, 0], np.arange(4) / 10)


def test_every_disturbance_starts_at_the_truth_and_has_five_levels(track):
    tracks = {("S", f"sentence0{i}"): smooth_track(150, np.random.default_rng(i)) for i in range(1, 4)}
    for kind, d in DISTURBANCES.items():
        for which in ("small", "full"):
            levels = d.levels(which)
            assert len(levels) >= 5 and levels[0] == 0 and list(levels) == sorted(levels), kind
        out = disturb(kind, tracks, 0, BLENDVOCA_NAMES)
        for key, v in tracks.items():
            assert out[key].shape[1:] == v.shape and out[key].shape[0] == d.sample_count("small")
            assert np.allclose(out[key], v[None]), kind
        top = disturb(kind, tracks, d.levels("small")[-1], BLENDVOCA_NAMES)
        assert any(not np.allclose(top[key], v[None]) for key, v in tracks.items()), kind
    with pytest.raises(ValueError, match="unknown disturbance"):
        disturb("nope", tracks, 0, BLENDVOCA_NAMES)
