"""FaceFormer's motion decoder, which CodeTalker's stage 2 reuses: construction, teacher-forced
and incremental (cached) passes, and its configuration read from the authors' weights.

The decoder is a ``torch.nn.TransformerDecoder`` of post-norm layers (``batch_first``),
self-attention with :func:`~baselines.common.attention_bias.biased_causal_mask`
and cross-attention with :func:`~baselines.common.attention_bias.enc_dec_mask`.
Because every mask is causal, frame ``i``'s output depends only on inputs ``0..i``:
:func:`decode_step` computes it from the cached inputs of each layer, which equals
re-running the whole decoder on the prefix (what the authors' ``predict`` does) at a
fraction of the cost.
"""

from __future__ import annotations

import torch
from torch import nn

from baselines.common.attention_bias import biased_causal_mask, enc_dec_mask
from baselines.common.checkpoint import count_layers, require_key
from baselines.common.encoders.trainable import build_audio_encoder, motion_audio_features
from baselines.common.positional import PeriodicPositionalEncoding, period_of_encoding

__all__ = ["SpeechMotionTransformer", "decode_step", "decode_teacher_forced", "decoder_config_from_state",
           "motion_decoder"]


def motion_decoder(d_model: int, n_head: int, num_layers: int, dropout: float = 0.1) -> nn.TransformerDecoder:
    """The authors' decoder: ``num_layers`` post-norm ReLU layers, feed-forward ``2 * d_model``."""
    layer = nn.TransformerDecoderLayer(d_model=d_model, nhead=n_head, dim_feedforward=2 * d_model,
                                       dropout=dropout, batch_first=True)
    return nn.TransformerDecoder(layer, num_layers=num_layers)


class SpeechMotionTransformer(nn.Module):
    """The parts FaceFormer and CodeTalker's stage 2 share, with the authors' names:
    ``audio_encoder``, ``audio_feature_map``, ``vertice_map``, ``PPE`` and
    ``transformer_decoder``, made by :meth:`build_speech_decoder` in that order (so a seed
    draws the same initial weights as the authors' constructors)."""

    def build_speech_decoder(self, cfg: dict) -> None:
        """Make the shared parts from ``cfg`` (FaceFormer's config keys)."""
        self.dataset, self.period, self.n_head = cfg["dataset"], int(cfg["period"]), int(cfg["n_head"])
        self.fps = int(cfg["fps"])
        self.audio_encoder, audio_dim = build_audio_encoder(cfg["audio"])
        self.audio_feature_map = nn.Linear(audio_dim, cfg["feature_dim"])
        self.vertice_map = nn.Linear(cfg["vertice_dim"], cfg["feature_dim"])
        self.PPE = PeriodicPositionalEncoding(cfg["feature_dim"], dropout=cfg["dropout"], period=self.period,
                                              max_seq_len=cfg["max_seq_len"])
        self.transformer_decoder = motion_decoder(cfg["feature_dim"], self.n_head, cfg["num_layers"], cfg["dropout"])

    def audio_features(self, audio: torch.Tensor, num_frames: int | None = None) -> torch.Tensor:
        """Mapped speech features ``(B, T, feature_dim)``, one per motion frame.

        Parameters
        ----------
        audio : (B, N) Tensor
            16 kHz speech, normalised (:func:`~baselines.common.encoders.wav2vec2.normalize_waveform`)
            for wav2vec 2.0.
        num_frames : int, optional
            Default: the authors' count from the audio length.
        """
        return self.audio_feature_map(motion_audio_features(self.audio_encoder, audio, num_frames, fps=self.fps))

    def decode_options(self) -> dict:
        """The keywords of :func:`decode_teacher_forced` and :func:`decode_step` for this network."""
        return {"period": self.period, "dataset": self.dataset, "bias_heads": self.n_head}


def _self_mask(n_head: int, batch: int, rows: torch.Tensor) -> torch.Tensor:
    return rows.repeat(batch, 1, 1)


