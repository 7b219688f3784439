import numpy as np
import pytest
import torch

from baselines.said.pipeline import SAiD
from baselines.said.sample import sample_diffusion
from baselines.said.schedule import alphas_cumprod_schedule

NAMES = tuple(f"c{i}" for i in range(6))


@pytest.fixture(scope="module")
def said():
    torch.manual_seed(0)
    return SAiD.from_preset(NAMES, channels=16, cond_dim=16, heads=2, num_steps=8)


def test_mask_of_ones_returns_reference_exactly(said):
    rng = np.random.default_rng(0)
    ref = rng.random((30, 6))
    out = said.generate(rng.standard_normal(8000).astype(np.float32) * 0.1, 30, samples=3, reference=ref, mask=np.ones((30, 6)))
    assert out.shape == (3, 30, 6)
    for s in out:
        np.testing.assert_array_equal(s, ref)


def test_partial_mask_keeps_masked_entries_and_generates_the_rest(said):
    rng = np.random.default_rng(1)
    ref = rng.random((40, 6))
    mask = np.zeros((40, 6))
    mask[:10] = 1  # in-betweening: both ends fixed
    mask[-10:] = 1
    mask[:, 2] = 1  # a per-blendshape constraint
    out = said.generate(rng.standard_normal(11000).astype(np.float32) * 0.1, 40, samples=2, reference=ref, mask=mask, seed=4)
    keep = mask.astype(bool)
    for s in out:
        np.testing.assert_array_equal(s[keep], ref[keep])
        assert np.all((s >= 0) & (s <= 1))
    assert not np.allclose(out[0][~keep], out[1][~keep])


def test_sampler_level_editing_keeps_reference_in_data_space():
    ab = torch.from_numpy(alphas_cumprod_schedule(100)).double()
    ref = torch.rand(12, 4, dtype=torch.float64) * 2 - 1
    mask = torch.zeros(12, 4, dtype=torch.float64)
    mask[:, :2] = 1

    def noise_fn(x, t):
        return torch.zeros_like(x)

    out = sample_diffusion(noise_fn, (2, 12, 4), ab, num_steps=10, reference=ref, mask=mask, generator=torch.Generator().manual_seed(0))
    torch.testing.assert_close(out[:, :, :2], ref[:, :2].expand(2, -1, -1), rtol=0, atol=0)


def test_editing_input_errors(said):
    audio = np.zeros(8000, np.float32)
    with pytest.raises(ValueError, match="both a reference and a mask"):
        said.generate(audio, 30, reference=np.zeros((30, 6)))
    with pytest.raises(ValueError, match="shape"):
        said.generate(audio, 30, reference=np.zeros((29, 6)), mask=np.zeros((29, 6)))
    with pytest.raises(ValueError, match="binary"):
        said.generate(audio, 30, reference=np.zeros((30, 6)), mask=np.full((30, 6), 0.5))
