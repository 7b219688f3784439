import numpy as np
import pytest
import torch

from baselines.common.attention_bias import alignment_bias
from baselines.said.model import Attention


@pytest.mark.parametrize("t, s", [(1, 1), (2, 2), (5, 5), (60, 60), (7, 12), (12, 7 + 5), (8, 7), (30, 50)])
def test_band_is_exactly_i_minus_j_at_most_one(t, s):
    bias = alignment_bias(t, s).numpy()
    assert bias.shape == (t, s)
    for i in range(t):
        for j in range(s):
            assert bias[i, j] == (0.0 if abs(i - j) <= 1 else -np.inf)


def test_band_for_square_is_tridiagonal():
    b = alignment_bias(6, 6)
    expected = np.full((6, 6), -np.inf)
    for i in range(6):
        expected[i, max(0, i - 1) : i + 2] = 0.0
    np.testing.assert_array_equal(b.numpy(), expected)


def test_wider_band_and_counts():
    b = alignment_bias(10, 10, half_width=2).numpy()
    assert np.isfinite(b).sum(axis=1).tolist() == [3, 4, 5, 5, 5, 5, 5, 5, 4, 3]


def test_rows_without_keys_raise():
    with pytest.raises(ValueError, match="exceed key frames"):
        alignment_bias(10, 8)
    with pytest.raises(ValueError, match="num_keys"):
        alignment_bias(3, 0)


def test_cross_attention_ignores_keys_outside_the_band():
    torch.manual_seed(0)
    att = Attention(16, 8, heads=2)
    x, ctx = torch.randn(1, 9, 16), torch.randn(1, 9, 8)
    bias = alignment_bias(9, 9)
    out = att(x, ctx, bias)
    ctx2 = ctx.clone()
    ctx2[:, 7] += 10.0  # only rows 6, 7, 8 may see frame 7
    out2 = att(x, ctx2, bias)
    changed = (out2 - out).abs().amax(dim=-1)[0] > 1e-6
    assert changed.tolist() == [False] * 6 + [True] * 3


def test_cross_attention_matches_manual_softmax_with_bias():
    torch.manual_seed(1)
    att = Attention(8, 4, heads=1)
    x, ctx = torch.randn(1, 5, 8), torch.randn(1, 6, 4)
    bias = alignment_bias(5, 6)
    q, k, v = att.to_q(x)[0], att.to_k(ctx)[0], att.to_v(ctx)[0]
    w = torch.softmax(q @ k.T / np.sqrt(8) + bias, dim=-1)
    expected = att.to_out(w @ v)
    torch.testing.assert_close(att(x, ctx, bias)[0], expected, rtol=1e-5, atol=1e-6)