def decode_teacher_forced(decoder: nn.TransformerDecoder, inputs: torch.Tensor, memory: torch.Tensor, *,
                          period: int, dataset: str = "vocaset", bias_heads: int = 4) -> torch.Tensor:
    """All frames at once: ``(B, T, d)`` decoder outputs for ``(B, T, d)`` inputs and ``(B, S, d)`` memory.

    Parameters
    ----------
    decoder : nn.TransformerDecoder
    inputs : (B, T, d) Tensor
        Embedded previous frames (style + motion embedding + periodic encoding).
    memory : (B, S, d) Tensor
        Audio features.
    period : int
    dataset : {"vocaset", "BIWI"}
    bias_heads : int
        Number of heads of the bias (the authors fix 4, equal to the decoder's heads).

    Returns
    -------
    (B, T, d) Tensor
    """
    b, t, _ = inputs.shape
    tgt_mask = _self_mask(bias_heads, b, biased_causal_mask(bias_heads, t, period).to(inputs))
    memory_mask = enc_dec_mask(t, memory.shape[1], dataset).to(inputs.device)
    return decoder(inputs, memory, tgt_mask=tgt_mask, memory_mask=memory_mask)


def decode_step(decoder: nn.TransformerDecoder, new_input: torch.Tensor, memory: torch.Tensor, cache: list, *,
                period: int, dataset: str = "vocaset", bias_heads: int = 4) -> torch.Tensor:
    """Output of the next frame given the cached inputs of every layer.

    Parameters
    ----------
    decoder : nn.TransformerDecoder
        In eval mode (dropout off).
    new_input : (B, 1, d) Tensor
        Embedded input of frame ``i``.
    memory : (B, S, d) Tensor
    cache : list
        One ``(B, i, d)`` Tensor (or None at ``i = 0``) per layer: the inputs of that
        layer at frames ``0..i-1``; updated in place.
    period, dataset, bias_heads
        As in :func:`decode_teacher_forced`.

    Returns
    -------
    (B, 1, d) Tensor
        The decoder output at frame ``i``.
    """
    b = new_input.shape[0]
    x = new_input
    for n, layer in enumerate(decoder.layers):
        keys = x if cache[n] is None else torch.cat([cache[n], x], dim=1)
        cache[n] = keys
        i = keys.shape[1] - 1
        self_bias = biased_causal_mask(bias_heads, i + 1, period)[:, i:, :].to(x)
        cross_mask = enc_dec_mask(i + 1, memory.shape[1], dataset)[i:, :].to(x.device)
        sa = layer.self_attn(x, keys, keys, attn_mask=_self_mask(bias_heads, b, self_bias), need_weights=False)[0]
        x = layer.norm1(x + sa)
        ca = layer.multihead_attn(x, memory, memory, attn_mask=cross_mask, need_weights=False)[0]
        x = layer.norm2(x + ca)
        x = layer.norm3(x + layer.linear2(layer.activation(layer.linear1(x))))
    if decoder.norm is not None:
        x = decoder.norm(x)
    return x


def decoder_config_from_state(state: dict, *, num_subjects: int, audio: dict | None = None, n_head: int = 4,
                              dataset: str = "vocaset", where: str) -> dict:
    """The model config of a FaceFormer-style network (FaceFormer, CodeTalker's stage 2) that fits ``state``.

    Widths, period, decoder layers and the maximum sequence length are read from the
    tensors ``vertice_map.weight``, ``PPE.pe`` and ``transformer_decoder.layers.*``; what
    the weights do not record is passed in.

    Parameters
    ----------
    state : dict of str -> Tensor
        The authors' state dict (``module.`` prefixes removed).
    num_subjects : int
        Training speakers (read by the caller from its style layer).
    audio : dict, optional
        Audio encoder spec; default wav2vec 2.0 with the base configuration.
    n_head : int, default 4
        Decoder heads (not stored; the authors use 4).
    dataset : {"vocaset", "BIWI"}
    where : str
        Named in the error of a missing key.

    Returns
    -------
    dict
        ``dataset``, ``vertice_dim``, ``feature_dim``, ``period``, ``n_head``,
        ``num_layers``, ``num_subjects``, ``max_seq_len``, ``audio``.
    """
    vertice_map = require_key(state, "vertice_map.weight", where)
    pe = require_key(state, "PPE.pe", where)
    period = period_of_encoding(pe)
    return {
        "dataset": dataset,
        "vertice_dim": int(vertice_map.shape[1]),
        "feature_dim": int(vertice_map.shape[0]),
        "period": period,
        "n_head": int(n_head),
        "num_layers": count_layers(state, "transformer_decoder.layers."),
        "num_subjects": int(num_subjects),
        "max_seq_len": int(pe.shape[1]) - period,
        "audio": audio or {"kind": "wav2vec2", "config": "base"},
    }
