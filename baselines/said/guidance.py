"""Classifier-free guidance."""

from __future__ import annotations

import torch


def classifier_free_guidance(
    eps_cond: torch.Tensor, eps_uncond: torch.Tensor, gamma: float = 2.0
) -> torch.Tensor:
    """Return the guided noise estimate ``eps_cond + gamma * (eps_cond - eps_uncond)``.

    SAiD's form: ``gamma = 0`` is the plain conditional model, larger values push the
    sample further from the unconditional one.

    Parameters
    ----------
    eps_cond : (B, T, K) Tensor
        Noise predicted with the audio condition.
    eps_uncond : (B, T, K) Tensor
        Noise predicted with the null condition.
    gamma : float, default 2.0
        Guidance strength.

    Returns
    -------
    eps : (B, T, K) Tensor
    """
    if eps_cond.shape != eps_uncond.shape:
        raise ValueError(
            "classifier_free_guidance: expected eps_cond and eps_uncond of one shape, got "
            f"{tuple(eps_cond.shape)} and {tuple(eps_uncond.shape)}"
        )
    return eps_cond + gamma * (eps_cond - eps_uncond)


def rescale_guidance(eps: torch.Tensor, eps_cond: torch.Tensor, rescale: float) -> torch.Tensor:
    """Return the guided estimate with its spread pulled back towards the conditional one's.

    ``rescale * eps * (std(eps_cond) / std(eps)) + (1 - rescale) * eps`` with the
    (unbiased) standard deviation over each item's frames and channels (Lin et
    al. 2024, sec. 3.4; SAiD's ``guidance_rescale``).

    Parameters
    ----------
    eps, eps_cond : (B, T, K) Tensor
        Guided and conditional noise estimates.
    rescale : float
        In [0, 1]; 0 returns ``eps``.

    Returns
    -------
    (B, T, K) Tensor
    """
    dims = tuple(range(1, eps.ndim))
    ratio = eps_cond.std(dim=dims, keepdim=True) / eps.std(dim=dims, keepdim=True)
    return rescale * (eps * ratio) + (1.0 - rescale) * eps
