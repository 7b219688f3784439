"""FaceFormer's attention biases: the periodic ALiBi-style causal bias and the alignment mask.

Self-attention over motion frames adds ``-m_h * floor((i - j) / p)`` for keys ``j <= i``
(slope ``m_h`` per head, period ``p``) and ``-inf`` for future keys ``j > i``.
Cross-attention on VOCASET lets motion frame ``i`` see only audio feature ``i``
(the features are resampled to the motion frame count beforehand).
"""

from __future__ import annotations

import math

import torch

__all__ = ["alibi_slopes", "alignment_mask", "biased_causal_mask"]


def alibi_slopes(n_head: int) -> list[float]:
    """ALiBi head slopes: the geometric sequence ``2^(-8k/n)``, ``k = 1..n`` for a power of two ``n``;
    otherwise the slopes of the next lower power of two followed by every other slope of the next higher.

    Parameters
    ----------
    n_head : int

    Returns
    -------
    list of float, length ``n_head``
    """
    if n_head < 1:
        raise ValueError(f"alibi_slopes: expected n_head >= 1, got {n_head}")

    def power_of_two(n: int) -> list[float]:
        start = 2.0 ** (-(2.0 ** -(math.log2(n) - 3)))
        return [start * start**i for i in range(n)]

    if math.log2(n_head).is_integer():
        return power_of_two(n_head)
    lower = 2 ** math.floor(math.log2(n_head))
    return power_of_two(lower) + alibi_slopes(2 * lower)[0::2][: n_head - lower]


def biased_causal_mask(n_head: int, length: int, period: int) -> torch.Tensor:
    """Additive self-attention mask ``(n_head, length, length)``: periodic linear bias, ``-inf`` above the diagonal.

    Entry ``[h, i, j]`` is ``-slope_h * floor((i - j) / period)`` for ``j <= i`` and ``-inf`` for ``j > i``.

    Parameters
    ----------
    n_head : int
    length : int
        Number of motion frames.
    period : int
        Period ``p`` of the bias (30 on VOCASET, one second at 30 fps).

    Returns
    -------
    (n_head, length, length) float32 Tensor
    """
    if period < 1:
        raise ValueError(f"biased_causal_mask: expected period >= 1, got {period}")
    slopes = torch.tensor(alibi_slopes(n_head), dtype=torch.float32)
    i = torch.arange(length).unsqueeze(1)
    j = torch.arange(length).unsqueeze(0)
    distance = torch.div(i - j, period, rounding_mode="floor").to(torch.float32)
    bias = -slopes[:, None, None] * distance[None]
    return bias.masked_fill((j > i)[None], float("-inf"))


def alignment_mask(num_frames: int, num_features: int, dataset: str = "vocaset") -> torch.Tensor:
    """Boolean cross-attention mask ``(T, S)``: ``True`` where motion frame ``t`` may NOT attend feature ``s``.

    ``"vocaset"``: frame ``t`` sees feature ``t`` only; ``"BIWI"``: features ``2t`` and ``2t + 1``.

    Parameters
    ----------
    num_frames : int
        ``T``, motion frames (queries).
    num_features : int
        ``S``, audio features (keys).
    dataset : {"vocaset", "BIWI"}

    Returns
    -------
    (T, S) bool Tensor
    """
    t = torch.arange(num_frames).unsqueeze(1)
    s = torch.arange(num_features).unsqueeze(0)
    if dataset == "vocaset":
        allowed = s == t
    elif dataset == "BIWI":
        allowed = (s >= 2 * t) & (s < 2 * t + 2)
    else:
        raise ValueError(f"alignment_mask: expected dataset 'vocaset' or 'BIWI', got {dataset!r}")
    return ~allowed
