"""wav2vec 2.0 speech encoder (transformers), features resampled to the coefficient frame rate,
and the waveform normalisation every wav2vec 2.0 user of the baselines applies."""

from __future__ import annotations

import os

import torch
from torch import nn

from baselines.wav2vec2 import interpolated_features, pretrained_wav2vec2_model, tiny_config, wav2vec2_model

__all__ = ["Wav2Vec2Encoder", "normalize_waveform"]


def normalize_waveform(audio: torch.Tensor) -> torch.Tensor:
    """Return each waveform with zero mean and unit variance (wav2vec 2.0's input normalisation).

    ``(x - mean) / sqrt(var + 1e-7)`` with the population variance: what SAiD's
    ``process_audio`` and FaceFormer's and CodeTalker's ``Wav2Vec2Processor`` (the
    base-960h feature extractor) do.

    Parameters
    ----------
    audio : (B, N) Tensor

    Returns
    -------
    normalized : (B, N) Tensor
    """
    mean = audio.mean(dim=-1, keepdim=True)
    var = audio.var(dim=-1, keepdim=True, unbiased=False)
    return (audio - mean) / torch.sqrt(var + 1e-7)


class Wav2Vec2Encoder(nn.Module):
    """Frozen wav2vec 2.0 with a linear interpolation layer after its CNN.

    The CNN features (~50 fps) are resampled to the requested frame count before the
    transformer, as in SAiD and FaceFormer, so the output has exactly one feature per
    coefficient frame.

    Parameters
    ----------
    model : transformers.Wav2Vec2Model
    """

    def __init__(self, model):
        super().__init__()
        self.model = model
        self.feature_dim = int(model.config.hidden_size)
        self.sample_rate = 16000

    @classmethod
    def from_pretrained(cls, path: str | os.PathLike) -> Wav2Vec2Encoder:
        """Load the weights from a local directory (``config.json`` + weights).

        Raises
        ------
        UserError
            ``path`` holds no ``config.json``.
        """
        return cls(pretrained_wav2vec2_model(path))

    @classmethod
    def tiny(cls, seed: int = 0) -> Wav2Vec2Encoder:
        """Return a tiny random-init encoder (deterministic in ``seed``), for tests."""
        with torch.random.fork_rng():
            torch.manual_seed(seed)
            model = wav2vec2_model(tiny_config())
        return cls(model)

    def forward(self, audio: torch.Tensor, num_frames: int) -> torch.Tensor:
        """Return features ``(B, num_frames, hidden_size)`` for 16 kHz audio ``(B, N)``."""
        if audio.ndim != 2:
            raise ValueError(f"Wav2Vec2Encoder: expected (B, N) audio, got shape {tuple(audio.shape)}")
        if audio.shape[-1] < 400:
            audio = torch.nn.functional.pad(audio, (0, 400 - audio.shape[-1]))
        return interpolated_features(self.model, normalize_waveform(audio.float()), num_frames)
