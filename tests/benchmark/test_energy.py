"""The energy score: closed forms, the fair estimator and its propriety."""

import itertools

import numpy as np
import pytest

from benchmark.metrics.energy import energy_scores, vertex_energy_score


def brute_force(samples, truth):
    s = len(samples)
    first = np.mean([np.linalg.norm(x - truth) for x in samples])
    if s == 1:
        return first
    pairs = sum(np.linalg.norm(samples[i] - samples[j]) for i, j in itertools.permutations(range(s), 2))
    return first - pairs / (2 * s * (s - 1))


def test_matches_the_definition():
    rng = np.random.default_rng(0)
    for s in (1, 2, 5):
        samples, truth = rng.normal(size=(s, 7, 4)), rng.normal(size=(7, 4))
        expected = [brute_force(samples[:, m], truth[m]) for m in range(7)]
        np.testing.assert_allclose(energy_scores(samples, truth), expected, rtol=1e-12, atol=1e-12)


def test_closed_forms():
    # S = 1: the distance to the outcome; two samples on either side of it in 1-d:
    # (|a| + |b|) / 2 - |a - b| / 2 = 0 when the outcome lies between them
    assert energy_scores(np.array([[[3.0, 4.0]]]), np.zeros((1, 2)))[0] == 5.0
    assert energy_scores(np.array([[[-1.0]], [[2.0]]]), np.zeros((1, 1)))[0] == pytest.approx(0.0)
    # identical samples: the second term vanishes
    assert energy_scores(np.ones((4, 1, 3)), np.zeros((1, 3)))[0] == pytest.approx(np.sqrt(3))
    # positions far from the origin do not cost precision (the samples are centred)
    near = energy_scores(np.array([[[0.0]], [[1e-3]]]), np.zeros((1, 1)))
    far = energy_scores(np.array([[[1e3]], [[1e3 + 1e-3]]]), np.full((1, 1), 1e3))
    np.testing.assert_allclose(near, far, rtol=1e-6)


def test_the_true_distribution_scores_best_in_expectation():
    """Samples of the outcome's own distribution beat a collapsed forecast (its mean)
    and a noisier one; the fair estimator makes S = 3 and S = 10 agree."""
    rng = np.random.default_rng(1)
    items, dim = 4000, 3
    truth = rng.normal(size=(items, dim))

    def score(samples):
        return energy_scores(samples, truth).mean()

    true_3, true_10 = score(rng.normal(size=(3, items, dim))), score(rng.normal(size=(10, items, dim)))
    collapsed = score(np.zeros((10, items, dim)))
    noisy = score(rng.normal(scale=1.6, size=(10, items, dim)))
    assert true_10 < collapsed and true_10 < noisy
    assert true_3 == pytest.approx(true_10, rel=0.03)


def test_vertex_energy_is_rms_distance_in_mm():
    rng = np.random.default_rng(2)
    truth = rng.normal(size=(5, 10, 3)) * 0.01
    one = truth[None] + 0.001  # every vertex 1 mm off in x, y and z: RMS sqrt(3) mm
    assert vertex_energy_score(one, truth) == pytest.approx(np.sqrt(3))
    with pytest.raises(ValueError, match=r"\(S, T, V, 3\)"):
        vertex_energy_score(truth, truth)



@pytest.mark.parametrize("shape", [(10, 259, 40), (10, 37, 50), (1, 20, 30), (3, 16, 8), (3, 17, 5), (2, 1, 4)])
def test_vertex_energy_in_blocks_of_frames_is_the_whole_sequence_score_bit_for_bit(shape):
    from benchmark.metrics.energy import energy_scores, vertex_energy_score
    from benchmark.metrics.vertex import MM

    s, t, v = shape
    rng = np.random.default_rng(t)
    truth = rng.normal(size=(t + 3, v, 3)) * 0.01
    samples = truth[None, :t] + rng.normal(size=(s, t, v, 3)) * 0.002
    whole = energy_scores(samples.reshape(s, t, 3 * v), truth[:t].reshape(t, 3 * v))
    assert vertex_energy_score(samples, truth) == float(whole.mean() * MM / np.sqrt(v))
