"""Additive attention biases and boolean attention masks of the baselines' transformers.

SAiD (and CDFace's windowed attention) align coefficient frames with audio frames
through a band: :func:`alignment_bias` (additive, ``-inf`` outside) and
:func:`alignment_mask` (boolean, any ratio of key to query frames).

FaceFormer (and CodeTalker's stage 2, which reuses its decoder) adds to the
self-attention over motion frames the periodic ALiBi-style causal bias
``-m_h * floor((i - j) / p)`` for keys ``j <= i`` (slope ``m_h`` per head, period
``p``) and ``-inf`` for future keys ``j > i`` (:func:`biased_causal_mask`); its
cross-attention lets motion frame ``i`` see only audio feature ``i`` on VOCASET
(:func:`enc_dec_mask`, the features resampled to the motion frame count beforehand).
"""

from __future__ import annotations

import math

import torch

__all__ = ["alibi_slopes", "alignment_bias", "alignment_mask", "biased_causal_mask", "enc_dec_mask"]


def alignment_bias(
    num_queries: int,
    num_keys: int,
    *,
    half_width: int = 1,
    dtype: torch.dtype = torch.float32,
    device: torch.device | str | None = None,
) -> torch.Tensor:
    """Return the additive attention bias that aligns coefficient frames with audio frames.

    ``B[i, j] = 0`` where ``|i - j| <= half_width`` and ``-inf`` elsewhere, so that
    ``softmax(Q K^T / sqrt(d) + B)`` lets coefficient frame ``i`` attend only to the
    audio features of frames ``i - 1, i, i + 1`` (SAiD, ``half_width = 1``).

    Parameters
    ----------
    num_queries : int
        Number of coefficient frames ``T`` (rows).
    num_keys : int
        Number of audio feature frames ``T_a`` (columns).  It may differ from
        ``num_queries``; the band is then cut by the rectangle.
    half_width : int, default 1
        Half width of the band.
    dtype, device
        Of the returned tensor.

    Returns
    -------
    bias : (num_queries, num_keys) Tensor
        ``0`` inside the band, ``-inf`` outside.

    Raises
    ------
    ValueError
        If a size is not positive, or if some query row would have no key inside the
        band (``num_queries > num_keys + half_width``): such a row has a softmax over
        nothing, which is NaN.
    """
    for name, value in (("num_queries", num_queries), ("num_keys", num_keys)):
        if int(value) != value or value < 1:
            raise ValueError(f"alignment_bias: expected {name} >= 1 (int), got {value!r}")
    if int(half_width) != half_width or half_width < 0:
        raise ValueError(f"alignment_bias: expected half_width >= 0 (int), got {half_width!r}")
    if num_queries > num_keys + half_width:
        raise ValueError(
            f"alignment_bias: query frames {num_queries} exceed key frames {num_keys} + "
            f"half_width {half_width}, so the last rows would attend to nothing; resample "
            "the audio features to the coefficient frame count first"
        )
    i = torch.arange(num_queries, device=device)[:, None]
    j = torch.arange(num_keys, device=device)[None, :]
    inside = (i - j).abs() <= half_width
    bias = torch.zeros((num_queries, num_keys), dtype=dtype, device=device)
    return bias.masked_fill(~inside, float("-inf"))


def alignment_mask(num_queries: int, num_keys: int, *, pad: int = 1, device: torch.device | str | None = None) -> torch.Tensor:
    """Return the boolean band of SAiD's cross-attention for any ratio of key to query frames.

    Query frame ``i`` covers key positions ``[lo, hi)`` around its centre
    ``c = (i + 0.5) r`` with ``r = num_keys / num_queries``:
    ``lo = max(round(c - r / 2 - pad), 0)`` and ``hi = min(round(c + r / 2 + pad), num_keys)``,
    rounding half to even.  With ``num_keys == num_queries`` this is the band
    ``|i - j| <= pad`` of :func:`alignment_bias`.

    Parameters
    ----------
    num_queries, num_keys : int
        ``T`` and ``S``, both >= 1.
    pad : int, default 1
        Extra key frames on each side.
    device : optional

    Returns
    -------
    allowed : (num_queries, num_keys) bool Tensor
        True where query ``i`` may attend to key ``j``.
    """
    for name, value in (("num_queries", num_queries), ("num_keys", num_keys)):
        if int(value) != value or value < 1:
            raise ValueError(f"alignment_mask: expected {name} >= 1 (int), got {value!r}")
    ratio = num_keys / num_queries
    half = ratio / 2 + pad
    centre = (torch.arange(num_queries, dtype=torch.float64, device=device) + 0.5) * ratio
    lo = torch.round(centre - half).clamp(min=0)
    hi = torch.round(centre + half).clamp(max=num_keys)
    j = torch.arange(num_keys, dtype=torch.float64, device=device)[None, :]
    return (j >= lo[:, None]) & (j < hi[:, None])


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


def enc_dec_mask(num_frames: int, num_features: int, dataset: str = "vocaset") -> torch.Tensor:
    """FaceFormer's boolean cross-attention mask ``(T, S)``: ``True`` where motion frame ``t`` may NOT attend
    feature ``s`` (the authors' ``enc_dec_mask``).

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
        raise ValueError(f"enc_dec_mask: expected dataset 'vocaset' or 'BIWI', got {dataset!r}")
    return ~allowed
