import pytest
import torch

from baselines.said.guidance import classifier_free_guidance
from baselines.said.losses import noise_l1_loss, said_loss, velocity_loss


def test_velocity_loss_zero_for_equal_noise():
    n = torch.randn(3, 10, 32)
    assert velocity_loss(n, n.clone()) == 0
    # a constant offset in time changes no frame-to-frame difference
    assert velocity_loss(n, n + 0.7).item() == pytest.approx(0.0, abs=1e-6)


def test_velocity_loss_hand_computed():
    n = torch.tensor([[[0.0], [1.0], [3.0]]])  # diffs 1, 2
    p = torch.tensor([[[0.0], [2.0], [2.0]]])  # diffs 2, 0
    # |1 - 2| = 1, |2 - 0| = 2 -> mean 1.5
    assert velocity_loss(n, p).item() == pytest.approx(1.5)
    # L1: |0|, |1 - 2|, |3 - 2| -> 2 / 3
    assert noise_l1_loss(n, p).item() == pytest.approx(2 / 3)
    assert said_loss(n, p, velocity_weight=2.0).item() == pytest.approx(2 / 3 + 3.0)


def test_losses_reject_bad_shapes():
    with pytest.raises(ValueError, match="one shape"):
        velocity_loss(torch.zeros(1, 3, 2), torch.zeros(1, 4, 2))
    with pytest.raises(ValueError, match="at least 2 frames"):
        velocity_loss(torch.zeros(1, 1, 2), torch.zeros(1, 1, 2))


def test_guidance_formula():
    c, u = torch.randn(2, 5, 3), torch.randn(2, 5, 3)
    torch.testing.assert_close(classifier_free_guidance(c, u, 2.0), c + 2.0 * (c - u))
    torch.testing.assert_close(classifier_free_guidance(c, u, 0.0), c)
    torch.testing.assert_close(classifier_free_guidance(c, c, 5.0), c)
    # gamma = 2 equals 3 * cond - 2 * uncond
    torch.testing.assert_close(classifier_free_guidance(c, u), 3 * c - 2 * u)
