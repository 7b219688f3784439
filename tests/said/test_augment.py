import numpy as np
import pytest

from baselines.said.augment import (
    audio_window,
    mirror_swapped,
    training_batch,
    validation_windows,
)


def test_mirror_swap_with_blendvoca_pairs_is_an_involution():
    from blendvoca.names import BLENDVOCA_NAMES, mirror_permutation

    perm = mirror_permutation(BLENDVOCA_NAMES)
    c = np.random.default_rng(0).random((5, 32))
    s = mirror_swapped(c, perm)
    i, j = BLENDVOCA_NAMES.index("mouthSmileLeft"), BLENDVOCA_NAMES.index("mouthSmileRight")
    np.testing.assert_array_equal(s[:, i], c[:, j])
    k = BLENDVOCA_NAMES.index("jawOpen")
    np.testing.assert_array_equal(s[:, k], c[:, k])
    np.testing.assert_array_equal(mirror_swapped(s, perm), c)
    with pytest.raises(ValueError):
        mirror_swapped(c, np.arange(31))


def test_audio_window_alignment_shift_and_padding():
    audio = np.arange(1, 16001, dtype=np.float32)  # 1 s
    w = audio_window(audio, 30, 6)  # frames 30..35 -> samples 8000..9600
    np.testing.assert_array_equal(w, audio[8000:9600])
    np.testing.assert_array_equal(audio_window(audio, 30, 6, shift=-100), audio[7900:9500])
    end = audio_window(audio, 57, 6)  # runs past the end
    np.testing.assert_array_equal(end[:800], audio[15200:16000])
    assert np.all(end[800:] == 0)
    start = audio_window(audio, 0, 3, shift=-10)
    assert np.all(start[:10] == 0) and start[10] == 1


def test_training_batch_shapes_and_augmentation():
    rng = np.random.default_rng(0)
    coeffs = np.tile(np.arange(2, dtype=np.float32), (200, 1))
    coeffs[:, 1] += np.arange(200) / 1000
    pairs = [(coeffs, np.zeros(200 * 16000 // 60, np.float32))]
    c, a = training_batch(pairs, 64, 50, rng, mirror=np.array([1, 0]), mirror_prob=0.5)
    assert c.shape == (64, 50, 2) and a.shape == (64, 50 * 16000 // 60)
    swapped = c[:, 0, 0] > 0.5
    assert 10 < swapped.sum() < 54
    # short corpus: the window shrinks to the shortest sentence
    c2, _ = training_batch([(coeffs[:30], np.zeros(8000, np.float32))], 2, 50, rng)
    assert c2.shape == (2, 30, 2)
    vc, _ = validation_windows(pairs, 50)
    np.testing.assert_array_equal(vc[0], coeffs[:50])
