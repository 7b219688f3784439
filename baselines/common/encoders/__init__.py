"""Speech encoders of the baselines.

The frozen encoders (SAiD, CDFace) return features at the coefficient frame rate.
Every one is a ``torch.nn.Module`` with ``feature_dim``, ``sample_rate`` (16000)
and ``forward(audio (B, N), num_frames) -> (B, num_frames, feature_dim)``; none has
trainable parameters.  ``build_encoder(spec)`` makes one from a JSON-able spec:

- ``{"kind": "logmel", "n_mels": 80}``: log-mel spectrogram, no pretrained weights;
- ``{"kind": "wav2vec2", "path": DIR}``: wav2vec 2.0 from a local ``from_pretrained``
  directory (the real weights, e.g. facebook/wav2vec2-base-960h downloaded by the user);
- ``{"kind": "wav2vec2-tiny", "seed": 0}``: a tiny random-init wav2vec 2.0 for tests.

The trainable front ends of FaceFormer and CodeTalker, built from a spec of their
own, are in :mod:`baselines.common.encoders.trainable`.
"""

from __future__ import annotations

from baselines.common.encoders.interpolate import interpolate_features
from baselines.common.encoders.logmel import (
    LogMelEncoder,
    log_mel_spectrogram,
    mel_filterbank,
)
from baselines.common.encoders.wav2vec2 import Wav2Vec2Encoder
from blendvoca.errors import UserError

ENCODER_KINDS = ("logmel", "wav2vec2", "wav2vec2-tiny")


def build_encoder(spec: dict):
    """Return the frozen encoder described by ``spec``.

    Parameters
    ----------
    spec : dict
        ``{"kind": ..., **options}``, see the module docstring.

    Returns
    -------
    encoder : torch.nn.Module
    """
    if not isinstance(spec, dict) or "kind" not in spec:
        raise TypeError(f"build_encoder: expected a dict with a 'kind' key, got {spec!r}")
    options = {k: v for k, v in spec.items() if k != "kind"}
    kind = spec["kind"]
    if kind == "logmel":
        encoder = LogMelEncoder(**options)
    elif kind == "wav2vec2":
        encoder = Wav2Vec2Encoder.from_pretrained(**options)
    elif kind == "wav2vec2-tiny":
        encoder = Wav2Vec2Encoder.tiny(**options)
    else:
        raise UserError(f"build_encoder: expected kind in {ENCODER_KINDS}, got {kind!r}")
    for p in encoder.parameters():
        p.requires_grad_(False)
    return encoder.eval()


__all__ = ["ENCODER_KINDS", "LogMelEncoder", "Wav2Vec2Encoder", "build_encoder", "interpolate_features",
           "log_mel_spectrogram", "mel_filterbank"]
