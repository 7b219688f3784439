"""Noise schedules of the diffusion process and the forward (noising) step."""

from __future__ import annotations

import math

import numpy as np
import torch

from blendvoca.errors import UserError

SCHEDULES = ("cosine", "linear", "scaled_linear")


def alphas_cumprod_schedule(
    num_train_steps: int = 1000,
    kind: str = "cosine",
    *,
    beta_start: float = 1e-4,
    beta_end: float = 0.02,
) -> np.ndarray:
    """Return the cumulative products ``alpha_bar[t] = prod_{s<=t} (1 - beta[s])``.

    Parameters
    ----------
    num_train_steps : int, default 1000
        Number of diffusion steps ``N`` of training.
    kind : {"cosine", "linear", "scaled_linear"}, default "cosine"
        ``cosine``: Nichol & Dhariwal's schedule (betas capped at 0.999);
        ``linear``: betas linear from ``beta_start`` to ``beta_end`` (DDPM);
        ``scaled_linear``: square roots of betas linear (Stable Diffusion).
    beta_start, beta_end : float
        Ends of the linear schedules.

    Returns
    -------
    alphas_cumprod : (N,) float64 ndarray
        Decreasing, in (0, 1).
    """
    if int(num_train_steps) != num_train_steps or num_train_steps < 2:
        raise ValueError(f"alphas_cumprod_schedule: expected num_train_steps >= 2, got {num_train_steps!r}")
    n = int(num_train_steps)
    if kind == "cosine":
        def alpha_bar(s: np.ndarray) -> np.ndarray:
            return np.cos((s / n + 0.008) / 1.008 * math.pi / 2) ** 2

        s = np.arange(n, dtype=np.float64)
        betas = np.minimum(1.0 - alpha_bar(s + 1) / alpha_bar(s), 0.999)
    elif kind == "linear":
        betas = np.linspace(beta_start, beta_end, n, dtype=np.float64)
    elif kind == "scaled_linear":
        betas = np.linspace(beta_start**0.5, beta_end**0.5, n, dtype=np.float64) ** 2
    else:
        raise ValueError(f"alphas_cumprod_schedule: expected kind in {SCHEDULES}, got {kind!r}")
    return np.cumprod(1.0 - betas)


def sampling_timesteps(num_train_steps: int, num_steps: int) -> np.ndarray:
    """Return the decreasing training timesteps visited by a sampler with ``num_steps`` steps.

    "Trailing" spacing: the first step is always ``N - 1`` (pure noise) and with
    ``num_steps == N`` every timestep is visited.

    Parameters
    ----------
    num_train_steps : int
        ``N``.
    num_steps : int
        ``1 <= num_steps <= N``.

    Returns
    -------
    timesteps : (num_steps,) int64 ndarray
        Strictly decreasing, from ``N - 1``.
    """
    if int(num_steps) != num_steps or not 1 <= num_steps <= num_train_steps:
        raise UserError(
            f"sampling_timesteps: expected 1 <= num_steps <= {num_train_steps}, got {num_steps!r}"
        )
    steps = np.round(np.arange(num_train_steps, 0, -num_train_steps / num_steps)).astype(np.int64) - 1
    return steps[:num_steps]


def add_noise(
    x0: torch.Tensor, noise: torch.Tensor, timesteps: torch.Tensor, alphas_cumprod: torch.Tensor
) -> torch.Tensor:
    """Return ``x_t = sqrt(alpha_bar[t]) x0 + sqrt(1 - alpha_bar[t]) noise``.

    Parameters
    ----------
    x0, noise : (B, T, K) Tensor
    timesteps : (B,) int64 Tensor
        A timestep per batch item; ``-1`` means "no noise" (``alpha_bar = 1``).
    alphas_cumprod : (N,) Tensor

    Returns
    -------
    x_t : (B, T, K) Tensor
    """
    if x0.shape != noise.shape:
        raise ValueError(f"add_noise: expected x0 and noise of one shape, got {tuple(x0.shape)} and {tuple(noise.shape)}")
    if timesteps.shape != (x0.shape[0],):
        raise ValueError(f"add_noise: expected timesteps of shape ({x0.shape[0]},), got {tuple(timesteps.shape)}")
    ab = alphas_of(timesteps, alphas_cumprod).to(x0.dtype)[:, None, None]
    return ab.sqrt() * x0 + (1.0 - ab).sqrt() * noise


def alphas_of(timesteps: torch.Tensor, alphas_cumprod: torch.Tensor) -> torch.Tensor:
    """Return ``alpha_bar[t]`` with ``alpha_bar[-1] = 1`` (the clean end of the chain).

    Parameters
    ----------
    timesteps : (B,) int64 Tensor
    alphas_cumprod : (N,) Tensor

    Returns
    -------
    alpha_bar : (B,) Tensor
    """
    t = timesteps.long()
    if (t < -1).any() or (t >= alphas_cumprod.shape[0]).any():
        raise ValueError(f"alphas_of: expected timesteps in [-1, {alphas_cumprod.shape[0] - 1}], got {t.tolist()}")
    padded = torch.cat([alphas_cumprod.new_ones(1), alphas_cumprod])
    return padded[t + 1]


def authors_alphas_cumprod(num_train_steps: int = 1000, max_beta: float = 0.999) -> torch.Tensor:
    """Return the cosine ``alpha_bar`` as SAiD's schedulers hold it (``squaredcos_cap_v2``), in float32.

    The betas ``min(1 - f((i + 1) / N) / f(i / N), max_beta)`` with
    ``f(s) = cos((s + 0.008) / 1.008 * pi / 2)^2`` are rounded to float32 first and
    the cumulative product is taken in float32, so the values equal the schedulers'
    own to the last bit (the float64 :func:`alphas_cumprod_schedule` differs by
    about 1e-7).

    Returns
    -------
    alphas_cumprod : (N,) float32 Tensor
    """
    n = int(num_train_steps)

    def f(s):
        return math.cos((s + 0.008) / 1.008 * math.pi / 2) ** 2

    betas = torch.tensor([min(1 - f((i + 1) / n) / f(i / n), max_beta) for i in range(n)], dtype=torch.float32)
    return torch.cumprod(1.0 - betas, dim=0)


def leading_timesteps(num_train_steps: int, num_steps: int) -> np.ndarray:
    """Return the "leading" timesteps ``(num_steps - 1 - k) * (N // num_steps)`` of SAiD's inference (ends at 0).

    Returns
    -------
    timesteps : (num_steps,) int64 ndarray, strictly decreasing
    """
    if int(num_steps) != num_steps or not 1 <= num_steps <= num_train_steps:
        raise UserError(f"leading_timesteps: expected 1 <= num_steps <= {num_train_steps}, got {num_steps!r}")
    ratio = int(num_train_steps) // int(num_steps)
    return (np.arange(int(num_steps) - 1, -1, -1) * ratio).astype(np.int64)
