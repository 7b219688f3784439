import numpy as np
import pytest
import torch

from baselines.said.sample import sample_diffusion
from baselines.said.samplers import ddim_step, ddpm_step
from baselines.said.schedule import (
    add_noise,
    alphas_cumprod_schedule,
    alphas_of,
    sampling_timesteps,
)


@pytest.mark.parametrize("kind", ["cosine", "linear", "scaled_linear"])
def test_schedule_is_decreasing_in_unit_interval(kind):
    ab = alphas_cumprod_schedule(1000, kind)
    assert ab.shape == (1000,)
    assert np.all(np.diff(ab) < 0) and 0 < ab[-1] < ab[0] < 1


def test_linear_schedule_closed_form():
    betas = np.linspace(1e-4, 0.02, 10)
    np.testing.assert_allclose(alphas_cumprod_schedule(10, "linear"), np.cumprod(1 - betas))


def test_sampling_timesteps():
    assert sampling_timesteps(1000, 1000).tolist() == list(range(999, -1, -1))
    assert sampling_timesteps(1000, 4).tolist() == [999, 749, 499, 249]
    assert sampling_timesteps(10, 1).tolist() == [9]
    with pytest.raises(ValueError):
        sampling_timesteps(10, 11)


def test_add_noise_closed_form_and_clean_end():
    ab = torch.from_numpy(alphas_cumprod_schedule(100)).double()
    x0, n = torch.randn(2, 4, 3, dtype=torch.float64), torch.randn(2, 4, 3, dtype=torch.float64)
    t = torch.tensor([10, -1])
    xt = add_noise(x0, n, t, ab)
    torch.testing.assert_close(xt[0], ab[10].sqrt() * x0[0] + (1 - ab[10]).sqrt() * n[0])
    torch.testing.assert_close(xt[1], x0[1])
    assert alphas_of(torch.tensor([-1]), ab).item() == 1.0


def _oracle(x0, ab):
    def noise_fn(x, t):
        a = alphas_of(t, ab)[:, None, None]
        return (x - a.sqrt() * x0) / (1 - a).sqrt()

    return noise_fn


@pytest.mark.parametrize("sampler, steps, eta", [("ddim", 1, 0.0), ("ddim", 10, 0.0), ("ddim", 50, 0.0), ("ddim", 20, 1.0), ("ddpm", 25, 0.0), ("ddpm", 1000, 0.0)])
def test_perfect_noise_oracle_reconstructs_x0(sampler, steps, eta):
    ab = torch.from_numpy(alphas_cumprod_schedule(1000)).double()
    x0 = torch.rand(3, 20, 32, dtype=torch.float64) * 2 - 1
    g = torch.Generator().manual_seed(0)
    out = sample_diffusion(_oracle(x0, ab), x0.shape, ab, sampler=sampler, num_steps=steps, eta=eta, generator=g)
    torch.testing.assert_close(out, x0, rtol=0, atol=1e-9)


def test_ddpm_step_equals_ddim_step_with_eta_one():
    ab = torch.from_numpy(alphas_cumprod_schedule(1000)).double()
    x, eps, z = (torch.randn(2, 7, 4, dtype=torch.float64) for _ in range(3))
    for t, tp in [(999, 899), (500, 480), (10, 0)]:
        a = ddim_step(x, eps, ab[t], ab[tp], eta=1.0, noise=z, clip=None)
        b = ddpm_step(x, eps, ab[t], ab[tp], noise=z, clip=None)
        torch.testing.assert_close(a, b)


def test_deterministic_ddim_is_reproducible_and_stochastic_ddpm_varies():
    ab = torch.from_numpy(alphas_cumprod_schedule(1000)).double()

    def zero(x, t):
        return torch.zeros_like(x)

    a = sample_diffusion(zero, (2, 5, 3), ab, num_steps=10, generator=torch.Generator().manual_seed(3))
    b = sample_diffusion(zero, (2, 5, 3), ab, num_steps=10, generator=torch.Generator().manual_seed(3))
    torch.testing.assert_close(a, b)
    assert not torch.allclose(a[0], a[1])


def test_v_parametrization_gives_the_true_noise_for_the_true_v():
    from baselines.said.parametrization import noise_from_output

    ab = torch.from_numpy(alphas_cumprod_schedule(1000)).double()
    x0, eps = torch.randn(3, 6, 4, dtype=torch.float64), torch.randn(3, 6, 4, dtype=torch.float64)
    t = torch.tensor([0, 500, 999])
    a = ab[t][:, None, None]
    x_t = add_noise(x0, eps, t, ab)
    v = a.sqrt() * eps - (1 - a).sqrt() * x0
    torch.testing.assert_close(noise_from_output(v, x_t, ab[t], "v"), eps)
    torch.testing.assert_close(noise_from_output(eps, x_t, ab[t], "epsilon"), eps)
    with pytest.raises(ValueError, match="prediction"):
        noise_from_output(v, x_t, ab[t], "x0")
