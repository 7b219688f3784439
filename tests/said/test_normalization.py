import numpy as np
import pytest
import torch

from baselines.said.normalization import (
    coefficient_normalization,
    data_bounds,
    from_diffusion_space,
    to_diffusion_space,
)


def test_unit_interval_is_two_u_minus_one():
    u = torch.rand(3, 5, 4, dtype=torch.float64)
    mean, scale = (torch.from_numpy(a) for a in coefficient_normalization([u[0].numpy()], "unit-interval"))
    torch.testing.assert_close(to_diffusion_space(u, mean, scale), 2 * u - 1)
    lo, hi = data_bounds(mean, scale)
    assert lo.tolist() == [-1.0] * 4 and hi.tolist() == [1.0] * 4


def test_centered_has_zero_mean_and_round_trips():
    rng = np.random.default_rng(0)
    tracks = [np.column_stack([rng.random(50), 0.3 + 0.1 * rng.random(50), np.full(50, 0.02)]) for _ in range(3)]
    mean, scale = coefficient_normalization(tracks, "centered")
    frames = np.concatenate(tracks)
    np.testing.assert_allclose(mean, frames.mean(0))
    assert scale.tolist() == [0.5] * 3
    m, s = torch.from_numpy(mean), torch.from_numpy(scale)
    x = to_diffusion_space(torch.from_numpy(frames), m, s)
    np.testing.assert_allclose(x.numpy().mean(0), 0, atol=1e-12)
    np.testing.assert_allclose(x.numpy(), 2 * (frames - frames.mean(0)))
    torch.testing.assert_close(from_diffusion_space(x, m, s), torch.from_numpy(frames))
    lo, hi = data_bounds(m, s)
    assert torch.all(lo >= -2) and torch.all(hi <= 2)
    torch.testing.assert_close(from_diffusion_space(torch.stack([lo, hi]), m, s), torch.tensor([[0.0] * 3, [1.0] * 3], dtype=torch.float64))
    with pytest.raises(ValueError, match="kind"):
        coefficient_normalization(tracks, "minmax")


def test_standardized_has_unit_overall_variance_one_scale_and_round_trips():
    rng = np.random.default_rng(1)
    tracks = [np.column_stack([0.2 * rng.random(40), 0.05 + 0.01 * rng.random(40), np.full(40, 0.0)]) for _ in range(3)]
    mean, scale = coefficient_normalization(tracks, "standardized")
    frames = np.concatenate(tracks)
    np.testing.assert_allclose(mean, frames.mean(0))
    assert np.all(scale == scale[0]) and scale[0] == pytest.approx(np.sqrt(frames.var(0).mean()))
    m, s = torch.from_numpy(mean), torch.from_numpy(scale)
    x = to_diffusion_space(torch.from_numpy(frames), m, s).numpy()
    assert np.mean(x.var(0)) == pytest.approx(1.0)
    torch.testing.assert_close(from_diffusion_space(torch.from_numpy(x), m, s), torch.from_numpy(frames))
    lo, hi = data_bounds(m, s)
    torch.testing.assert_close(from_diffusion_space(torch.stack([lo, hi]), m, s), torch.tensor([[0.0] * 3, [1.0] * 3], dtype=torch.float64))
    # constant data: no division by zero
    assert coefficient_normalization([np.full((5, 2), 0.3)], "standardized")[1].tolist() == [0.5, 0.5]
