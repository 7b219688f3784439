"""Frame-rate conversion of tracks (60 fps motion -> 25 fps video)."""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError


def resample_frames(frames, src_fps: float, dst_fps: float) -> np.ndarray:
    """Linearly interpolate a sequence to another frame rate.

    Frame t of the output is at time ``t / dst_fps``; the output covers the
    input's duration: ``floor((T - 1) * dst_fps / src_fps) + 1`` frames.

    Parameters
    ----------
    frames : (T, ...) array_like
    src_fps, dst_fps : float

    Returns
    -------
    (T', ...) float64 ndarray
    """
    x = np.asarray(frames, dtype=np.float64)
    if x.ndim < 1 or len(x) == 0:
        raise UserError(f"resample_frames: expected a non-empty sequence (T, ...), got shape {x.shape}")
    if src_fps <= 0 or dst_fps <= 0:
        raise UserError(f"resample_frames: frame rates must be positive, got {src_fps}, {dst_fps}")
    count = int(np.floor((len(x) - 1) * dst_fps / src_fps + 1e-9)) + 1
    pos = np.arange(count) * (src_fps / dst_fps)
    lo = np.clip(np.floor(pos).astype(np.int64), 0, len(x) - 1)
    hi = np.clip(lo + 1, 0, len(x) - 1)
    w = (pos - lo).reshape((-1,) + (1,) * (x.ndim - 1))
    return (1 - w) * x[lo] + w * x[hi]
