"""Resampling of mesh (or coefficient) sequences to another frame rate."""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError


def resample_sequence(frames, fps_in: float, fps_out: float = 60.0, *, num_frames=None) -> np.ndarray:
    """Return ``frames`` linearly interpolated in time from ``fps_in`` to ``fps_out``.

    Frame ``i`` of the output is the input at time ``i / fps_out`` (the first
    frames coincide); times past the last input frame hold the last frame.

    Parameters
    ----------
    frames : (T, ...) array_like
        Sequence sampled at ``fps_in`` (e.g. ``(T, V, 3)`` meshes or ``(T, K)``
        coefficients).
    fps_in, fps_out : float
        Input and output frame rates (frames per second).
    num_frames : int, optional
        Output length; default ``round(T * fps_out / fps_in)`` (same duration).

    Returns
    -------
    (T_out, ...) ndarray of float64
    """
    frames = np.asarray(frames, dtype=np.float64)
    if frames.ndim < 1 or frames.shape[0] == 0:
        raise UserError(f"resample_sequence: frames must be (T, ...) with T >= 1, got {frames.shape}")
    for name, value in (("fps_in", fps_in), ("fps_out", fps_out)):
        if not np.isscalar(value) or not np.isfinite(value) or value <= 0:
            raise UserError(f"resample_sequence: {name} must be a positive number, got {value!r}")
    num_in = frames.shape[0]
    if num_frames is None:
        num_frames = max(1, int(round(num_in * fps_out / fps_in)))
    if int(num_frames) != num_frames or num_frames < 1:
        raise UserError(f"resample_sequence: num_frames must be a positive integer, got {num_frames!r}")
    num_frames = int(num_frames)
    if fps_in == fps_out and num_frames == num_in:
        return frames.copy()
    position = np.minimum(np.arange(num_frames) * (fps_in / fps_out), num_in - 1)
    left = np.floor(position).astype(np.int64)
    right = np.minimum(left + 1, num_in - 1)
    weight = (position - left).reshape((-1,) + (1,) * (frames.ndim - 1))
    return (1.0 - weight) * frames[left] + weight * frames[right]
