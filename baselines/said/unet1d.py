"""SAiD's denoiser as the authors build it: a 1-D latent-diffusion UNet with aligned cross-attention.

The network is the latent-diffusion ``UNetModel`` in one dimension with one
resolution level (``channel_mult = (1,)``), ``num_res_blocks`` residual blocks per
side, a spatial transformer after every residual block and in the middle, and
the parameter names of that model, so that the ``denoiser.model.*`` part of the
published SAiD state_dict loads strictly into :class:`ConditionalUNet1D`:

* ``time_embed.{0,2}``: sinusoidal timestep embedding (``model_channels``) then
  Linear-SiLU-Linear to ``4 * model_channels``;
* ``input_blocks.0.0``: Conv1d ``in_channels -> model_channels`` (kernel 3);
* ``input_blocks.i = [ResBlock, SpatialTransformer]``, ``middle_block = [ResBlock,
  SpatialTransformer, ResBlock]``, ``output_blocks.i = [ResBlock(2C -> C),
  SpatialTransformer]`` with the UNet skip concatenation;
* ``out.{0,2}``: GroupNorm-SiLU-Conv1d to ``out_channels``.

The last convolution of every residual block, every transformer's ``proj_out``
and the output convolution start at zero.  The transformer's cross-attention
sees the audio features through the alignment mask of
:func:`baselines.common.attention_bias.alignment_mask`; its feed-forward is a GEGLU.

For sampling, :meth:`ConditionalUNet1D.context_cache` precomputes the
cross-attention keys and values of a condition once, so that the denoising
steps skip those projections (same result).  A context of ``r`` times the
batch of ``x`` (classifier-free guidance: the null and the audio condition)
gives the output of ``x`` repeated ``r`` times, with the layers before the first
cross-attention (input convolution, first residual block, first
self-attention), which do not see the condition, run once; the time embedding
is computed once per distinct timestep, and the cross-attention on its band
only, so that the arithmetic of a row does not depend on the batch it is in.

Sequences of different lengths share a batch through ``lengths``: each row is
zero-padded to the longest, and every layer that mixes frames sees the valid
frames only (group norms take their statistics over them, the convolutions read
zeros beyond them, as their own padding would be, and no attention attends to a
padded frame), so a row's valid frames get the output of that sequence alone, up
to float rounding.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from baselines.common.attention_bias import alignment_mask


def timestep_embedding(timesteps: torch.Tensor, dim: int, max_period: float = 10000.0) -> torch.Tensor:
    """Return ``[cos(t f_k), sin(t f_k)]`` with ``f_k = max_period^(-k / (dim // 2))`` (zero-padded if ``dim`` is odd).

    Parameters
    ----------
    timesteps : (B,) Tensor
    dim : int
    max_period : float, default 10000.0

    Returns
    -------
    embedding : (B, dim) float32 Tensor
    """
    half = dim // 2
    freqs = torch.exp(-math.log(max_period) * torch.arange(half, dtype=torch.float32) / half).to(timesteps.device)
    args = timesteps[:, None].float() * freqs[None]
    emb = torch.cat([torch.cos(args), torch.sin(args)], dim=-1)
    if dim % 2:
        emb = torch.cat([emb, torch.zeros_like(emb[:, :1])], dim=-1)
    return emb


def _repeated(t: torch.Tensor, rows: int) -> torch.Tensor:
    """``t`` (B, ...) repeated along its batch to ``rows`` (a multiple of B) rows; ``t`` itself when B == rows."""
    if t.shape[0] == rows:
        return t
    return t.repeat(rows // t.shape[0], *([1] * (t.dim() - 1)))


def frame_mask(lengths: torch.Tensor, rows: int, num_frames: int, dtype=torch.float32) -> torch.Tensor:
    """``(rows, 1, num_frames)``: 1 on the first ``lengths[i]`` frames of row ``i`` (``lengths`` repeated to ``rows``)."""
    frames = torch.arange(num_frames, device=lengths.device)
    return (frames[None, :] < _repeated(lengths, rows)[:, None]).to(dtype)[:, None, :]


def _per_length(function, lengths: torch.Tensor, tensors, dim: int) -> torch.Tensor:
    """``function(*crops)`` for the rows of each length together, on their first ``length`` frames along ``dim``.

    ``tensors`` share their batch (rows of ``lengths``); ``function`` returns a crop
    shaped like the first tensor's. The result is that tensor's shape, zero beyond
    each row's length: each row gets the arithmetic of its sequence alone.
    """
    out = tensors[0].new_zeros(tensors[0].shape)
    for length in torch.unique(lengths).tolist():
        index = (lengths == length).nonzero().flatten()
        frames = (slice(None),) * (dim - 1) + (slice(0, length),)
        out[(index,) + frames] = function(*(t[(index,) + frames].contiguous() for t in tensors))
    return out


def masked_group_norm(norm: nn.GroupNorm, x: torch.Tensor, lengths: torch.Tensor | None) -> torch.Tensor:
    """``norm(x)`` for ``x (N, C, T)`` with each row normalised over its first ``lengths`` frames (zero beyond).

    The rows of one length go through ``norm`` together on their valid frames, so
    that each gets the arithmetic of its sequence alone.  ``lengths is None``: the
    plain ``norm(x)``.
    """
    if lengths is None:
        return norm(x)
    return _per_length(norm, _repeated(lengths, x.shape[0]), (x,), dim=2)


def _zeroed(module: nn.Module) -> nn.Module:
    for p in module.parameters():
        nn.init.zeros_(p)
    return module


class GroupNorm32(nn.GroupNorm):
    """GroupNorm evaluated in float32 (cast back to the input dtype)."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return super().forward(x.float()).type(x.dtype)


class TimestepSequential(nn.Sequential):
    """Children run in order; residual blocks get the timestep embedding, transformers the condition."""

    def forward(self, x, emb, context=None, caches=None, emb_index=None, lengths=None):
        for layer in self:
            if isinstance(layer, ResBlock):
                x = layer(x, emb, emb_index, lengths)
            elif isinstance(layer, SpatialTransformer):
                x = layer(x, context, None if caches is None else caches[id(layer)], lengths)
            else:
                x = layer(x)
        return x


class ResBlock(nn.Module):
    """``skip(x) + out_layers(in_layers(x) + emb_layers(emb))`` (GroupNorm-SiLU-Conv, kernel 3).

    Parameters
    ----------
    channels, emb_channels : int
    dropout : float
    out_channels : int, optional
        Defaults to ``channels``; otherwise the skip is a 1x1 convolution.
    groups : int, default 32
    """

    def __init__(self, channels: int, emb_channels: int, dropout: float, out_channels: int | None = None, groups: int = 32):
        super().__init__()
        out = out_channels or channels
        self.in_layers = nn.Sequential(GroupNorm32(groups, channels), nn.SiLU(), nn.Conv1d(channels, out, 3, padding=1))
        self.emb_layers = nn.Sequential(nn.SiLU(), nn.Linear(emb_channels, out))
        self.out_layers = nn.Sequential(
            GroupNorm32(groups, out), nn.SiLU(), nn.Dropout(p=dropout), _zeroed(nn.Conv1d(out, out, 3, padding=1))
        )
        self.skip_connection = nn.Identity() if out == channels else nn.Conv1d(channels, out, 1)

    def forward(self, x: torch.Tensor, emb: torch.Tensor, emb_index: torch.Tensor | None = None,
                lengths: torch.Tensor | None = None) -> torch.Tensor:
        """x: (r B, C_in, T), emb: (U, emb_channels) -> (r B, C_out, T).

        ``emb_index (B,)``: the row of ``emb`` of each item (None: ``U == B``); item
        ``i`` serves rows ``i, i + B, ...`` of ``x``.  ``lengths (B,)``: valid frames
        of each item (None: all ``T``); the output is zero beyond them.
        """
        if lengths is None:
            h = self.in_layers(x)
        else:
            mask = frame_mask(lengths, x.shape[0], x.shape[2], x.dtype)
            norm, act, conv = self.in_layers
            h = conv(act(masked_group_norm(norm, x, lengths)) * mask)
        e = self.emb_layers(emb).type(h.dtype)
        if emb_index is not None:
            e = e[emb_index]
        h = h + _repeated(e, h.shape[0])[:, :, None]  # one embedding per group of repeated rows
        if lengths is None:
            return self.skip_connection(x) + self.out_layers(h)
        norm, act, drop, conv = self.out_layers
        return (self.skip_connection(x) + conv(drop(act(masked_group_norm(norm, h, lengths))) * mask)) * mask


class CrossAttention(nn.Module):
    """Multi-head attention ``softmax(Q K^T / sqrt(d_head), masked) V``, then ``to_out``.

    Parameters
    ----------
    query_dim : int
    context_dim : int, optional
        Defaults to ``query_dim`` (self-attention).
    heads, dim_head : int
    dropout : float
        Of ``to_out``.
    """

    def __init__(self, query_dim: int, context_dim: int | None = None, heads: int = 8, dim_head: int = 64, dropout: float = 0.0):
        super().__init__()
        inner = heads * dim_head
        context_dim = context_dim or query_dim
        self.heads, self.dim_head = heads, dim_head
        self.to_q = nn.Linear(query_dim, inner, bias=False)
        self.to_k = nn.Linear(context_dim, inner, bias=False)
        self.to_v = nn.Linear(context_dim, inner, bias=False)
        self.to_out = nn.Sequential(nn.Linear(inner, query_dim), nn.Dropout(dropout))

    def _heads(self, z: torch.Tensor) -> torch.Tensor:
        """(B, N, heads * dim_head) -> (B, N, heads, dim_head) (a view)."""
        b, n, _ = z.shape
        return z.view(b, n, self.heads, self.dim_head)

    def keys_values(self, context: torch.Tensor, pad: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
        """Return the keys and values ``(B, S + 2 pad, heads, dim_head)`` of ``context (B, S, context_dim)``,
        with ``pad`` zero rows on each side of the frame axis."""
        k, v = self._heads(self.to_k(context)), self._heads(self.to_v(context))
        if pad:
            k, v = F.pad(k, (0, 0, 0, 0, pad, pad)), F.pad(v, (0, 0, 0, 0, pad, pad))
        return k, v

    def forward(self, x, context=None, allowed=None, kv=None, band=None, kv_pad=0, lengths=None):
        """x: (B, T, query_dim); context: (B, S, context_dim) or None; allowed: (T, S) bool; kv: from :meth:`keys_values`.

        ``kv`` was padded by ``kv_pad`` rows.  ``band = p`` (with ``S == T`` and
        ``kv_pad == p``): the keys are ``|i - j| <= p``, computed on the band alone
        (same values as ``allowed`` = that band, in ``O(T p)``).  ``lengths (B,)``:
        keys beyond ``lengths[i]`` are not attended to by row ``i`` (with ``allowed``
        None or ``band``).
        """
        q = self._heads(self.to_q(x))
        k, v = kv if kv is not None else self.keys_values(x if context is None else context, kv_pad)
        b, t = q.shape[:2]
        if band is not None:
            if band != kv_pad:
                raise ValueError(f"CrossAttention: expected keys padded by the band half width {band}, got {kv_pad}")
            out = banded_attention(q, k, v, band, lengths)
        else:
            s = k.shape[1] - 2 * kv_pad
            k, v = k[:, kv_pad:kv_pad + s], v[:, kv_pad:kv_pad + s]
            if lengths is None:
                out = F.scaled_dot_product_attention(q.transpose(1, 2), k.transpose(1, 2), v.transpose(1, 2),
                                                     attn_mask=allowed)
                out = out.transpose(1, 2)
            else:
                if allowed is not None:
                    raise ValueError("CrossAttention: lengths go with full or banded attention, not an alignment mask")
                # the rows of one length attend on their valid frames together: each row's arithmetic is
                # that of its sequence alone (a key mask would round differently)
                def attend(*qkv):
                    return F.scaled_dot_product_attention(*(z.transpose(1, 2) for z in qkv)).transpose(1, 2)

                out = _per_length(attend, lengths, (q, k, v), dim=1)
        return self.to_out(out.reshape(b, t, self.heads * self.dim_head))


def banded_attention(q: torch.Tensor, k: torch.Tensor, v: torch.Tensor, pad: int,
                     lengths: torch.Tensor | None = None) -> torch.Tensor:
    """``softmax(Q K^T / sqrt(d))V`` restricted to keys ``|i - j| <= pad``, on the band alone.

    Parameters
    ----------
    q : (B, T, H, d) Tensor
    k, v : (B, T + 2 pad, H, d) Tensor
        Keys and values of frames ``-pad .. T - 1 + pad`` (the ``pad`` rows on each
        side are never attended to; zeros from :meth:`CrossAttention.keys_values`).
    pad : int
    lengths : (B,) Tensor, optional
        Valid frames of each row: keys at or beyond them are not attended to.

    Returns
    -------
    (B, T, H, d) Tensor
    """
    t, d = q.shape[1], q.shape[3]
    if k.shape[1] != t + 2 * pad or v.shape[1] != t + 2 * pad:
        raise ValueError(f"banded_attention: expected keys and values of {t + 2 * pad} frames, got {k.shape[1]}, {v.shape[1]}")
    # scores of the 2 pad + 1 offsets, (W, B, T, H); the softmax over W written out
    scores = torch.stack([(q * k[:, o:o + t]).sum(-1) for o in range(2 * pad + 1)]) * d**-0.5
    j = torch.arange(t, device=q.device)[None, :] + torch.arange(-pad, pad + 1, device=q.device)[:, None]
    if lengths is None:
        outside = ((j < 0) | (j >= t))[:, None, :, None]
    else:
        # a valid frame's band stops at its sequence's end; padded frames keep theirs (finite, never used)
        i = torch.arange(t, device=q.device)
        beyond = (j[:, None, :] >= lengths[None, :, None]) & (i[None, None, :] < lengths[None, :, None])
        outside = ((j < 0) | (j >= t))[:, None, :] | beyond
        outside = outside[..., None]
    scores = scores.masked_fill(outside, float("-inf"))
    weights = (scores - scores.amax(0)).exp_()
    weights = weights / weights.sum(0)
    out = weights[0, ..., None] * v[:, 0:t]
    for o in range(1, 2 * pad + 1):
        out = out + weights[o, ..., None] * v[:, o:o + t]
    return out


class GEGLU(nn.Module):
    """``a * gelu(g)`` with ``[a, g] = proj(x)``."""

    def __init__(self, dim_in: int, dim_out: int):
        super().__init__()
        self.proj = nn.Linear(dim_in, 2 * dim_out)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        a, gate = self.proj(x).chunk(2, dim=-1)
        return a * F.gelu(gate)


class FeedForward(nn.Module):
    """GEGLU to ``mult * dim``, dropout, Linear back to ``dim``."""

    def __init__(self, dim: int, mult: int = 4, dropout: float = 0.0):
        super().__init__()
        self.net = nn.Sequential(GEGLU(dim, mult * dim), nn.Dropout(dropout), nn.Linear(mult * dim, dim))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


class BasicTransformerBlock(nn.Module):
    """Pre-norm self-attention, aligned cross-attention to the condition, GEGLU feed-forward."""

    def __init__(self, dim: int, heads: int, dim_head: int, context_dim: int, dropout: float = 0.0, pad: int = 1):
        super().__init__()
        self.attn1 = CrossAttention(dim, None, heads, dim_head, dropout)
        self.ff = FeedForward(dim, dropout=dropout)
        self.attn2 = CrossAttention(dim, context_dim, heads, dim_head, dropout)
        self.norm1 = nn.LayerNorm(dim)
        self.norm2 = nn.LayerNorm(dim)
        self.norm3 = nn.LayerNorm(dim)
        self.pad = pad

    def keys_values(self, context: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The cross-attention's keys and values of ``context``, padded by the band half width."""
        return self.attn2.keys_values(context, self.pad)

    def forward(self, x, context, kv=None, lengths=None):
        """x: (B, T, dim), context: (r B, S, context_dim) -> (r B, T, dim).

        With ``r > 1`` the self-attention runs on the ``B`` rows once and its output
        is repeated ``r`` times before the cross-attention (the same result as
        repeating ``x``).  ``lengths (B,)``: valid frames per item (``S == T`` then).
        """
        x = self.attn1(self.norm1(x), lengths=None if lengths is None else _repeated(lengths, x.shape[0])) + x
        if kv is None:
            kv = self.keys_values(context)
        x = _repeated(x, kv[0].shape[0])
        num_keys = kv[0].shape[1] - 2 * self.pad
        row_lengths = None if lengths is None else _repeated(lengths, x.shape[0])
        if num_keys == x.shape[1]:  # one audio feature per frame: the band |i - j| <= pad
            x = self.attn2(self.norm2(x), context, None, kv, band=self.pad, kv_pad=self.pad, lengths=row_lengths) + x
        else:
            if lengths is not None:
                raise ValueError(f"BasicTransformerBlock: lengths need one condition frame per frame, got {num_keys} "
                                 f"for {x.shape[1]}")
            allowed = alignment_mask(x.shape[1], num_keys, pad=self.pad, device=x.device)
            x = self.attn2(self.norm2(x), context, allowed, kv, kv_pad=self.pad) + x
        return self.ff(self.norm3(x)) + x


class SpatialTransformer(nn.Module):
    """GroupNorm, ``depth`` transformer blocks over frames, zero-initialised 1x1 ``proj_out``, residual."""

    def __init__(self, channels: int, heads: int, dim_head: int, context_dim: int, depth: int = 1, dropout: float = 0.0, groups: int = 32, pad: int = 1):
        super().__init__()
        if heads * dim_head != channels:
            raise ValueError(f"SpatialTransformer: expected heads * dim_head == channels, got {heads} * {dim_head} != {channels}")
        self.norm = nn.GroupNorm(groups, channels, eps=1e-6)
        self.transformer_blocks = nn.ModuleList(
            BasicTransformerBlock(channels, heads, dim_head, context_dim, dropout, pad) for _ in range(depth)
        )
        self.proj_out = _zeroed(nn.Conv1d(channels, channels, 1))

    def keys_values(self, context: torch.Tensor) -> list:
        """Cross-attention keys and values of every block for ``context``."""
        return [block.keys_values(context) for block in self.transformer_blocks]

    def forward(self, x, context, cache=None, lengths=None):
        """x: (B, C, T), context: (r B, S, context_dim) -> (r B, C, T) (``x`` repeated ``r`` times at the first
        block's cross-attention); ``lengths (B,)``: valid frames per item, the output is zero beyond them."""
        h = masked_group_norm(self.norm, x, lengths).transpose(1, 2)
        for i, block in enumerate(self.transformer_blocks):
            h = block(h, context, None if cache is None else cache[i], lengths)
        x = _repeated(x, h.shape[0])
        # the 1x1 convolution as a matrix product over the frames-major h (no transposed copy)
        out = F.linear(h, self.proj_out.weight[:, :, 0], self.proj_out.bias).transpose(1, 2) + x
        return out if lengths is None else out * frame_mask(lengths, out.shape[0], out.shape[2], out.dtype)


#: The layer groups the authors start at zero (:meth:`ConditionalUNet1D.zero_initialised_layers`).
ZERO_INIT_GROUPS = ("res", "attention", "out")


class ConditionalUNet1D(nn.Module):
    """The denoiser ``eps(x_t, t, context)`` of SAiD (latent-diffusion UNet, 1-D, one level).

    Parameters
    ----------
    in_channels, out_channels : int
        Coefficient channels (32).
    context_dim : int
        Size of a condition (audio feature) vector.
    model_channels : int, default 192
        Width (the authors' value).
    num_head_channels : int, default 32
        Channels per attention head (heads = ``model_channels // num_head_channels``).
    num_res_blocks : int, default 1
    dropout : float, default 0.1
        Of the residual blocks (the transformers have none, as in the authors' model).
    norm_groups : int, default 32
    pad : int, default 1
        Alignment band half width (:func:`alignment_mask`).
    """

    def __init__(
        self,
        in_channels: int = 32,
        out_channels: int = 32,
        context_dim: int = 768,
        model_channels: int = 192,
        num_head_channels: int = 32,
        num_res_blocks: int = 1,
        dropout: float = 0.1,
        norm_groups: int = 32,
        pad: int = 1,
    ):
        super().__init__()
        c = int(model_channels)
        if c % num_head_channels or c % norm_groups:
            raise ValueError(
                f"ConditionalUNet1D: expected model_channels divisible by num_head_channels and norm_groups, "
                f"got {c}, {num_head_channels}, {norm_groups}"
            )
        self.in_channels, self.out_channels, self.model_channels = in_channels, out_channels, c
        heads = c // num_head_channels
        temb = 4 * c

        def res(cin):
            return ResBlock(cin, temb, dropout, c, norm_groups)

        def transformer():
            return SpatialTransformer(c, heads, num_head_channels, context_dim, groups=norm_groups, pad=pad)

        self.time_embed = nn.Sequential(nn.Linear(c, temb), nn.SiLU(), nn.Linear(temb, temb))
        self.input_blocks = nn.ModuleList([TimestepSequential(nn.Conv1d(in_channels, c, 3, padding=1))])
        self.input_blocks.extend(TimestepSequential(res(c), transformer()) for _ in range(num_res_blocks))
        self.middle_block = TimestepSequential(res(c), transformer(), res(c))
        self.output_blocks = nn.ModuleList(TimestepSequential(res(2 * c), transformer()) for _ in range(num_res_blocks + 1))
        self.out = nn.Sequential(GroupNorm32(norm_groups, c), nn.SiLU(), _zeroed(nn.Conv1d(c, out_channels, 3, padding=1)))

    def zero_initialised_layers(self, groups=ZERO_INIT_GROUPS) -> list[nn.Conv1d]:
        """The layers that start at zero, by group: ``res``, every residual block's last
        convolution; ``attention``, every transformer's ``proj_out``; ``out``, the output
        convolution (all three by default)."""
        unknown = sorted(set(groups) - set(ZERO_INIT_GROUPS))
        if unknown:
            raise ValueError(f"ConditionalUNet1D: expected zero-init groups among {ZERO_INIT_GROUPS}, got {unknown}")
        layers = {"res": [m.out_layers[-1] for m in self.modules() if isinstance(m, ResBlock)],
                  "attention": [m.proj_out for m in self.transformers()], "out": [self.out[-1]]}
        return [layer for group in ZERO_INIT_GROUPS if group in groups for layer in layers[group]]

    def transformers(self) -> list[SpatialTransformer]:
        """The spatial transformers, in forward order."""
        return [m for m in self.modules() if isinstance(m, SpatialTransformer)]

    def context_cache(self, context: torch.Tensor) -> dict:
        """Precompute every cross-attention's keys and values for ``context (B, S, context_dim)``.

        Pass the result as ``caches`` to :meth:`forward` with any ``x_t`` of batch ``B``
        (the same output as passing ``context``, without the key/value projections).
        """
        return {id(m): m.keys_values(context) for m in self.transformers()}

    def forward(self, x: torch.Tensor, timesteps: torch.Tensor, context: torch.Tensor | None = None, caches: dict | None = None,
                lengths: torch.Tensor | None = None) -> torch.Tensor:
        """Return the network output (the noise estimate for SAiD).

        Parameters
        ----------
        x : (B, in_channels, T) Tensor
        timesteps : (B,) Tensor
        context : (r B, S, context_dim) Tensor
            Condition; may be None when ``caches`` is given.  With ``r > 1`` the
            output is that of ``x`` and ``timesteps`` repeated ``r`` times (row
            ``i + k B`` has condition ``k B + i``); the layers before the first
            cross-attention, which do not see the condition, run on the ``B`` rows once.
        caches : dict, optional
            From :meth:`context_cache` (for a context of batch ``r B``).
        lengths : (B,) Tensor, optional
            Valid frames of each item (zero-padded to ``T``; one condition frame per
            frame, ``S == T``): each item's first ``lengths[i]`` output frames are
            those of the item alone, up to float rounding; the rest are zero.

        Returns
        -------
        (r B, out_channels, T) Tensor
        """
        if context is None and caches is None:
            raise ValueError("ConditionalUNet1D: expected a context or its caches")
        n = context.shape[0] if context is not None else next(iter(caches.values()))[0][0].shape[0]
        if n % x.shape[0] or timesteps.shape[0] != x.shape[0]:
            raise ValueError(f"ConditionalUNet1D: expected x and timesteps of one batch dividing the context's {n}, "
                             f"got {x.shape[0]} and {timesteps.shape[0]}")
        # the time embedding of each distinct timestep once (sampling: one row per step, the
        # same arithmetic for any batch)
        steps, index = torch.unique(timesteps, return_inverse=True)
        emb = self.time_embed(timestep_embedding(steps, self.model_channels))
        if lengths is not None:
            lengths = torch.as_tensor(lengths, device=x.device).long()
            if lengths.shape != (x.shape[0],) or bool((lengths < 1).any()) or bool((lengths > x.shape[2]).any()):
                raise ValueError(f"ConditionalUNet1D: expected lengths (B,) = ({x.shape[0]},) in 1..{x.shape[2]}, "
                                 f"got {lengths.tolist()}")
            if bool((lengths == x.shape[2]).all()):
                lengths = None  # nothing padded: the plain forward
        mask = None if lengths is None else frame_mask(lengths, x.shape[0], x.shape[2])
        skips = []
        h = x.float() if mask is None else x.float() * mask
        for block in self.input_blocks:
            h = block(h, emb, context, caches, index, lengths)
            if mask is not None and h.shape[0] == mask.shape[0]:
                h = h * mask
            skips.append(h)
        h = self.middle_block(h, emb, context, caches, index, lengths)
        for block in self.output_blocks:
            h = block(torch.cat([h, _repeated(skips.pop(), h.shape[0])], dim=1), emb, context, caches, index, lengths)
        h = _repeated(h, n)  # (when no cross-attention on the way repeated it)
        if lengths is None:
            return self.out(h.type(x.dtype))
        norm, act, conv = self.out
        rows_mask = frame_mask(lengths, n, x.shape[2])
        return conv(act(masked_group_norm(norm, h, lengths)) * rows_mask).type(x.dtype) * rows_mask
