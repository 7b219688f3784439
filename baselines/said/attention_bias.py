"""The alignment bias of SAiD's cross-attention."""

from __future__ import annotations

import torch


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
