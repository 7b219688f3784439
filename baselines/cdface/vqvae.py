"""One facial part's VQ prior (CDFace Sec. III-A): self-attention encoder, codebook, decoder.

A frame's part motion ``x_t`` (``3 V_part`` displacement values) is encoded into
``h`` vectors of size ``d`` (``z_t in R^{h x d}``), each replaced by its nearest
entry of a ``K``-entry codebook (:class:`baselines.vq.VectorQuantizer`), and decoded
back. Encoder and decoder are transformer encoders over time whose self-attention
is limited to a band of ``+-half_width`` frames (None: every frame), so a frame's
code describes local motion.
"""

from __future__ import annotations

import math

import torch
from torch import nn

from baselines.cdface.attention import band_mask
from baselines.vq import VectorQuantizer

__all__ = ["PartVQVAE", "sinusoidal_positions", "vq_loss"]


def sinusoidal_positions(positions: torch.Tensor, dim: int, period: float | None = None) -> torch.Tensor:
    """Sinusoidal encoding of frame indices, ``(..., T) -> (..., T, dim)``.

    With ``period`` the indices are taken modulo it first (FaceFormer's periodic
    positional encoding), so the encoding repeats every ``period`` frames.
    """
    positions = positions.to(torch.float32)
    if period is not None:
        positions = torch.remainder(positions, float(period))
    half = dim // 2
    freqs = torch.exp(-math.log(10000.0) * torch.arange(half, dtype=torch.float32, device=positions.device) / max(half, 1))
    angles = positions[..., None] * freqs
    enc = torch.cat([torch.sin(angles), torch.cos(angles)], dim=-1)
    if dim % 2:
        enc = torch.nn.functional.pad(enc, (0, 1))
    return enc


def _encoder_stack(width: int, layers: int, heads: int, dropout: float) -> nn.TransformerEncoder:
    layer = nn.TransformerEncoderLayer(width, heads, dim_feedforward=2 * width, dropout=dropout, batch_first=True)
    return nn.TransformerEncoder(layer, layers, enable_nested_tensor=False)


