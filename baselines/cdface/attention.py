"""Additive attention masks of the CDFace transformers."""

from __future__ import annotations

import torch

from baselines.common.attention_bias import alignment_bias

__all__ = ["band_mask", "causal_band_mask"]


def band_mask(num_frames: int, half_width: int | None, *, device=None) -> torch.Tensor | None:
    """``(T, T)`` bias: 0 where ``|i - j| <= half_width``, ``-inf`` elsewhere (None: no mask)."""
    if half_width is None:
        return None
    return alignment_bias(num_frames, num_frames, half_width=int(half_width), device=device)


def causal_band_mask(num_frames: int, context: int | None, *, device=None) -> torch.Tensor:
    """``(T, T)`` bias letting frame ``i`` see frames ``i - context .. i`` (all past when None)."""
    i = torch.arange(num_frames, device=device)[:, None]
    j = torch.arange(num_frames, device=device)[None, :]
    allowed = j <= i
    if context is not None:
        allowed &= (i - j) <= int(context)
    bias = torch.zeros((num_frames, num_frames), device=device)
    return bias.masked_fill(~allowed, float("-inf"))
