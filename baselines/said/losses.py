"""SAiD's training losses on the noise."""

from __future__ import annotations

import torch


def _check_pair(name: str, a: torch.Tensor, b: torch.Tensor) -> None:
    if a.shape != b.shape:
        raise ValueError(f"{name}: expected two tensors of one shape, got {tuple(a.shape)} and {tuple(b.shape)}")
    if a.ndim != 3:
        raise ValueError(f"{name}: expected (B, T, K) tensors, got shape {tuple(a.shape)}")


def noise_l1_loss(noise: torch.Tensor, noise_pred: torch.Tensor) -> torch.Tensor:
    """Return the mean absolute error between true and predicted noise.

    Parameters
    ----------
    noise, noise_pred : (B, T, K) Tensor

    Returns
    -------
    loss : () Tensor
    """
    _check_pair("noise_l1_loss", noise, noise_pred)
    return (noise - noise_pred).abs().mean()


def velocity_loss(noise: torch.Tensor, noise_pred: torch.Tensor) -> torch.Tensor:
    """Return the noise-level velocity loss.

    ``mean |(n[t+1] - n[t]) - (p[t+1] - p[t])|`` over batch, frames ``t`` and
    coefficients, with ``n`` the true and ``p`` the predicted noise.

    Parameters
    ----------
    noise, noise_pred : (B, T, K) Tensor
        ``T >= 2``.

    Returns
    -------
    loss : () Tensor
    """
    _check_pair("velocity_loss", noise, noise_pred)
    if noise.shape[1] < 2:
        raise ValueError(f"velocity_loss: expected at least 2 frames, got {noise.shape[1]}")
    return (torch.diff(noise, dim=1) - torch.diff(noise_pred, dim=1)).abs().mean()


def said_loss(
    noise: torch.Tensor, noise_pred: torch.Tensor, *, velocity_weight: float = 1.0
) -> torch.Tensor:
    """Return SAiD's training loss, ``noise_l1_loss + velocity_weight * velocity_loss``.

    Parameters
    ----------
    noise, noise_pred : (B, T, K) Tensor
    velocity_weight : float, default 1.0

    Returns
    -------
    loss : () Tensor
    """
    return noise_l1_loss(noise, noise_pred) + velocity_weight * velocity_loss(noise, noise_pred)
