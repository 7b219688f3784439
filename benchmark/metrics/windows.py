"""The window protocol: how coefficient tracks are cut into 120-frame windows.

One function, :func:`cut_windows`, is used by every latent-space metric (FD, WInD,
multimodality) so that ground truth and generated tracks are cut the same way:

* windows of ``window`` frames (120 = 2 s at 60 fps) start at frames
  ``0, stride, 2*stride, ...`` (published protocol: stride 1);
* ground truth of T frames gives ``(T - window) // stride + 1 - gt_drop_last``
  windows (published protocol: the last 2 window starts are dropped); a sequence
  shorter than that gives none;
* a generated track gives ``(T - window) // stride + 1`` windows per sample, and a
  generated window is kept only when the ground truth has a window with the same
  (subject, sentence, start frame): windows past the end of the ground truth and
  sentences without ground truth are dropped.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping
from dataclasses import dataclass

import numpy as np

WINDOW = 120
STRIDE = 1
GT_DROP_LAST = 2


def window_starts(num_frames: int, window: int = WINDOW, stride: int = STRIDE, drop_last: int = 0) -> np.ndarray:
    """Start frames of the windows of a track.

    Parameters
    ----------
    num_frames : int
        Length T of the track.
    window, stride : int
    drop_last : int
        Number of final window starts to drop (2 for ground truth in the
        published protocol).

    Returns
    -------
    (N,) int64 ndarray
        ``N = max(0, (T - window) // stride + 1 - drop_last)``.
    """
    if window < 1 or stride < 1 or drop_last < 0:
        raise ValueError(
            f"window_starts: expected window >= 1, stride >= 1, drop_last >= 0, "
            f"got window={window}, stride={stride}, drop_last={drop_last}"
        )
    if num_frames < window:
        return np.zeros(0, dtype=np.int64)
    count = (num_frames - window) // stride + 1 - drop_last
    return np.arange(max(count, 0), dtype=np.int64) * stride


def slice_windows(track: np.ndarray, starts: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """Windows ``track[s : s + window]`` for each start ``s``.

    Parameters
    ----------
    track : (T, C) ndarray
    starts : (N,) int ndarray
    window : int

    Returns
    -------
    (N, window, C) ndarray (a copy).
    """
    track = np.asarray(track)
    if track.ndim != 2:
        raise ValueError(f"slice_windows: expected track (T, C), got shape {track.shape}")
    starts = np.asarray(starts, dtype=np.int64)
    if starts.size and (starts.min() < 0 or starts.max() + window > len(track)):
        raise ValueError(
            f"slice_windows: windows [{starts.min()}, {starts.max() + window}) exceed track of {len(track)} frames"
        )
    if starts.size == 0:
        return np.zeros((0, window, track.shape[1]), dtype=track.dtype)
    view = np.lib.stride_tricks.sliding_window_view(track, window, axis=0)  # (T-w+1, C, w)
    return np.ascontiguousarray(view[starts].transpose(0, 2, 1))


@dataclass(frozen=True)
class Windows:
    """Windows cut from a split by :func:`cut_windows`.

    Attributes
    ----------
    real : (N, window, C) ndarray
        Ground-truth windows.
    real_keys : list of (key, start)
    fake : (M, window, C) ndarray
        Generated windows kept by the protocol.
    fake_keys : list of (key, start, sample)
    """

    real: np.ndarray
    real_keys: list
    fake: np.ndarray
    fake_keys: list

    def fake_groups(self) -> list:
        """Group id per generated window: (key, start), the same audio window."""
        return [(key, start) for key, start, _ in self.fake_keys]


def cut_windows(
    ground_truth: Mapping[Hashable, np.ndarray],
    generated: Mapping[Hashable, np.ndarray] | None = None,
    window: int = WINDOW,
    stride: int = STRIDE,
    gt_drop_last: int = GT_DROP_LAST,
) -> Windows:
    """Cut ground truth and generated tracks into windows (the published protocol).

    Parameters
    ----------
    ground_truth : mapping key -> (T, C) ndarray
        Key is typically ``(subject, sentence)``.
    generated : mapping key -> (S, T', C) or (T', C) ndarray, optional
        S samples per key.
    window, stride, gt_drop_last : int
        See the module docstring.

    Returns
    -------
    Windows
    """
    real, real_keys = [], []
    channels = None
    for key, track in ground_truth.items():
        track = np.asarray(track, dtype=np.float64)
        if track.ndim != 2:
            raise ValueError(f"cut_windows: ground truth {key!r}: expected (T, C), got shape {track.shape}")
        if channels is None:
            channels = track.shape[1]
        elif track.shape[1] != channels:
            raise ValueError(f"cut_windows: ground truth {key!r} has {track.shape[1]} channels, expected {channels}")
        starts = window_starts(len(track), window, stride, gt_drop_last)
        real.append(slice_windows(track, starts, window))
        real_keys.extend((key, int(s)) for s in starts)
    present = set(real_keys)
    fake, fake_keys = [], []
    for key, tracks in (generated or {}).items():
        tracks = np.asarray(tracks, dtype=np.float64)
        if tracks.ndim == 2:
            tracks = tracks[None]
        if tracks.ndim != 3:
            raise ValueError(f"cut_windows: generated {key!r}: expected (S, T, C), got shape {tracks.shape}")
        if channels is not None and tracks.shape[2] != channels:
            raise ValueError(
                f"cut_windows: generated {key!r} has {tracks.shape[2]} channels, ground truth has {channels}"
            )
        starts = window_starts(tracks.shape[1], window, stride, 0)
        starts = np.array([s for s in starts if (key, int(s)) in present], dtype=np.int64)
        for sample, track in enumerate(tracks):
            fake.append(slice_windows(track, starts, window))
            fake_keys.extend((key, int(s), sample) for s in starts)
    channels = channels or 0
    empty = np.zeros((0, window, channels))
    return Windows(
        real=np.concatenate(real) if real else empty,
        real_keys=real_keys,
        fake=np.concatenate(fake) if fake else empty,
        fake_keys=fake_keys,
    )
