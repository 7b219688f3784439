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
