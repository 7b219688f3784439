"""VectorQuantizer: nearest code, straight-through gradient, losses and codebook update."""

import numpy as np
import pytest
import torch

from baselines.vq import VectorQuantizer, nearest_code_indices


def _quantizer(n_e=7, e_dim=4, beta=0.25, seed=0):
    torch.manual_seed(seed)
    vq = VectorQuantizer(n_e, e_dim, beta)
    with torch.no_grad():
        vq.embedding.weight.normal_()
    return vq


def test_nearest_code_matches_brute_force():
    vq = _quantizer()
    z = torch.randn(3, 5, 4, dtype=torch.float32)
    quantized, _, (_, one_hot, indices) = vq(z)
    e = vq.embedding.weight.detach().numpy()
    zn = z.numpy().reshape(-1, 4)
    brute = np.argmin(((zn[:, None, :] - e[None]) ** 2).sum(-1), axis=1)
    np.testing.assert_array_equal(indices[:, 0].numpy(), brute)
    np.testing.assert_array_equal(one_hot.numpy().argmax(1), brute)
    assert quantized.shape == (3, 4, 5)
    np.testing.assert_allclose(quantized.detach().permute(0, 2, 1).numpy().reshape(-1, 4), e[brute], atol=1e-6)
    np.testing.assert_array_equal(nearest_code_indices(torch.from_numpy(zn), vq.embedding.weight).numpy(), brute)


def test_straight_through_gradient_is_identity():
    vq = _quantizer()
    z = torch.randn(2, 6, 4, requires_grad=True)
    w = torch.randn(2, 4, 6)
    quantized, _, _ = vq(z)
    (quantized * w).sum().backward()
    np.testing.assert_allclose(z.grad.numpy(), w.permute(0, 2, 1).numpy(), atol=1e-6)


def test_loss_value_and_gradients_closed_form():
    beta = 0.3
    vq = _quantizer(beta=beta)
    z = torch.randn(2, 5, 4, requires_grad=True)
    _, loss, (_, _, indices) = vq(z)
    e = vq.embedding.weight.detach()
    zq = e[indices[:, 0]].view(2, 5, 4)
    mse = ((zq - z.detach()) ** 2).mean()
    torch.testing.assert_close(loss.detach(), (1 + beta) * mse)
    loss.backward()
    m = z.numel()
    # encoder side: only the commitment term, 2 beta (z - e) / numel
    torch.testing.assert_close(z.grad, 2 * beta * (z.detach() - zq) / m)
    # codebook side: 2 (e_k - z_i) / numel summed over the vectors assigned to k; unused codes get 0
    expected = torch.zeros_like(e)
    flat = z.detach().reshape(-1, 4)
    for i, k in enumerate(indices[:, 0].tolist()):
        expected[k] += 2 * (e[k] - flat[i]) / m
    torch.testing.assert_close(vq.embedding.weight.grad, expected)


def test_codebook_step_moves_codes_toward_assigned_vectors():
    vq = _quantizer(n_e=5, e_dim=3)
    z = torch.randn(1, 40, 3)
    _, loss, (_, _, indices) = vq(z)
    before = vq.embedding.weight.detach().clone()
    loss.backward()
    with torch.no_grad():
        vq.embedding.weight -= 1.0 * vq.embedding.weight.grad
    after = vq.embedding.weight.detach()
    flat = z.reshape(-1, 3)
    for k in range(5):
        members = flat[indices[:, 0] == k]
        if len(members) == 0:
            torch.testing.assert_close(after[k], before[k])
            continue
        centroid = members.mean(0)
        assert torch.linalg.norm(after[k] - centroid) < torch.linalg.norm(before[k] - centroid)


def test_perplexity_counts_used_codes():
    vq = _quantizer(n_e=4, e_dim=2)
    with torch.no_grad():
        vq.embedding.weight.copy_(torch.tensor([[0., 0.], [10., 0.], [0., 10.], [10., 10.]]))
    z = torch.tensor([[[0.1, 0.], [9.9, 0.2], [0., 9.], [0.2, 0.1]]])
    _, _, (perplexity, _, indices) = vq(z)
    assert indices[:, 0].tolist() == [0, 1, 2, 0]
    usage = np.array([0.5, 0.25, 0.25])
    assert float(perplexity) == pytest.approx(float(np.exp(-(usage * np.log(usage)).sum())), rel=1e-5)


def test_distance_and_codebook_entry_layouts():
    vq = _quantizer()
    z = torch.randn(2, 4, 3)  # (B, e_dim, N)
    d = vq.get_distance(z)
    assert d.shape == (2, 7, 3)
    e = vq.embedding.weight.detach()
    for b in range(2):
        for n in range(3):
            torch.testing.assert_close(d[b, :, n].detach(), ((z[b, :, n][None] - e) ** 2).sum(1), rtol=1e-4, atol=1e-5)
    idx = torch.tensor([3, 0, 6])
    torch.testing.assert_close(vq.get_codebook_entry(idx).detach(), e[idx])
    assert vq.get_codebook_entry(idx, shape=(1, 3, 4)).shape == (1, 3, 4)
    with pytest.raises(IndexError, match=r"\[0, 7\)"):
        vq.get_codebook_entry(torch.tensor([7]))


def test_bad_shape_names_expected():
    vq = _quantizer()
    with pytest.raises(ValueError, match=r"\(B, N, 4\)"):
        vq(torch.randn(2, 3, 5))


def test_state_dict_key_is_the_authors():
    vq = VectorQuantizer(256, 64, 0.25)
    assert {k: tuple(v.shape) for k, v in vq.state_dict().items()} == {"embedding.weight": (256, 64)}
    w = vq.embedding.weight.detach()
    assert float(w.abs().max()) <= 1 / 256
