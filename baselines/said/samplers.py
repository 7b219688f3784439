"""One reverse step of the DDIM and DDPM samplers, over arrays.

Both take the noise estimate ``eps`` at timestep ``t`` and return the sample at the
earlier timestep ``t_prev`` (``alpha_bar_prev = 1`` at the clean end).  Strided
("respaced") chains are handled by using ``alpha_bar[t] / alpha_bar[t_prev]`` as the
step's alpha.
"""

from __future__ import annotations

import torch

SAMPLERS = ("ddim", "ddpm")


def predicted_x0(x_t: torch.Tensor, eps: torch.Tensor, alpha_bar: torch.Tensor) -> torch.Tensor:
    """Return ``x0 = (x_t - sqrt(1 - alpha_bar) eps) / sqrt(alpha_bar)``.

    Parameters
    ----------
    x_t, eps : (B, T, K) Tensor
    alpha_bar : () Tensor

    Returns
    -------
    x0 : (B, T, K) Tensor
    """
    return (x_t - (1.0 - alpha_bar).sqrt() * eps) / alpha_bar.sqrt()


def _x0_and_eps(x_t, eps, alpha_bar, clip):
    x0 = predicted_x0(x_t, eps, alpha_bar)
    if clip is not None:
        # Clipping keeps x0 on the data range.  The direction term keeps the model's
        # eps: recomputing eps from the clipped x0 would carry the x0 of the first,
        # nearly pure-noise steps (where x0 = (x_t - eps) / sqrt(alpha_bar) amplifies
        # every error) into the whole chain.
        x0 = x0.clamp(clip[0], clip[1]) if isinstance(clip, tuple) else x0.clamp(-clip, clip)
    return x0, eps


def ddim_step(
    x_t: torch.Tensor,
    eps: torch.Tensor,
    alpha_bar: torch.Tensor,
    alpha_bar_prev: torch.Tensor,
    *,
    eta: float = 0.0,
    noise: torch.Tensor | None = None,
    clip: float | tuple | None = 1.0,
) -> torch.Tensor:
    """Return ``x_{t_prev}`` by one DDIM step (Song et al. 2021, eq. 12).

    Parameters
    ----------
    x_t, eps : (B, T, K) Tensor
        Current sample and its noise estimate.
    alpha_bar, alpha_bar_prev : () Tensor
        ``alpha_bar`` at ``t`` and at ``t_prev`` (1 at the clean end).
    eta : float, default 0.0
        0: deterministic DDIM; 1: the DDPM posterior variance.
    noise : (B, T, K) Tensor, optional
        Fresh standard normal noise, needed when ``eta > 0``.
    clip : float, (lo, hi) pair of (K,) Tensors, or None; default 1.0
        Clamp the predicted ``x0`` to ``[-clip, clip]`` or per column to ``[lo, hi]``;
        None: no clamp.

    Returns
    -------
    x_prev : (B, T, K) Tensor
    """
    x0, eps = _x0_and_eps(x_t, eps, alpha_bar, clip)
    var = (1.0 - alpha_bar_prev) / (1.0 - alpha_bar) * (1.0 - alpha_bar / alpha_bar_prev)
    sigma = eta * var.clamp(min=0.0).sqrt()
    direction = (1.0 - alpha_bar_prev - sigma**2).clamp(min=0.0).sqrt() * eps
    x_prev = alpha_bar_prev.sqrt() * x0 + direction
    if eta > 0:
        if noise is None:
            raise ValueError("ddim_step: eta > 0 needs a noise tensor")
        x_prev = x_prev + sigma * noise
    return x_prev


def ddpm_step(
    x_t: torch.Tensor,
    eps: torch.Tensor,
    alpha_bar: torch.Tensor,
    alpha_bar_prev: torch.Tensor,
    *,
    noise: torch.Tensor,
    clip: float | tuple | None = 1.0,
) -> torch.Tensor:
    """Return ``x_{t_prev}`` drawn from the DDPM posterior ``q(x_prev | x_t, x0)`` (Ho et al. 2020).

    Mean ``sqrt(ab_prev) beta / (1 - ab) x0 + sqrt(alpha) (1 - ab_prev) / (1 - ab) x_t``,
    variance ``beta (1 - ab_prev) / (1 - ab)``, with ``alpha = ab / ab_prev`` and
    ``beta = 1 - alpha``.

    Parameters
    ----------
    x_t, eps : (B, T, K) Tensor
    alpha_bar, alpha_bar_prev : () Tensor
    noise : (B, T, K) Tensor
        Fresh standard normal noise.
    clip : float, (lo, hi) pair of (K,) Tensors, or None; default 1.0

    Returns
    -------
    x_prev : (B, T, K) Tensor
    """
    x0, _ = _x0_and_eps(x_t, eps, alpha_bar, clip)
    alpha = alpha_bar / alpha_bar_prev
    beta = 1.0 - alpha
    mean = (alpha_bar_prev.sqrt() * beta / (1.0 - alpha_bar)) * x0 + (
        alpha.sqrt() * (1.0 - alpha_bar_prev) / (1.0 - alpha_bar)
    ) * x_t
    var = beta * (1.0 - alpha_bar_prev) / (1.0 - alpha_bar)
    return mean + var.clamp(min=0.0).sqrt() * noise
