"""The wav2vec 2.0 feature pass with the interpolation to the motion frame rate.

FaceFormer, CodeTalker and SAiD resample the CNN features (about 50 per second)
linearly to the motion frame count *before* the feature projection and the
transformer, so the encoder outputs one feature per motion frame.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

__all__ = ["interpolated_features", "linear_interpolation", "projected_features"]


def linear_interpolation(features: torch.Tensor, num_frames: int) -> torch.Tensor:
    """Features resampled along time with ``F.interpolate(mode="linear", align_corners=True)``.

    Parameters
    ----------
    features : (B, T_in, C) Tensor
    num_frames : int

    Returns
    -------
    (B, num_frames, C) Tensor
    """
    return F.interpolate(features.transpose(1, 2), size=int(num_frames), align_corners=True,
                         mode="linear").transpose(1, 2)


def projected_features(model, features: torch.Tensor) -> torch.Tensor:
    """``model.feature_projection(features)`` as one tensor (newer transformers return a tuple)."""
    out = model.feature_projection(features)
    return out[0] if isinstance(out, tuple) else out


def interpolated_features(model, audio: torch.Tensor, num_frames: int) -> torch.Tensor:
    """Last hidden states of ``model`` (a ``Wav2Vec2Model``) with ``num_frames`` frames.

    Parameters
    ----------
    model : transformers.Wav2Vec2Model
    audio : (B, N) Tensor
        16 kHz waveform, already normalised as the method's processor does.
    num_frames : int

    Returns
    -------
    (B, num_frames, hidden_size) Tensor
    """
    cnn = model.feature_extractor(audio).transpose(1, 2)
    hidden = projected_features(model, linear_interpolation(cnn, num_frames))
    return model.encoder(hidden).last_hidden_state
