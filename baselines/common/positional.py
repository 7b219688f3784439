"""The periodic positional encoding of FaceFormer and CodeTalker (sinusoids repeating every ``period`` frames)."""

from __future__ import annotations

import math

import torch
from torch import nn

__all__ = ["PeriodicPositionalEncoding", "period_of_encoding", "periodic_encoding"]


def periodic_encoding(d_model: int, period: int, length: int) -> torch.Tensor:
    """Sinusoidal encoding of positions ``t mod period``: ``(1, length, d_model)``.

    Channel ``2k`` is ``sin(pos * w_k)``, channel ``2k + 1`` is ``cos(pos * w_k)``,
    ``w_k = 10000^(-2k / d_model)``.
    """
    if d_model % 2:
        raise ValueError(f"periodic_encoding: expected an even d_model, got {d_model}")
    position = (torch.arange(length) % period).to(torch.float32).unsqueeze(1)
    div_term = torch.exp(torch.arange(0, d_model, 2).float() * (-math.log(10000.0) / d_model))
    pe = torch.zeros(length, d_model)
    pe[:, 0::2] = torch.sin(position * div_term)
    pe[:, 1::2] = torch.cos(position * div_term)
    return pe.unsqueeze(0)


def period_of_encoding(pe: torch.Tensor) -> int:
    """Period of a periodic positional encoding buffer ``(1, L, d)``: the first row equal to row 0."""
    rows = pe.reshape(pe.shape[-2], pe.shape[-1])
    for t in range(1, rows.shape[0]):
        if torch.equal(rows[t], rows[0]):
            return t
    return rows.shape[0]


class PeriodicPositionalEncoding(nn.Module):
    """Adds the periodic encoding, then dropout (the authors' ``PPE``).

    The buffer ``pe`` has the authors' shape ``(1, period * (max_seq_len // period + 1), d_model)``;
    longer inputs get the same periodic values computed on the fly.

    Parameters
    ----------
    d_model : int
    dropout : float, default 0.1
    period : int, default 25
    max_seq_len : int, default 600
    """

    def __init__(self, d_model: int, dropout: float = 0.1, period: int = 25, max_seq_len: int = 600):
        super().__init__()
        self.period = int(period)
        self.dropout = nn.Dropout(p=dropout)
        self.register_buffer("pe", periodic_encoding(d_model, self.period, self.period * (max_seq_len // self.period + 1)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """x: (B, T, d_model) -> (B, T, d_model)."""
        if x.shape[1] <= self.pe.shape[1]:
            pe = self.pe[:, : x.shape[1]]
        else:
            pe = periodic_encoding(x.shape[2], self.period, x.shape[1]).to(x)
        return self.dropout(x + pe)

    def at(self, t: int, like: torch.Tensor) -> torch.Tensor:
        """The encoding ``(1, 1, d_model)`` of frame ``t`` (no dropout), in ``like``'s dtype and device past the
        buffer (the step of an autoregressive loop)."""
        if t < self.pe.shape[1]:
            return self.pe[:, t : t + 1]
        return periodic_encoding(like.shape[2], self.period, t + 1)[:, t:].to(like)
