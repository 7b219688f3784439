"""What an export format is: one class in its own module of :mod:`blendvoca.export`,
named in :data:`blendvoca.export.FORMAT_REGISTRY` (adding a format is that module and
one registry line)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from blendvoca.export.align import AlignedTrack


@dataclass(frozen=True)
class RigAnimation:
    """A rig animated by a track, as the readers of the rigged formats recover it.

    Attributes
    ----------
    neutral : (V, 3) float64, faces : (F, 3) int64, deltas : (K, V, 3) float64
    names : tuple of K str
    times : (T,) float64 seconds, weights : (T, K) float64
    """

    neutral: np.ndarray
    faces: np.ndarray
    deltas: np.ndarray
    names: tuple[str, ...]
    times: np.ndarray
    weights: np.ndarray


@dataclass(frozen=True)
class ExportOptions:
    """What :func:`blendvoca.export.export_track` hands every format besides the track.

    Attributes
    ----------
    fps : frame rate of the track
    rig : blendvoca.rig.Rig or None (formats with ``needs_rig`` get one)
    audio : path of the sound or None
    convention : a :mod:`blendvoca.names` convention whose columns to write, or None
        (``csv`` only)
    """

    fps: float = 60.0
    rig: object = None
    audio: object = None
    convention: str | None = None


class ExportFormat:
    """One export format: its name, file suffix, whether it needs a rig, and how a
    checked track is written and read back. Subclasses set the attributes and
    implement :meth:`write` and :meth:`read`."""

    #: The name ``--format`` takes.
    name: str = ""
    #: The suffix of the files it writes.
    suffix: str = ""
    #: Whether it writes the rig's mesh (and so cannot be written without one).
    needs_rig: bool = False
    #: Whether it writes the columns of a naming convention (``ExportOptions.convention``).
    takes_convention: bool = False

    def write(self, out, coeffs: np.ndarray, names: Sequence[str], options: ExportOptions) -> AlignedTrack:
        """Write a checked ``(T, K)`` track whose columns are ``names``; the track as written."""
        raise NotImplementedError

    def read(self, path, *, fps: float) -> tuple[np.ndarray, tuple[str, ...], float]:
        """``(coeffs, names, fps)`` of a file of this format; ``fps`` for files that store no rate."""
        raise NotImplementedError
