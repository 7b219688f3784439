import numpy as np
import pytest
import torch

from baselines.cdface.closure import closure_mask, flame_lip_pair, lip_distance
from baselines.cdface.losses import (
    best_of_n_reconstruction,
    code_regularizer,
    diversity_loss,
    lip_losses,
    lip_reconstruction,
    upper_face_losses,
)


def _preds(values):
    """(N, T) scalars -> (N, B=1, T, D=1)."""
    return torch.tensor(values, dtype=torch.float64)[:, None, :, None]


def test_diversity_loss_is_minus_the_summed_minimum_pair_distance():
    # frame 0: samples 0, 1, 3 (closest pair 1 apart); frame 1: 0, 0, 2 (a repeat: 0)
    preds = _preds([[0.0, 0.0], [1.0, 0.0], [3.0, 2.0]])
    assert float(diversity_loss(preds)) == pytest.approx(-1.0, abs=1e-5)
    # masked (Eq. 11): frame 0 closed contributes nothing
    assert float(diversity_loss(preds, torch.tensor([[0.0, 1.0]]))) == pytest.approx(0.0, abs=1e-5)
    # the L2 norm over a frame's values: (3, 4) vs (0, 0) is 5 apart
    two_d = torch.tensor([[3.0, 4.0], [0.0, 0.0]], dtype=torch.float64)[:, None, None, :]
    assert float(diversity_loss(two_d)) == pytest.approx(-5.0, abs=1e-5)
    with pytest.raises(ValueError, match="N >= 2"):
        diversity_loss(preds[:1])


def test_diversity_loss_gradient_pushes_the_closest_pair_apart():
    preds = _preds([[0.0], [1.0], [3.0]]).requires_grad_(True)
    diversity_loss(preds).backward()
    g = preds.grad[:, 0, 0, 0]
    # only the closest pair (0, 1) is in the loss: d(-|x1 - x0|) = -1 for x1, +1 for x0
    np.testing.assert_allclose(g.numpy(), [1.0, -1.0, 0.0], atol=1e-6)
    same = _preds([[1.0], [1.0]]).requires_grad_(True)
    diversity_loss(same).backward()
    assert torch.isfinite(same.grad).all()


def test_best_of_n_supervises_the_closest_sample_per_frame():
    preds = _preds([[0.0, 0.0], [1.5, 0.0], [3.0, 2.0]]).requires_grad_(True)
    target = torch.tensor([[1.0, 2.0]], dtype=torch.float64)[:, :, None]
    # frame 0: |1 - 1.5| = 0.5 (sample 1); frame 1: |2 - 2| = 0 (sample 2)
    loss = best_of_n_reconstruction(preds, target)
    assert float(loss.detach()) == pytest.approx(0.5)
    loss.backward()
    g = preds.grad[:, 0, :, 0]
    assert g[0].abs().sum() == 0 and g[1, 1] == 0 and g[1, 0] == pytest.approx(1.0)


def test_lip_reconstruction_adds_every_sample_on_closure_frames():
    preds = _preds([[0.0, 0.0], [1.5, 0.0], [3.0, 2.0]])
    target = torch.tensor([[1.0, 2.0]], dtype=torch.float64)[:, :, None]
    mask = torch.tensor([[1.0, 0.0]])  # frame 1 needs closure
    # best-of-N 0.5 + (|2 - 0| + |2 - 0| + |2 - 2|) / 3 on frame 1
    assert float(lip_reconstruction(preds, target, mask)) == pytest.approx(0.5 + 4.0 / 3.0)
    assert float(lip_reconstruction(preds, target, torch.ones(1, 2))) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="frame mask"):
        lip_reconstruction(preds, target, torch.ones(2))


def test_batch_mean_and_code_regularizer():
    a = _preds([[0.0], [2.0]])
    batch = torch.cat([a, 2 * a], dim=1)  # (2, B=2, 1, 1): distances 2 and 4
    assert float(diversity_loss(batch)) == pytest.approx(-3.0, abs=1e-5)
    codes = torch.tensor([[[[3.0, 4.0]]], [[[0.0, 1.0]]]], requires_grad=True)  # (N=2, B=1, T=1, C=2)
    quantized = torch.zeros_like(codes, requires_grad=True)
    loss = code_regularizer(codes, quantized)
    assert float(loss.detach()) == pytest.approx(5.0 + 1.0)
    loss.backward()
    assert quantized.grad is None and codes.grad is not None


def test_part_losses_apply_the_weights_of_eq15_and_eq16():
    preds = _preds([[0.0, 0.0], [1.5, 0.0], [3.0, 2.0]])
    target = torch.tensor([[1.0, 2.0]], dtype=torch.float64)[:, :, None]
    mask = torch.tensor([[1.0, 0.0]])
    codes = torch.ones(3, 1, 2, 4, dtype=torch.float64)
    lip = lip_losses(preds, target, mask, codes, torch.zeros_like(codes), lambda_d=0.02, lambda_rc=1.0, lambda_rg=1.0)
    # masked diversity: frame 0 only, closest pair 1.5 apart; regulariser 3 samples x 2 frames x |(1,1,1,1)| = 12
    assert float(lip["diversity"]) == pytest.approx(-1.5, abs=1e-5)
    assert float(lip["regularizer"]) == pytest.approx(12.0)
    assert float(lip["total"]) == pytest.approx(0.02 * -1.5 + 0.5 + 4 / 3 + 12.0, abs=1e-5)
    # upper face: 2 lip samples x 3 upper samples; the second group is the first shifted by 1
    group = preds[:, 0]
    upper = torch.stack([group, group + 1.0])[:, :, None]  # (N^l=2, N^u=3, B=1, T=2, D=1)
    ucodes = torch.zeros(2, 3, 1, 2, 4, dtype=torch.float64)
    up = upper_face_losses(upper, target, ucodes, ucodes, lambda_d=0.02, lambda_rc=1.0, lambda_rg=1.0)
    # Eq. 9: sum over lip samples of -(1.5 + 0) each; Eq. 10: 0.5 + (frame 0: |1 - 1| = 0, frame 1: |2 - 1| = 1)
    assert float(up["diversity"]) == pytest.approx(-3.0, abs=1e-5)
    assert float(up["reconstruction"]) == pytest.approx(0.5 + 1.0)
    assert float(up["total"]) == pytest.approx(0.02 * -3.0 + 1.5, abs=1e-5)


def test_closure_mask_on_a_constructed_sequence():
    # vertex 0 upper lip, vertex 1 lower lip; apertures 2, 6, 4.9, 5.1 and exactly 5 mm
    gaps = np.array([0.002, 0.006, 0.0049, 0.0051, 0.005])
    verts = np.zeros((5, 3, 3))
    verts[:, 1, 1] = -gaps
    np.testing.assert_allclose(lip_distance(verts, (0, 1)), gaps)
    np.testing.assert_array_equal(closure_mask(verts, (0, 1), 0.005), [0, 1, 0, 1, 0])
    np.testing.assert_array_equal(closure_mask(verts, (0, 1), 0.0), [1, 1, 1, 1, 1])
    with pytest.raises(ValueError, match="outside"):
        lip_distance(verts, (0, 3))
    with pytest.raises(ValueError, match="epsilon"):
        closure_mask(verts, (0, 1), -1.0)


def test_flame_lip_pair_is_the_inner_lip_landmarks(assets_dir):
    from blendvoca.assets import load_index_list

    landmarks = load_index_list("flame-landmarks")
    assert flame_lip_pair() == (int(landmarks[62]), int(landmarks[66]))
