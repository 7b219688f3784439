"""SAiD's denoiser: a conditional 1-D UNet with aligned cross-attention to audio features.

Stable-Diffusion-style blocks simplified as in the paper: one encoder block, one
middle block, one decoder block, no down- or up-sampling.  A sinusoidal timestep
embedding enters every residual block; every transformer block has self-attention
over frames, cross-attention whose keys and values are audio features (with the
alignment bias of :func:`baselines.common.attention_bias.alignment_bias`) and a
feed-forward layer.  :class:`SAiDModel` adds the frozen speech encoder, a small
trainable audio adapter and the trainable null condition of classifier-free guidance.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from baselines.common.attention_bias import alignment_bias
from baselines.common.encoders import build_encoder
from baselines.said.unet1d import ZERO_INIT_GROUPS, ConditionalUNet1D, timestep_embedding

ARCHITECTURES = ("authors", "compact")


def _groups(channels: int, wanted: int = 32) -> int:
    return math.gcd(channels, wanted)


def zero_init_groups(zero_init) -> tuple[str, ...]:
    """The zero-initialised layer groups that the model key ``zero_init`` names.

    ``True``: all of :data:`~baselines.said.unet1d.ZERO_INIT_GROUPS` (the authors'
    initialisation); ``False``: none; a list of group names: those.
    """
    if isinstance(zero_init, bool):
        return ZERO_INIT_GROUPS if zero_init else ()
    if isinstance(zero_init, (list, tuple)) and all(isinstance(g, str) for g in zero_init):
        unknown = sorted(set(zero_init) - set(ZERO_INIT_GROUPS))
        if not unknown:
            return tuple(g for g in ZERO_INIT_GROUPS if g in zero_init)
    raise ValueError(f"SAiDModel: expected zero_init true, false or a list of groups among {list(ZERO_INIT_GROUPS)}, "
                     f"got {zero_init!r}")


class ResBlock1D(nn.Module):
    """Residual block: GroupNorm-SiLU-Conv, plus the projected timestep embedding, twice."""

    def __init__(self, in_channels: int, out_channels: int, temb_dim: int, dropout: float = 0.0):
        super().__init__()
        self.norm1 = nn.GroupNorm(_groups(in_channels), in_channels)
        self.conv1 = nn.Conv1d(in_channels, out_channels, 3, padding=1)
        self.temb = nn.Linear(temb_dim, out_channels)
        self.norm2 = nn.GroupNorm(_groups(out_channels), out_channels)
        self.dropout = nn.Dropout(dropout)
        self.conv2 = nn.Conv1d(out_channels, out_channels, 3, padding=1)
        self.skip = nn.Conv1d(in_channels, out_channels, 1) if in_channels != out_channels else nn.Identity()

    def forward(self, x: torch.Tensor, temb: torch.Tensor) -> torch.Tensor:
        """x: (B, C_in, T), temb: (B, temb_dim) -> (B, C_out, T)."""
        h = self.conv1(F.silu(self.norm1(x)))
        h = h + self.temb(F.silu(temb))[:, :, None]
        h = self.conv2(self.dropout(F.silu(self.norm2(h))))
        return self.skip(x) + h


class Attention(nn.Module):
    """Multi-head attention ``softmax(Q K^T / sqrt(d) + bias) V`` with separate query and context sizes."""

    def __init__(self, dim: int, context_dim: int, heads: int):
        super().__init__()
        if dim % heads:
            raise ValueError(f"Attention: expected dim divisible by heads, got dim={dim}, heads={heads}")
        self.heads = heads
        self.to_q = nn.Linear(dim, dim, bias=False)
        self.to_k = nn.Linear(context_dim, dim, bias=False)
        self.to_v = nn.Linear(context_dim, dim, bias=False)
        self.to_out = nn.Linear(dim, dim)

    def forward(self, x: torch.Tensor, context: torch.Tensor, bias: torch.Tensor | None = None) -> torch.Tensor:
        """x: (B, T, dim), context: (B, S, context_dim), bias: (T, S) or None -> (B, T, dim)."""
        b, t, d = x.shape
        h = self.heads

        def split(z):
            return z.reshape(b, z.shape[1], h, d // h).transpose(1, 2)

        q, k, v = split(self.to_q(x)), split(self.to_k(context)), split(self.to_v(context))
        out = F.scaled_dot_product_attention(q, k, v, attn_mask=None if bias is None else bias.to(q.dtype))
        return self.to_out(out.transpose(1, 2).reshape(b, t, d))


class TransformerBlock1D(nn.Module):
    """Self-attention, aligned cross-attention to the condition, feed-forward; residual around it all."""

    def __init__(self, channels: int, cond_dim: int, heads: int, dropout: float = 0.0):
        super().__init__()
        self.norm = nn.GroupNorm(_groups(channels), channels)
        self.proj_in = nn.Linear(channels, channels)
        self.norm1 = nn.LayerNorm(channels)
        self.self_attn = Attention(channels, channels, heads)
        self.norm2 = nn.LayerNorm(channels)
        self.cross_attn = Attention(channels, cond_dim, heads)
        self.norm3 = nn.LayerNorm(channels)
        self.ff = nn.Sequential(nn.Linear(channels, 4 * channels), nn.GELU(), nn.Dropout(dropout), nn.Linear(4 * channels, channels))
        self.proj_out = nn.Linear(channels, channels)

    def forward(self, x: torch.Tensor, cond: torch.Tensor, bias: torch.Tensor) -> torch.Tensor:
        """x: (B, C, T), cond: (B, S, cond_dim), bias: (T, S) -> (B, C, T)."""
        h = self.proj_in(self.norm(x).transpose(1, 2))
        n = self.norm1(h)
        h = h + self.self_attn(n, n)
        h = h + self.cross_attn(self.norm2(h), cond, bias)
        h = h + self.ff(self.norm3(h))
        return x + self.proj_out(h).transpose(1, 2)


class UNet1DCondition(nn.Module):
    """The denoiser ``eps(x_t, t, cond)``: encoder, middle and decoder block at one resolution.

    Parameters
    ----------
    num_coeffs : int
        ``K``, channels of the coefficient track.
    channels : int
        Width of every block.
    cond_dim : int
        Size of a condition (audio feature) vector.
    heads : int
        Attention heads.
    dropout : float
    attention_half_width : int
        Half width of the alignment bias band.
    """

    def __init__(self, num_coeffs: int = 32, channels: int = 64, cond_dim: int = 64, heads: int = 4, dropout: float = 0.0, attention_half_width: int = 1):
        super().__init__()
        self.channels, self.half_width = channels, attention_half_width
        temb_dim = 4 * channels
        self.time_mlp = nn.Sequential(nn.Linear(channels, temb_dim), nn.SiLU(), nn.Linear(temb_dim, temb_dim))
        self.conv_in = nn.Conv1d(num_coeffs, channels, 3, padding=1)
        self.down_res = ResBlock1D(channels, channels, temb_dim, dropout)
        self.down_attn = TransformerBlock1D(channels, cond_dim, heads, dropout)
        self.mid_res1 = ResBlock1D(channels, channels, temb_dim, dropout)
        self.mid_attn = TransformerBlock1D(channels, cond_dim, heads, dropout)
        self.mid_res2 = ResBlock1D(channels, channels, temb_dim, dropout)
        self.up_res = ResBlock1D(2 * channels, channels, temb_dim, dropout)
        self.up_attn = TransformerBlock1D(channels, cond_dim, heads, dropout)
        self.norm_out = nn.GroupNorm(_groups(channels), channels)
        self.conv_out = nn.Conv1d(channels, num_coeffs, 3, padding=1)

    def forward(self, x_t: torch.Tensor, timesteps: torch.Tensor, cond: torch.Tensor) -> torch.Tensor:
        """Return the predicted noise.

        Parameters
        ----------
        x_t : (B, T, K) Tensor
        timesteps : (B,) Tensor
        cond : (B, S, cond_dim) Tensor
            Audio features (``S`` frames, normally ``S == T``).

        Returns
        -------
        eps : (B, T, K) Tensor
        """
        if x_t.ndim != 3 or cond.ndim != 3 or cond.shape[0] != x_t.shape[0]:
            raise ValueError(f"UNet1DCondition: expected x_t (B, T, K) and cond (B, S, D), got {tuple(x_t.shape)} and {tuple(cond.shape)}")
        bias = alignment_bias(x_t.shape[1], cond.shape[1], half_width=self.half_width, dtype=x_t.dtype, device=x_t.device)
        temb = self.time_mlp(timestep_embedding(timesteps, self.channels).to(x_t.dtype))
        h = self.conv_in(x_t.transpose(1, 2))
        h = self.down_attn(self.down_res(h, temb), cond, bias)
        skip = h
        h = self.mid_res1(h, temb)
        h = self.mid_attn(h, cond, bias)
        h = self.mid_res2(h, temb)
        h = self.up_res(torch.cat([h, skip], dim=1), temb)
        h = self.up_attn(h, cond, bias)
        return self.conv_out(F.silu(self.norm_out(h))).transpose(1, 2)


class AudioAdapter(nn.Module):
    """Trainable map from frozen encoder features to condition vectors.

    A linear projection followed by ``layers`` residual temporal convolutions (kernel
    ``kernel``); with ``layers = 0`` it is only the projection (the paper's setting,
    where wav2vec 2.0 features already carry context).
    """

    def __init__(self, feature_dim: int, cond_dim: int | None, layers: int = 2, kernel: int = 5):
        super().__init__()
        # cond_dim None: the features enter the denoiser as they are (the authors' feature_dim = -1)
        self.proj = nn.Identity() if cond_dim is None else nn.Linear(feature_dim, cond_dim)
        cond_dim = feature_dim if cond_dim is None else cond_dim
        self.convs = nn.ModuleList(nn.Conv1d(cond_dim, cond_dim, kernel, padding=kernel // 2) for _ in range(layers))
        self.norms = nn.ModuleList(nn.GroupNorm(_groups(cond_dim), cond_dim) for _ in range(layers))

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        """features: (B, T, feature_dim) -> (B, T, cond_dim)."""
        h = self.proj(features).transpose(1, 2)
        for conv, norm in zip(self.convs, self.norms):
            h = h + conv(F.gelu(norm(h)))
        return h.transpose(1, 2)


class SAiDModel(nn.Module):
    """Frozen speech encoder + audio adapter + null condition + conditional UNet denoiser.

    Parameters
    ----------
    num_coeffs : int, default 32
    channels : int, default 64
        UNet width.
    cond_dim : int or None, default 64
        Condition (cross-attention key/value input) size; None: the encoder's
        feature size, without projection.
    heads : int, default 4
    dropout : float, default 0.0
        Of the residual blocks (``authors``) or of every block (``compact``).
    architecture : {"authors", "compact"}, default "compact"
        ``authors``: the authors' UNet (:class:`baselines.said.unet1d.ConditionalUNet1D`,
        ``heads = channels / num_head_channels``); ``compact``: the smaller
        :class:`UNet1DCondition` (three transformer blocks) of earlier checkpoints.
    encoder : dict, default ``{"kind": "logmel"}``
        Spec for :func:`baselines.common.encoders.build_encoder`.
    adapter_layers : int, default 2
    adapter_kernel : int, default 5
    attention_half_width : int, default 1
    zero_init : bool or list of str, default True
        ``authors``: start the layers of
        :meth:`~baselines.said.unet1d.ConditionalUNet1D.zero_initialised_layers` at zero,
        as the authors do; False gives them PyTorch's default initialisation; a list of
        groups (``res``, ``attention``, ``out``) keeps those at zero and no others.
    """

    def __init__(
        self,
        num_coeffs: int = 32,
        channels: int = 64,
        cond_dim: int = 64,
        heads: int = 4,
        dropout: float = 0.0,
        encoder: dict | None = None,
        adapter_layers: int = 2,
        adapter_kernel: int = 5,
        attention_half_width: int = 1,
        architecture: str = "compact",
        zero_init: bool | list = True,
    ):
        super().__init__()
        if architecture not in ARCHITECTURES:
            raise ValueError(f"SAiDModel: expected architecture in {ARCHITECTURES}, got {architecture!r}")
        kept = zero_init_groups(zero_init)  # checked for both architectures; the compact UNet has no such layers
        self.encoder_spec = dict(encoder or {"kind": "logmel"})
        self.num_coeffs = num_coeffs
        self.architecture = architecture
        self.encoder = build_encoder(self.encoder_spec)
        self.adapter = AudioAdapter(self.encoder.feature_dim, cond_dim, adapter_layers, adapter_kernel)
        cond_dim = self.encoder.feature_dim if cond_dim is None else cond_dim
        self.null_cond = nn.Parameter(torch.randn(cond_dim) * 0.02)
        # x = (u - coeff_mean) / coeff_scale; set from the training data by train_said
        self.register_buffer("coeff_mean", torch.full((num_coeffs,), 0.5))
        self.register_buffer("coeff_scale", torch.full((num_coeffs,), 0.5))
        if architecture == "authors":
            if channels % heads:
                raise ValueError(f"SAiDModel: expected channels divisible by heads, got {channels}, {heads}")
            self.denoiser = ConditionalUNet1D(num_coeffs, num_coeffs, cond_dim, channels, channels // heads, dropout=dropout,
                                              norm_groups=math.gcd(channels, 32), pad=attention_half_width)
            for layer in self.denoiser.zero_initialised_layers(tuple(g for g in ZERO_INIT_GROUPS if g not in kept)):
                layer.reset_parameters()
        else:
            self.denoiser = UNet1DCondition(num_coeffs, channels, cond_dim, heads, dropout, attention_half_width)

    def trainable_parameters(self):
        """Return the parameters that training updates (everything but the frozen encoder)."""
        return [p for n, p in self.named_parameters() if not n.startswith("encoder.")]

    def audio_features(self, audio: torch.Tensor, num_frames: int) -> torch.Tensor:
        """Return frozen encoder features ``(B, num_frames, feature_dim)`` for audio ``(B, N)``."""
        with torch.no_grad():
            self.encoder.eval()
            return self.encoder(audio, num_frames)

    def condition(self, features: torch.Tensor, drop: torch.Tensor | None = None) -> torch.Tensor:
        """Return condition vectors ``(B, T, cond_dim)``; rows with ``drop`` True get the null condition.

        Parameters
        ----------
        features : (B, T, feature_dim) Tensor
        drop : (B,) bool Tensor, optional
        """
        cond = self.adapter(features)
        if drop is not None:
            cond = torch.where(drop[:, None, None], self.null_cond.expand_as(cond), cond)
        return cond

    def null_condition(self, batch: int, num_frames: int) -> torch.Tensor:
        """Return the null condition repeated to ``(batch, num_frames, cond_dim)``."""
        return self.null_cond.expand(batch, num_frames, -1)

    def context_cache(self, cond: torch.Tensor) -> dict | None:
        """Cross-attention keys/values of ``cond`` for :meth:`forward` (``authors`` only; None otherwise)."""
        return self.denoiser.context_cache(cond) if self.architecture == "authors" else None

    def forward(self, x_t: torch.Tensor, timesteps: torch.Tensor, cond: torch.Tensor, caches: dict | None = None,
                lengths: torch.Tensor | None = None) -> torch.Tensor:
        """Return the network output ``(B, T, K)`` for ``x_t (B, T, K)``, ``timesteps (B,)``, ``cond (B, S, D)``.

        ``lengths (B,)``: valid frames of zero-padded rows (``authors`` only, see
        :meth:`baselines.said.unet1d.ConditionalUNet1D.forward`).
        """
        if self.architecture == "authors":
            return self.denoiser(x_t.transpose(1, 2), timesteps, cond, caches, lengths).transpose(1, 2)
        if lengths is not None:
            raise ValueError("SAiDModel: the compact UNet takes no lengths (sample one utterance at a time)")
        return self.denoiser(x_t, timesteps, cond)