class PartVQVAE(nn.Module):
    """VQ-VAE of one facial part.

    Parameters
    ----------
    in_dim : int
        ``3 V_part``.
    hidden : int
        Transformer width.
    layers, heads : int
        Transformer depth and heads (encoder and decoder each).
    num_codes : int
        ``h``, codebook vectors per frame.
    code_dim : int
        ``d``, size of a codebook vector.
    codebook_size : int
        ``K``.
    half_width : int or None
        Self-attention band half width in frames.
    period : int or None
        Period (frames) of the positional encoding; with one, a window cut
        anywhere at a multiple of it is encoded as in the whole sequence.
    dropout : float
    """

    def __init__(self, in_dim: int, hidden: int = 64, layers: int = 1, heads: int = 4, num_codes: int = 4,
                 code_dim: int = 16, codebook_size: int = 64, half_width: int | None = 4, period: int | None = 60,
                 dropout: float = 0.0):
        super().__init__()
        self.in_dim, self.hidden = int(in_dim), int(hidden)
        self.num_codes, self.code_dim = int(num_codes), int(code_dim)
        self.half_width = None if half_width is None else int(half_width)
        self.layers = int(layers)
        self.period = None if period is None else int(period)
        self.encoder_in = nn.Sequential(nn.Linear(self.in_dim, self.hidden), nn.LeakyReLU(0.2))
        self.encoder = _encoder_stack(self.hidden, self.layers, heads, dropout)
        self.encoder_out = nn.Linear(self.hidden, self.num_codes * self.code_dim)
        self.quantize = VectorQuantizer(codebook_size, self.code_dim, beta=1.0)
        self.decoder_in = nn.Sequential(nn.Linear(self.num_codes * self.code_dim, self.hidden), nn.LeakyReLU(0.2))
        self.decoder = _encoder_stack(self.hidden, self.layers, heads, dropout)
        self.decoder_out = nn.Linear(self.hidden, self.in_dim)

    @property
    def latent_dim(self) -> int:
        """``h d``, the size of one frame's flattened code."""
        return self.num_codes * self.code_dim

    @property
    def receptive_field(self) -> int | None:
        """Frames on each side that one decoded frame depends on (None: all)."""
        return None if self.half_width is None else self.half_width * self.layers

    def _positions(self, x: torch.Tensor, offset) -> torch.Tensor:
        positions = torch.arange(x.shape[1], device=x.device)
        offset = torch.as_tensor(offset, device=x.device).reshape(-1, 1)
        return sinusoidal_positions(positions[None] + offset, self.hidden, self.period)

    def encode(self, x: torch.Tensor, offset=0) -> torch.Tensor:
        """``(B, T, in_dim)`` motion -> ``(B, T, h d)`` continuous latents ``z``.

        ``offset`` (int or (B,) ints): frame index of ``x[:, 0]`` in its sentence.
        """
        if x.ndim != 3 or x.shape[-1] != self.in_dim:
            raise ValueError(f"PartVQVAE.encode: expected motion (B, T, {self.in_dim}), got {tuple(x.shape)}")
        h = self.encoder_in(x) + self._positions(x, offset)
        h = self.encoder(h, mask=band_mask(x.shape[1], self.half_width, device=x.device))
        return self.encoder_out(h)

    def quantized(self, z: torch.Tensor):
        """Nearest codes of ``z`` ``(..., T, h d)``, straight-through.

        Returns
        -------
        q : same shape as ``z``
        loss : scalar Tensor, ``||sg(z) - q||^2 + ||z - sg(q)||^2`` (means)
        indices : (..., T, h) int64 Tensor
        """
        lead = z.shape[:-1]
        flat = z.reshape(1, -1, self.code_dim)
        q, loss, (_, _, indices) = self.quantize(flat)
        return q.permute(0, 2, 1).reshape(z.shape), loss, indices.reshape(*lead, self.num_codes)

    def codes(self, indices: torch.Tensor) -> torch.Tensor:
        """``(..., T, h)`` code indices -> ``(..., T, h d)`` codebook vectors."""
        lead = indices.shape[:-1]
        return self.quantize.get_codebook_entry(indices.reshape(-1)).reshape(*lead, self.latent_dim)

    def decode(self, q: torch.Tensor, offset=0, last: bool = False) -> torch.Tensor:
        """``(B, T, h d)`` quantized latents -> ``(B, T, in_dim)`` motion (``offset`` as in :meth:`encode`);
        ``last``: only the last frame, ``(B, in_dim)``."""
        if q.ndim != 3 or q.shape[-1] != self.latent_dim:
            raise ValueError(f"PartVQVAE.decode: expected codes (B, T, {self.latent_dim}), got {tuple(q.shape)}")
        h = self.decoder_in(q) + self._positions(q, offset)
        h = self.decoder(h, mask=band_mask(q.shape[1], self.half_width, device=q.device))
        return self.decoder_out(h[:, -1] if last else h)

    def forward(self, x: torch.Tensor, offset=0):
        """Reconstruction ``(B, T, in_dim)`` and the VQ loss of the codes."""
        q, loss, _ = self.quantized(self.encode(x, offset))
        return self.decode(q, offset), loss


def vq_loss(model: PartVQVAE, x: torch.Tensor, offset=0) -> dict:
    """Eq. 3: ``||x - x_hat||^2 + ||sg(z) - q||^2 + ||z - sg(q)||^2`` (each a mean).

    Returns
    -------
    dict with ``total``, ``reconstruction``, ``quantization``.
    """
    recon, quant = model(x, offset)
    rec = torch.mean((recon - x) ** 2)
    return {"total": rec + quant, "reconstruction": rec, "quantization": quant}
