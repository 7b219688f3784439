"""CodeTalker stage 1: the motion VQ-VAE (discrete facial-motion codebook), authors' names.

``VQAutoEncoder`` = ``encoder`` (:class:`TransformerEncoder`: linear vertex mapping,
1-D convolution "squasher", pre-norm transformer), ``quantize``
(:class:`baselines.vq.VectorQuantizer`, ``n_embed`` codes of ``zquant_dim``) and
``decoder`` (:class:`TransformerDecoder`). Each frame's ``hidden_size`` feature is
split into ``face_quan_num`` vectors of ``zquant_dim`` (``hidden_size = face_quan_num *
zquant_dim``), each replaced by its nearest code; the VOCASET model keeps one feature per
frame (``quant_factor`` 0, length-preserving convolutions). Details kept as the authors' code
has them, so the released ``vocaset_stage1.pth.tar`` reproduces their outputs: the
attention scale is ``hidden_size ** -0.5`` (not per head), the MLP uses the tanh
GELU, and the sinusoidal ``PositionalEncoding`` adds the row of the *batch index*
(``pe[:x.size(0)]`` on a batch-first tensor) to every frame.
"""

from __future__ import annotations

import copy
import math

import torch
import torch.nn.functional as F
from torch import nn

from baselines.vq import VectorQuantizer

__all__ = ["STAGE1_DEFAULTS", "TransformerDecoder", "TransformerEncoder", "VQAutoEncoder", "resolved_stage1_config"]

#: The authors' VOCASET stage-1 settings (config/vocaset/stage1.yaml).
STAGE1_DEFAULTS = {
    "in_dim": 5023 * 3,
    "hidden_size": 1024,
    "num_hidden_layers": 6,
    "num_attention_heads": 8,
    "intermediate_size": 1536,
    "quant_factor": 0,
    "face_quan_num": 16,
    "neg": 0.2,
    "INaffine": False,
    "n_embed": 256,
    "zquant_dim": 64,
    "beta": 0.25,
}


def resolved_stage1_config(**overrides) -> dict:
    """:data:`STAGE1_DEFAULTS` with ``overrides``; checks ``hidden_size == face_quan_num * zquant_dim``."""
    unknown = sorted(set(overrides) - set(STAGE1_DEFAULTS))
    if unknown:
        raise ValueError(f"CodeTalker stage 1: unknown keys {unknown}; expected some of {sorted(STAGE1_DEFAULTS)}")
    cfg = {**copy.deepcopy(STAGE1_DEFAULTS), **overrides}
    if cfg["quant_factor"] != 0:
        raise ValueError(f"CodeTalker stage 1: only quant_factor 0 (the VOCASET model, one feature per frame) "
                         f"is built, got {cfg['quant_factor']}")
    if cfg["hidden_size"] != cfg["face_quan_num"] * cfg["zquant_dim"]:
        raise ValueError(f"CodeTalker stage 1: expected hidden_size == face_quan_num * zquant_dim, got "
                         f"{cfg['hidden_size']} != {cfg['face_quan_num']} * {cfg['zquant_dim']}")
    return cfg


