"""Mouth activity of a capture that has a jaw rotation and no mesh: the jaw's opening angle.

BEAT2's takes (SMPL-X poses, FLAME expressions whose model cannot be had here) carry
the jaw as an axis-angle rotation, ``poses[:, 66:69]``; its angle from the rest pose
is the articulation signal that :func:`benchmark.lipsync.geometric_sync` correlates
with the speech envelope in place of the lip-vertex displacement.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from scipy.interpolate import interp1d

from blendvoca.errors import DataError

#: Columns of the jaw's axis-angle rotation in an SMPL-X ``poses (T, 165)`` array.
SMPLX_JAW = slice(66, 69)


def jaw_opening(rotations) -> np.ndarray:
    """The jaw's rotation angle (radians) per frame from axis-angle rotations ``(T, 3)``."""
    rot = np.asarray(rotations, dtype=np.float64)
    if rot.ndim != 2 or rot.shape[1] != 3:
        raise DataError(f"jaw_opening: expected axis-angle rotations (T, 3), got {rot.shape}")
    return np.linalg.norm(rot, axis=1)


def resampled_track(track, fps_in: float, fps_out: float = 60.0) -> np.ndarray:
    """A per-frame track at ``fps_in`` linearly resampled to ``fps_out`` over the same span."""
    track = np.asarray(track, dtype=np.float64)
    t_in = np.arange(len(track)) / fps_in
    count = int(np.floor(t_in[-1] * fps_out + 1e-9)) + 1
    return interp1d(t_in, track, axis=0)(np.arange(count) / fps_out)


def read_smplx_jaw(path: str | os.PathLike, fps: float = 60.0) -> np.ndarray:
    """The jaw opening angle of an SMPL-X motion file (BEAT2's ``.npz``: ``poses (T, 165)``,
    ``mocap_frame_rate``), resampled to ``fps``.

    Raises
    ------
    DataError
        The file is not such an archive (names the file and what it holds).
    """
    path = Path(os.fspath(path))
    try:
        with np.load(path, allow_pickle=False) as npz:
            keys = set(npz.files)
            if not {"poses", "mocap_frame_rate"} <= keys:
                raise DataError(f"{path}: expected an SMPL-X motion archive with 'poses' (T, 165) and "
                                f"'mocap_frame_rate', got the arrays {sorted(keys)}")
            poses = np.asarray(npz["poses"], dtype=np.float64)
            rate = float(npz["mocap_frame_rate"])
    except (OSError, ValueError, EOFError) as exc:
        raise DataError(f"{path}: not a readable .npz archive ({exc})") from None
    if poses.ndim != 2 or poses.shape[1] < SMPLX_JAW.stop or len(poses) < 2 or not rate > 0:
        raise DataError(f"{path}: expected poses (T >= 2, 165) and a positive mocap_frame_rate, "
                        f"got poses {poses.shape} at {rate} fps")
    return resampled_track(jaw_opening(poses[:, SMPLX_JAW]), rate, fps)
