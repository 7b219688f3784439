"""The trainable speech front ends of FaceFormer and CodeTalker: features at the motion frame rate.

``wav2vec2`` is the authors' encoder: wav2vec 2.0 whose CNN features (50 per second)
are resampled linearly to the motion frame count before its transformer; without a
frame count, ``int(cnn_frames / 50 * fps)`` frames (the authors' inference rule).
``logmel`` is a light stand-in for CPU training: a log-mel spectrogram resampled to
the frame count followed by a trainable 1-D convolution stack (temporal context
that the wav2vec 2.0 transformer would otherwise supply).
"""

from __future__ import annotations

import os

import torch
from torch import nn

from baselines.common.encoders.logmel import LogMelEncoder
from baselines.common.presets import expand_path
from baselines.wav2vec2 import (
    base_config,
    linear_interpolation,
    pretrained_wav2vec2_model,
    projected_features,
    tiny_config,
    wav2vec2_model,
)
from blendvoca.errors import UserError

__all__ = ["LogMelContextEncoder", "authors_frame_count", "build_audio_encoder", "load_pretrained_wav2vec2",
           "motion_audio_features", "wav2vec2_motion_features"]


def authors_frame_count(num_cnn_frames: int, fps: int = 30, cnn_rate: int = 50) -> int:
    """Motion frames the authors' inference derives from the CNN feature count: ``int(n / 50 * fps)``."""
    return int(num_cnn_frames / float(cnn_rate) * fps)


def wav2vec2_motion_features(model, audio: torch.Tensor, num_frames: int | None = None, *, fps: int = 30) -> torch.Tensor:
    """wav2vec 2.0 last hidden states, one per motion frame.

    Parameters
    ----------
    model : transformers.Wav2Vec2Model
    audio : (B, N) Tensor
        Normalised 16 kHz speech (:func:`~baselines.common.encoders.wav2vec2.normalize_waveform`).
    num_frames : int, optional
        Motion frames; default :func:`authors_frame_count` of the CNN output.
    fps : int, default 30

    Returns
    -------
    (B, T, hidden_size) Tensor
    """
    cnn = model.feature_extractor(audio).transpose(1, 2)
    if num_frames is None:
        num_frames = authors_frame_count(cnn.shape[1], fps)
    hidden = projected_features(model, linear_interpolation(cnn, num_frames))
    if model.training and getattr(model.config, "apply_spec_augment", False):
        hidden = model._mask_hidden_states(hidden)
    return model.encoder(hidden).last_hidden_state


class LogMelContextEncoder(nn.Module):
    """Log-mel features at the motion frame rate with a trainable convolutional context.

    Parameters
    ----------
    n_mels : int, default 80
    hidden_size : int, default 64
        Output feature size (the ``768`` of wav2vec 2.0).
    layers : int, default 2
        Convolutions (kernel ``kernel``, GELU) after a 1x1 input projection.
    kernel : int, default 5
    """

    def __init__(self, n_mels: int = 80, hidden_size: int = 64, layers: int = 2, kernel: int = 5):
        super().__init__()
        self.logmel = LogMelEncoder(n_mels=n_mels)
        self.hidden_size = int(hidden_size)
        blocks = [nn.Conv1d(n_mels, hidden_size, 1)]
        for _ in range(int(layers)):
            blocks += [nn.GELU(), nn.Conv1d(hidden_size, hidden_size, kernel, padding=kernel // 2)]
        self.context = nn.Sequential(*blocks)

    def forward(self, audio: torch.Tensor, num_frames: int | None = None, *, fps: int = 30) -> torch.Tensor:
        """audio (B, N) 16 kHz -> (B, T, hidden_size); default ``T = int(N / 16000 * fps)``."""
        if num_frames is None:
            num_frames = max(1, int(audio.shape[-1] / 16000.0 * fps))
        with torch.no_grad():
            mel = self.logmel(audio, int(num_frames))
        return self.context(mel.transpose(1, 2)).transpose(1, 2)


def build_audio_encoder(spec: dict) -> tuple[nn.Module, int]:
    """The speech encoder of ``spec`` and its feature size.

    ``{"kind": "wav2vec2", "config": "base" | "tiny" | {Wav2Vec2Config fields}}``: a
    randomly initialised wav2vec 2.0 (weights come from a checkpoint), CNN frozen as
    the authors do; ``{"kind": "logmel", "n_mels": 80, "hidden_size": 64, "layers": 2}``:
    :class:`LogMelContextEncoder`.
    """
    kind = spec.get("kind")
    if kind == "wav2vec2":
        which = spec.get("config", "base")
        if which == "base":
            config = base_config()
        elif which == "tiny":
            config = tiny_config()
        elif isinstance(which, dict):
            config = base_config(**which)
        else:
            raise UserError(f"audio encoder: expected config 'base', 'tiny' or a dict, got {which!r}")
        model = wav2vec2_model(config)
        model.feature_extractor._freeze_parameters()
        return model, int(config.hidden_size)
    if kind == "logmel":
        options = {k: v for k, v in spec.items() if k != "kind"}
        encoder = LogMelContextEncoder(**options)
        return encoder, encoder.hidden_size
    raise UserError(f"audio encoder: expected kind 'wav2vec2' or 'logmel', got {kind!r}")


def motion_audio_features(encoder: nn.Module, audio: torch.Tensor, num_frames: int | None = None, *,
                          fps: int = 30) -> torch.Tensor:
    """Features ``(B, T, hidden_size)`` of an encoder of :func:`build_audio_encoder`, one per motion frame.

    Parameters
    ----------
    encoder : LogMelContextEncoder or transformers.Wav2Vec2Model
    audio : (B, N) Tensor
        16 kHz speech, normalised for wav2vec 2.0.
    num_frames : int, optional
        Motion frames; default the authors' count from the audio length.
    fps : int, default 30
    """
    if isinstance(encoder, LogMelContextEncoder):
        return encoder(audio, num_frames, fps=fps)
    return wav2vec2_motion_features(encoder, audio, num_frames, fps=fps)


def load_pretrained_wav2vec2(model, path: str | os.PathLike) -> None:
    """Copy the weights of a local ``from_pretrained`` wav2vec 2.0 directory into ``model`` (a Wav2Vec2Model).

    ``path`` may be a preset's ``${VAR:-default}`` form (:func:`~baselines.common.presets.expand_path`).

    Raises
    ------
    UserError
        ``path`` holds no ``config.json``.
    """
    pretrained = pretrained_wav2vec2_model(expand_path(os.fspath(path)))
    model.load_state_dict(pretrained.state_dict(), strict=False)