class Attention(nn.Module):
    """Multi-head self-attention ``to_qkv`` (no bias) / ``to_out``, scale ``dim ** -0.5``."""

    def __init__(self, in_dim: int, dim: int, heads: int = 8):
        super().__init__()
        self.heads = heads
        self.scale = dim**-0.5
        self.to_qkv = nn.Linear(in_dim, dim * 3, bias=False)
        self.to_out = nn.Linear(dim, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """x: (B, N, in_dim) -> (B, N, dim); all frames see all frames."""
        b, n, _ = x.shape
        q, k, v = self.to_qkv(x).reshape(b, n, 3, self.heads, -1).permute(2, 0, 3, 1, 4)
        attn = torch.softmax(torch.einsum("bhid,bhjd->bhij", q, k) * self.scale, dim=-1)
        out = torch.einsum("bhij,bhjd->bhid", attn, v).transpose(1, 2).reshape(b, n, -1)
        return self.to_out(out)


class MLP(nn.Module):
    """``l2(gelu_tanh(l1(x)))``."""

    def __init__(self, in_dim: int, out_dim: int, hidden_dim: int):
        super().__init__()
        self.l1 = nn.Linear(in_dim, hidden_dim)
        self.l2 = nn.Linear(hidden_dim, out_dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.l2(F.gelu(self.l1(x), approximate="tanh"))


class Norm(nn.Module):
    """``fn(LayerNorm(x))`` (pre-norm)."""

    def __init__(self, fn: nn.Module, size: int):
        super().__init__()
        self.norm = nn.LayerNorm(size, eps=1e-5)
        self.fn = fn

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.fn(self.norm(x))


class Residual(nn.Module):
    """``x + fn(x)``."""

    def __init__(self, fn: nn.Module):
        super().__init__()
        self.fn = fn

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + self.fn(x)


class Transformer(nn.Module):
    """``net``: alternating ``Residual(Norm(Attention))`` and ``Residual(Norm(MLP))`` blocks, no final norm."""

    def __init__(self, in_size: int, hidden_size: int, num_hidden_layers: int, num_attention_heads: int,
                 intermediate_size: int):
        super().__init__()
        blocks = []
        for _ in range(num_hidden_layers):
            blocks += [Residual(Norm(Attention(in_size, hidden_size, heads=num_attention_heads), hidden_size)),
                       Residual(Norm(MLP(hidden_size, hidden_size, intermediate_size), hidden_size))]
        self.net = nn.Sequential(*blocks)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


class LinearEmbedding(nn.Module):
    """``net``: one linear layer."""

    def __init__(self, size: int, dim: int):
        super().__init__()
        self.net = nn.Linear(size, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


class PositionalEncoding(nn.Module):
    """The authors' sinusoidal table ``pe`` ``(max_len, 1, d_model)``, added as ``x + pe[:x.size(0)]``.

    On their batch-first inputs this adds row ``b`` (the batch index) to every frame
    of item ``b``; kept so that the released weights see what they were trained with.
    """

    def __init__(self, d_model: int, dropout: float = 0.1, max_len: int = 5000):
        super().__init__()
        self.dropout = nn.Dropout(p=dropout)
        position = torch.arange(0, max_len, dtype=torch.float).unsqueeze(1)
        div_term = torch.exp(torch.arange(0, d_model, 2).float() * (-math.log(10000.0) / d_model))
        pe = torch.zeros(max_len, d_model)
        pe[:, 0::2] = torch.sin(position * div_term)
        pe[:, 1::2] = torch.cos(position * div_term)
        self.register_buffer("pe", pe.unsqueeze(1))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.dropout(x + self.pe[: x.size(0)])


def _conv_block(cfg: dict) -> nn.Sequential:
    """``Conv1d(k=5, replicate padding) - LeakyReLU - InstanceNorm1d``, length preserving."""
    dim = cfg["hidden_size"]
    return nn.Sequential(nn.Conv1d(dim, dim, 5, stride=1, padding=2, padding_mode="replicate"),
                         nn.LeakyReLU(cfg["neg"], True), nn.InstanceNorm1d(dim, affine=cfg["INaffine"]))


class TransformerEncoder(nn.Module):
    """Vertex displacements ``(B, T, in_dim)`` -> features ``(B, T, hidden_size)``."""

    def __init__(self, cfg: dict):
        super().__init__()
        dim = cfg["hidden_size"]
        self.vertice_mapping = nn.Sequential(nn.Linear(cfg["in_dim"], dim), nn.LeakyReLU(cfg["neg"], True))
        self.squasher = nn.Sequential(_conv_block(cfg))
        self.encoder_transformer = Transformer(dim, dim, cfg["num_hidden_layers"], cfg["num_attention_heads"],
                                               cfg["intermediate_size"])
        self.encoder_pos_embedding = PositionalEncoding(dim)
        self.encoder_linear_embedding = LinearEmbedding(dim, dim)

    def forward(self, inputs: torch.Tensor) -> torch.Tensor:
        x = self.vertice_mapping(inputs)
        x = self.squasher(x.permute(0, 2, 1)).permute(0, 2, 1)
        x = self.encoder_pos_embedding(self.encoder_linear_embedding(x))
        return self.encoder_transformer(x)


class TransformerDecoder(nn.Module):
    """Frame features ``(B, hidden_size, T)`` (channels first) -> displacements ``(B, T, out_dim)``."""

    def __init__(self, cfg: dict, out_dim: int):
        super().__init__()
        dim = cfg["hidden_size"]
        self.expander = nn.ModuleList([_conv_block(cfg)])
        self.decoder_transformer = Transformer(dim, dim, cfg["num_hidden_layers"], cfg["num_attention_heads"],
                                               cfg["intermediate_size"])
        self.decoder_pos_embedding = PositionalEncoding(dim)
        self.decoder_linear_embedding = LinearEmbedding(dim, dim)
        self.vertice_map_reverse = nn.Linear(dim, out_dim)

    def hidden(self, inputs: torch.Tensor) -> torch.Tensor:
        """Frame features ``(B, hidden_size, T)`` -> transformer outputs ``(B, T, hidden_size)``."""
        x = self.expander[0](inputs).permute(0, 2, 1)
        return self.decoder_transformer(self.decoder_pos_embedding(self.decoder_linear_embedding(x)))

    def forward(self, inputs: torch.Tensor) -> torch.Tensor:
        return self.vertice_map_reverse(self.hidden(inputs))


class VQAutoEncoder(nn.Module):
    """The motion VQ-VAE of CodeTalker (stage 1).

    Parameters
    ----------
    config : dict, optional
        Keys of :data:`STAGE1_DEFAULTS`.
    """

    def __init__(self, config: dict | None = None):
        super().__init__()
        self.config = resolved_stage1_config(**(config or {}))
        cfg = self.config
        self.encoder = TransformerEncoder(cfg)
        self.decoder = TransformerDecoder(cfg, cfg["in_dim"])
        self.quantize = VectorQuantizer(cfg["n_embed"], cfg["zquant_dim"], beta=cfg["beta"])

    def encode(self, x: torch.Tensor):
        """Displacements ``(B, T, in_dim)`` -> ``(quantized (B, zquant_dim, T * face_quan_num), loss, info)``."""
        h = self.encoder(x)
        h = h.reshape(x.shape[0], -1, self.config["zquant_dim"])
        return self.quantize(h)

    def _frames(self, quant: torch.Tensor) -> torch.Tensor:
        b = quant.shape[0]
        frames = quant.permute(0, 2, 1).reshape(b, -1, self.config["face_quan_num"] * self.config["zquant_dim"])
        return frames.permute(0, 2, 1).contiguous()

    def decode(self, quant: torch.Tensor) -> torch.Tensor:
        """Quantized ``(B, zquant_dim, T * face_quan_num)`` -> displacements ``(B, T, in_dim)``."""
        return self.decoder(self._frames(quant))

    def decode_frame(self, quant: torch.Tensor, frame: int = -1) -> torch.Tensor:
        """One frame ``(B, 1, in_dim)`` of :meth:`decode` (the decoder sees all frames; only one is mapped out)."""
        hidden = self.decoder.hidden(self._frames(quant))
        return self.decoder.vertice_map_reverse(hidden[:, frame : frame + 1 if frame != -1 else None])

    def forward(self, x: torch.Tensor, template: torch.Tensor):
        """Reconstruction of ``x`` ``(B, T, in_dim)`` around ``template`` ``(B, in_dim)``: ``(recon, vq_loss, info)``."""
        template = template.unsqueeze(1)
        quant, emb_loss, info = self.encode(x - template)
        return self.decode(quant) + template, emb_loss, info

    def get_quant(self, x: torch.Tensor):
        """``(quantized (B, zquant_dim, T * face_quan_num), indices (B * T * face_quan_num, 1))`` of displacements."""
        quant, _, info = self.encode(x)
        return quant, info[2]
