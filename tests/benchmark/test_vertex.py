import numpy as np
import pytest

from benchmark.metrics import (
    average_pairwise_distance,
    lip_vertex_error,
    mean_vertex_error,
    motion_dynamics,
    rig_vertices,
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


def test_pairwise_distance():
    base = np.zeros((1, 4, 2, 3))
    samples = np.concatenate([base, base + [0.001, 0, 0], base + [0.003, 0, 0]])
    # pairs: 1, 3, 2 mm
    assert average_pairwise_distance(samples) == pytest.approx(2.0)
    assert average_pairwise_distance(samples[:1].repeat(3, 0)) == 0.0
    with pytest.raises(ValueError, match="S >= 2"):
        average_pairwise_distance(samples[:1])


def test_shape_errors():
    with pytest.raises(ValueError, match="equal V"):
        mean_vertex_error(np.zeros((2, 3, 3)), np.zeros((2, 4, 3)))


def test_region_distances_match_single_calls():
    from benchmark.metrics import pairwise_distance_by_region

    rng = np.random.default_rng(1)
    samples = rng.normal(scale=0.001, size=(3, 5, 7, 3))
    regions = {"all": None, "some": [0, 3, 4]}
    got = pairwise_distance_by_region(samples, regions)
    assert got["all"] == pytest.approx(average_pairwise_distance(samples))
    assert got["some"] == pytest.approx(average_pairwise_distance(samples, [0, 3, 4]))
