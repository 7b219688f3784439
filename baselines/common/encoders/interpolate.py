"""Linear resampling of feature sequences to the coefficient frame count."""

from __future__ import annotations

import torch
import torch.nn.functional as F


def interpolate_features(features: torch.Tensor, num_frames: int) -> torch.Tensor:
    """Return ``features`` linearly resampled in time to ``num_frames`` frames.

    Frame centres are matched (``align_corners=False``): both sequences cover the
    same duration, e.g. ~50 fps wav2vec 2.0 features to 60 fps coefficients.

    Parameters
    ----------
    features : (B, T_in, D) Tensor
    num_frames : int

    Returns
    -------
    resampled : (B, num_frames, D) Tensor
    """
    if features.ndim != 3:
        raise ValueError(f"interpolate_features: expected (B, T_in, D) features, got shape {tuple(features.shape)}")
    if int(num_frames) != num_frames or num_frames < 1:
        raise ValueError(f"interpolate_features: expected num_frames >= 1, got {num_frames!r}")
    if features.shape[1] == num_frames:
        return features
    out = F.interpolate(features.transpose(1, 2), size=int(num_frames), mode="linear", align_corners=False)
    return out.transpose(1, 2)
