"""The speech-conditioned code querying model of CDFace (Sec. III-B/C, Eq. 7/8).

For each part, a transformer decoder reads the part's past motion (and, for the
upper face, the past motion of the lip sample it pairs with), the speaker style
token and the audio features (multi-head cross-attention), and an ``N``-head
feed-forward layer turns each frame's output into ``N`` codes, one per sample.
"""

from __future__ import annotations

import torch
from torch import nn

from baselines.cdface.attention import band_mask, causal_band_mask
from baselines.cdface.vqvae import sinusoidal_positions

__all__ = ["AudioProjection", "PartQuery", "cross_alignment_mask", "shift_right"]


def shift_right(x: torch.Tensor, first: torch.Tensor | None = None) -> torch.Tensor:
    """``(B, T, D)`` -> the past ``x_{t-1}`` at every frame; frame 0 gets ``first`` (zeros)."""
    head = torch.zeros_like(x[:, :1]) if first is None else first.reshape(x.shape[0], 1, x.shape[2]).to(x)
    return torch.cat([head, x[:, :-1]], dim=1)


def cross_alignment_mask(query_positions: torch.Tensor, num_keys: int, half_width: int | None) -> torch.Tensor | None:
    """``(Q, K)`` bias letting the frame at position ``p`` see audio frames ``p +- half_width``."""
    if half_width is None:
        return None
    keys = torch.arange(num_keys, device=query_positions.device)[None, :]
    inside = (query_positions[:, None] - keys).abs() <= int(half_width)
    return torch.zeros(inside.shape, device=query_positions.device).masked_fill(~inside, float("-inf"))


class AudioProjection(nn.Module):
    """Trainable part of the audio encoder ``E^a``: frozen features -> width, then self-attention.

    Parameters
    ----------
    feature_dim, width, layers, heads : int
    half_width : int or None
        Self-attention band (frames) over the audio sequence.
    dropout : float
    """

    def __init__(self, feature_dim: int, width: int, layers: int = 1, heads: int = 4,
                 half_width: int | None = 30, dropout: float = 0.0):
        super().__init__()
        self.width = int(width)
        self.half_width = None if half_width is None else int(half_width)
        self.proj = nn.Linear(int(feature_dim), self.width)
        layer = nn.TransformerEncoderLayer(self.width, heads, dim_feedforward=2 * self.width, dropout=dropout, batch_first=True)
        self.encoder = nn.TransformerEncoder(layer, int(layers), enable_nested_tensor=False) if layers else None

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        """``(B, T, feature_dim)`` -> ``(B, T, width)``."""
        h = self.proj(features)
        if self.encoder is not None:
            h = self.encoder(h, mask=band_mask(h.shape[1], self.half_width, device=h.device))
        return h


class PartQuery(nn.Module):
    """Code querying module of one part (Eq. 7 for the lips, Eq. 8 for the upper face).

    Parameters
    ----------
    motion_dim : int
        ``3 V_part`` of the part's own past motion.
    latent_dim : int
        ``h d`` of the part's codes.
    num_samples : int
        ``N`` heads (codes per frame).
    width, layers, heads : int
    context_dim : int or None
        ``3 V_l`` of the lip motion the upper face is conditioned on (None for lips).
    self_context : int or None
        Past frames each frame attends to (None: all).
    audio_half_width : int or None
        Cross-attention alignment band (frames).
    period : int or None
        Period of the positional encoding (frames).
    dropout : float
    """

    def __init__(self, motion_dim: int, latent_dim: int, num_samples: int, width: int = 64, layers: int = 1,
                 heads: int = 4, context_dim: int | None = None, self_context: int | None = 60,
                 audio_half_width: int | None = 2, period: int | None = 60, dropout: float = 0.0):
        super().__init__()
        self.motion_dim, self.latent_dim = int(motion_dim), int(latent_dim)
        self.num_samples, self.width, self.layers = int(num_samples), int(width), int(layers)
        self.self_context = None if self_context is None else int(self_context)
        self.audio_half_width = None if audio_half_width is None else int(audio_half_width)
        self.period = None if period is None else int(period)
        self.motion_in = nn.Linear(self.motion_dim, self.width)
        self.context_in = nn.Linear(int(context_dim), self.width) if context_dim else None
        layer = nn.TransformerDecoderLayer(self.width, heads, dim_feedforward=2 * self.width, dropout=dropout, batch_first=True)
        self.decoder = nn.TransformerDecoder(layer, self.layers)
        self.heads = nn.Linear(self.width, self.num_samples * self.latent_dim)

    @property
    def receptive_field(self) -> int | None:
        """Past frames one output depends on (None: all)."""
        return None if self.self_context is None else self.self_context * self.layers

    def embed(self, past: torch.Tensor, context: torch.Tensor | None = None) -> torch.Tensor:
        """Motion tokens ``(B, Q, width)`` of past motion (plus the lip context)."""
        h = self.motion_in(past)
        if self.context_in is not None:
            if context is None:
                raise ValueError("PartQuery: this part is conditioned on the lips; pass context=")
            h = h + self.context_in(context)
        return h

    def forward(self, past: torch.Tensor, audio: torch.Tensor, style: torch.Tensor, *,
                context: torch.Tensor | None = None, start: int = 0, offset=0, tokens=None, last: bool = False):
        """Codes of every frame of a span.

        Parameters
        ----------
        past : (B, Q, motion_dim) Tensor
            Past motion ``x_{t-1}`` at the Q frames of the span.
        audio : (B, K, width) Tensor
            Audio features of the whole (or windowed) sequence; frame ``start + q``
            of the span is aligned with audio frame ``start + q``.
        style : (B, width) Tensor
        context : (B, Q, context_dim) Tensor, optional
            Past lip motion (upper face only).
        tokens : (B, Q, width) Tensor, optional
            :meth:`embed` of ``past`` and ``context``, when already computed
            (then ``past`` may be None).
        last : bool
            Only the span's last frame: returns ``(N, B, latent_dim)``.
        start : int
            Position of the span's first frame in ``audio``.
        offset : int or (B,) ints
            Frame index of ``audio[:, 0]`` in its sentence (positional encoding).

        Returns
        -------
        (N, B, Q, latent_dim) Tensor
        """
        h = self.embed(past, context) if tokens is None else tokens
        b, q, _ = h.shape
        positions = torch.arange(start, start + q, device=h.device)
        offset = torch.as_tensor(offset, device=h.device).reshape(-1, 1)
        h = h + style[:, None] + sinusoidal_positions(positions[None] + offset, self.width, self.period)
        h = self.decoder(h, audio, tgt_mask=causal_band_mask(q, self.self_context, device=h.device),
                         memory_mask=cross_alignment_mask(positions, audio.shape[1], self.audio_half_width))
        if last:
            return self.heads(h[:, -1]).reshape(b, self.num_samples, self.latent_dim).permute(1, 0, 2)
        return self.heads(h).reshape(b, q, self.num_samples, self.latent_dim).permute(2, 0, 1, 3)
