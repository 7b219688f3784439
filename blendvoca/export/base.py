"""What an export format is: one class in its own module of :mod:`blendvoca.export`,
named in :data:`blendvoca.export.FORMAT_REGISTRY` (adding a format is that module and
one registry line)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blendvoca.errors import UserError
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
    copy_audio : reference a copy of the sound beside the export (:func:`export_audio`)
    """

    fps: float = 60.0
    rig: object = None
    audio: object = None
    convention: str | None = None
    copy_audio: bool = False


def audio_beside(audio, out) -> Path:
    """A copy of the sound file ``audio`` beside the export ``out``, under its own name
    (made atomically; an identical file already there is used).

    Raises
    ------
    UserError
        A different file of the sound's name is already there (it is never replaced).
    """
    import filecmp
    import shutil

    audio, folder = Path(os.fspath(audio)).resolve(), Path(os.fspath(out)).resolve().parent
    target = folder / audio.name
    if target == audio:
        return target
    if target.exists():
        if not filecmp.cmp(audio, target, shallow=False):
            raise UserError(f"--copy-audio: {target} exists and is not a copy of {audio}; move it or rename the audio")
        return target
    folder.mkdir(parents=True, exist_ok=True)
    partial = target.with_name(f".{target.name}.partial")
    shutil.copyfile(audio, partial)
    os.replace(partial, target)
    return target


def audio_reference(audio, out) -> str:
    """How an export at ``out`` names its sound file ``audio``: the path relative to the
    export's folder, with ``/`` separators, so that the two can be moved together (absolute
    only where no relative path exists: another drive)."""
    audio, folder = Path(os.fspath(audio)).resolve(), Path(os.fspath(out)).resolve().parent
    try:
        return Path(os.path.relpath(audio, folder)).as_posix()
    except ValueError:  # another drive (Windows)
        return audio.as_posix()


def export_audio(options: ExportOptions, out) -> Path | None:
    """The sound file an export at ``out`` references: ``options.audio``, or its copy beside
    the export when ``options.copy_audio``."""
    if options.audio is None:
        return None
    return audio_beside(options.audio, out) if options.copy_audio else Path(os.fspath(options.audio))


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
