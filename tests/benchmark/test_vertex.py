import numpy as np
import pytest

from benchmark.metrics import (
    average_pairwise_distance,
    diversity_metrics,
    lip_vertex_error,
    mean_vertex_error,
    minimum_pairwise_distance,
    motion_dynamics,
    pairwise_distances,
    rig_vertices,
    sequence_distance,
    upper_face_dynamics_deviation,
)


def test_rig_vertices_matches_loop():
    rng = np.random.default_rng(0)
    neutral, deltas, coeffs = rng.normal(size=(10, 3)), rng.normal(size=(4, 10, 3)), rng.uniform(size=(6, 4))
    ref = np.stack([neutral + np.einsum("k,kvc->vc", c, deltas) for c in coeffs])
    np.testing.assert_allclose(rig_vertices(neutral, deltas, coeffs), ref, atol=1e-12)


def test_lve_and_mve_known_offsets():
    gt = np.zeros((4, 5, 3))
    pred = gt.copy()
    pred[:, 0, 0] = 0.002  # 2 mm on a lip vertex
    pred[:, 3, 1] = 0.005  # 5 mm on a non-lip vertex
    assert lip_vertex_error(pred, gt, [0, 1]) == pytest.approx(2.0)
    assert lip_vertex_error(pred, gt, [0, 1], squared=True) == pytest.approx(4.0)
    assert lip_vertex_error(pred, gt, [0, 3]) == pytest.approx(5.0)
    assert mean_vertex_error(pred, gt) == pytest.approx((2 + 5) / 5)
    assert lip_vertex_error(gt, gt, [0]) == 0.0


def test_lve_is_max_per_frame_then_mean():
    gt = np.zeros((2, 3, 3))
    pred = gt.copy()
    pred[0, 0, 2] = 0.001
    pred[1, 1, 2] = 0.003
    assert lip_vertex_error(pred, gt, [0, 1]) == pytest.approx(2.0)


def test_fdd_closed_form():
    t = np.arange(100)
    neutral = np.zeros((3, 3))
    gt = np.zeros((100, 3, 3))
    gt[:, 0, 1] = 0.001 * (t % 2)  # squared displacement alternates 0 / 1 mm^2: std 0.5
    pred = np.zeros_like(gt)
    assert motion_dynamics(gt, neutral, [0]) == pytest.approx(0.5)
    assert upper_face_dynamics_deviation(pred, gt, neutral, [0]) == pytest.approx(0.5)
    assert upper_face_dynamics_deviation(gt, gt, neutral, [0, 1]) == 0.0


def _offset_samples(offsets_mm, t=4, v=2):
    """Samples that are one zero sequence shifted rigidly by ``offsets_mm`` along x."""
    samples = np.zeros((len(offsets_mm), t, v, 3))
    samples[:, :, :, 0] = np.asarray(offsets_mm, dtype=np.float64)[:, None, None] / 1000.0
    return samples


def test_apd_and_mpd_closed_form():
    samples = _offset_samples([0.0, 1.0, 3.0])
    # pairs 1, 3 and 2 mm: every vertex of every frame moves by the same amount
    assert average_pairwise_distance(samples) == pytest.approx(2.0)
    assert minimum_pairwise_distance(samples) == pytest.approx(1.0)
    np.testing.assert_allclose(pairwise_distances(samples), [[0, 1, 3], [1, 0, 2], [3, 2, 0]], atol=1e-12)
    assert average_pairwise_distance(samples[:1].repeat(3, 0)) == 0.0
    assert minimum_pairwise_distance(np.concatenate([samples, samples[:1]])) == 0.0  # a repeated sample
    with pytest.raises(ValueError, match="S >= 2"):
        average_pairwise_distance(samples[:1])
    with pytest.raises(ValueError, match="S >= 2"):
        minimum_pairwise_distance(samples[:1])


def test_apd_is_the_paper_double_sum_and_length_normalised():
    rng = np.random.default_rng(3)
    samples = rng.normal(scale=0.002, size=(4, 6, 5, 3))
    s, t, v, _ = samples.shape
    # Eq. 18 with the unnormalised Frobenius norm, divided by sqrt(T V)
    paper = sum(np.linalg.norm(samples[i] - samples[j]) for i in range(s) for j in range(s) if i != j) / (s * (s - 1))
    assert average_pairwise_distance(samples) == pytest.approx(paper / np.sqrt(t * v) * 1000.0)
    # Eq. 19
    paper_min = min(np.linalg.norm(samples[i] - samples[j]) for i in range(s) for j in range(s) if i != j)
    assert minimum_pairwise_distance(samples) == pytest.approx(paper_min / np.sqrt(t * v) * 1000.0)
    # a sequence played twice has the same normalised distances
    doubled = np.concatenate([samples, samples], axis=1)
    assert average_pairwise_distance(doubled) == pytest.approx(average_pairwise_distance(samples))
    assert sequence_distance(samples[0], samples[1]) == pytest.approx(pairwise_distances(samples)[0, 1])


def test_rms_over_frames_and_vertices():
    # one vertex of two moves by 3 mm in one frame of two: sqrt(9 / 4) = 1.5 mm
    samples = np.zeros((2, 2, 2, 3))
    samples[1, 0, 0, 2] = 0.003
    assert average_pairwise_distance(samples) == pytest.approx(1.5)
    assert average_pairwise_distance(samples, [0]) == pytest.approx(np.sqrt(9 / 2))
    assert average_pairwise_distance(samples, [1]) == 0.0


def test_upd_lpd_on_vertex_subsets():
    # vertices 0, 1: "upper face", 2, 3: "lips"; samples differ by 2 mm on the upper
    # face and 5 mm on the lips except sample 2, whose lips equal sample 0's
    samples = np.zeros((3, 5, 4, 3))
    samples[1, :, :2, 1] = 0.002
    samples[2, :, :2, 1] = -0.002
    samples[1, :, 2:, 1] = 0.005
    upper, lips = [0, 1], [2, 3]
    assert average_pairwise_distance(samples, upper) == pytest.approx((2 + 2 + 4) / 3)
    assert average_pairwise_distance(samples, lips) == pytest.approx((5 + 0 + 5) / 3)
    assert minimum_pairwise_distance(samples, lips) == 0.0
    div = diversity_metrics(samples, upper, lips)
    assert div["upd"] == pytest.approx(average_pairwise_distance(samples, upper))
    assert div["lpd"] == pytest.approx(average_pairwise_distance(samples, lips))
    assert div["apd"] == pytest.approx(average_pairwise_distance(samples))
    assert div["mpd"] == pytest.approx(minimum_pairwise_distance(samples))
    # sample pair (0, 2): 2 mm on two of four vertices -> sqrt(4 * 2 / 4)
    assert div["mpd"] == pytest.approx(np.sqrt(2.0))
    with pytest.raises(ValueError, match="vertex index"):
        average_pairwise_distance(samples, [7])


def test_shape_errors():
    with pytest.raises(ValueError, match="equal V"):
        mean_vertex_error(np.zeros((2, 3, 3)), np.zeros((2, 4, 3)))
