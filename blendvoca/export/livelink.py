"""``livelink``: a track as the CSV Epic's Live Link Face app exports for a take.

The file format (header, timecodes, the take's rate, the rotations) is owned by
:mod:`blendvoca.io.livelink`, which both writes and reads it; this module aligns a
track's columns to the app's 52 shapes and writes the rotations as 0. At a rate
that is no whole number (59.94) the timecodes count ``FF`` at that rate, and reading
the file back tells the rate from them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.export.base import ExportFormat, ExportOptions
from blendvoca.io.atomic import atomic_write
from blendvoca.io.livelink import (
    format_livelink_csv as _format_take,
    livelink_timecode,
    parse_livelink_timecode,
    read_livelink_take,
)

__all__ = ["LiveLinkCsv", "format_livelink_csv", "livelink_timecode", "parse_livelink_timecode",
           "read_livelink_csv", "write_livelink_csv"]


def format_livelink_csv(coeffs, names: Sequence[str], fps: float = 60.0) -> tuple[str, AlignedTrack]:
    """The CSV text of a track in Live Link Face's layout; shapes the track lacks are 0,
    the rotations are 0."""
    aligned = align_track(coeffs, names, "livelink", where="livelink")
    return _format_take(aligned.coeffs, aligned.names, fps), aligned


def write_livelink_csv(path, coeffs, names: Sequence[str], fps: float = 60.0) -> AlignedTrack:
    """Write a Live Link Face CSV, atomically; returns the track as written (52 columns)."""
    text, aligned = format_livelink_csv(coeffs, names, fps)
    with atomic_write(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    return aligned


def read_livelink_csv(path, fps: float = 60.0) -> tuple[np.ndarray, tuple[str, ...], np.ndarray, float]:
    """Read a Live Link Face CSV (:func:`blendvoca.io.livelink.read_livelink_take`).

    Returns
    -------
    coeffs : (T, 52) float64 ndarray, columns in ARKit's order (the ``arkit52`` convention)
    names : the 52 camelCase names
    times : (R,) float64 ndarray, seconds of each row's timecode
    rate : the take's frame rate told by the timecodes (``fps`` for a file within one second)
    """
    take = read_livelink_take(path, fps=fps)
    return take.weights, take.names, take.times, take.fps


class LiveLinkCsv(ExportFormat):
    """``livelink``: Live Link Face CSV (Unreal, MetaHuman)."""

    name, suffix = "livelink", ".csv"

    def write(self, out, coeffs, names, options: ExportOptions) -> AlignedTrack:
        return write_livelink_csv(out, coeffs, names, options.fps)

    def read(self, path, *, fps: float):
        """The take's rows and the rate its timecodes tell (``fps`` for a file within one second)."""
        coeffs, names, _, rate = read_livelink_csv(path, fps)
        return coeffs, names, rate
