"""Live Link Face CSV: what Epic's iOS app writes when a take is exported.

Layout (checked against a take exported by the app): header ``Timecode,
BlendShapeCount``, the 52 ARKit shapes in PascalCase in the app's order
(:data:`blendvoca.names.LIVELINK_SHAPE_COLUMNS`), then ``HeadYaw`` ... ``RightEyeRoll``;
every row ``HH:MM:SS:FF.fff`` (FF the frame within the second, .fff the subframe),
``61`` and 61 values with 10 decimals.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Sequence

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.export.base import ExportFormat, ExportOptions
from blendvoca.io.atomic import atomic_write
from blendvoca.io.coeffs import read_coeffs_csv
from blendvoca.names import LIVELINK_HEADER, LIVELINK_ROTATION_COLUMNS, LIVELINK_SHAPE_COLUMNS

_TIMECODE = re.compile(r"^(\d+):(\d{2}):(\d{2}):(\d+)(?:\.(\d+))?$")


def livelink_timecode(frame: int, fps: float) -> str:
    """The app's timecode of frame ``frame`` at ``fps``: ``HH:MM:SS:FF.fff``.

    ``FF`` counts frames within the second, ``.fff`` is the fraction of a frame
    (0 for a track sampled exactly at ``fps``).
    """
    if fps <= 0:
        raise UserError(f"livelink_timecode: fps must be positive, got {fps}")
    seconds_total = math.floor(frame / fps + 1e-9)
    within = frame - seconds_total * fps  # frames into the second, may be fractional
    whole = math.floor(within + 1e-9)
    sub = int(round((within - whole) * 1000))
    if sub == 1000:
        whole, sub = whole + 1, 0
    h, rem = divmod(seconds_total, 3600)
    m, s = divmod(rem, 60)
    return f"{h:02d}:{m:02d}:{s:02d}:{whole:02d}.{sub:03d}"


def parse_livelink_timecode(text: str, fps: float) -> float:
    """Seconds of an ``HH:MM:SS:FF[.fff]`` timecode at ``fps``."""
    match = _TIMECODE.match(text.strip())
    if not match:
        raise DataError(f"not a Live Link timecode: {text!r}; expected HH:MM:SS:FF.fff")
    h, m, s, f = (int(g) for g in match.groups()[:4])
    sub = float("0." + match.group(5)) if match.group(5) else 0.0
    return h * 3600 + m * 60 + s + (f + sub) / fps


def format_livelink_csv(coeffs, names: Sequence[str], fps: float = 60.0) -> tuple[str, AlignedTrack]:
    """The CSV text of a track in Live Link Face's layout; shapes the track lacks are 0,
    the rotations are 0."""
    aligned = align_track(coeffs, names, "livelink", where="livelink")
    rotations = np.zeros(len(LIVELINK_ROTATION_COLUMNS))
    lines = [",".join(LIVELINK_HEADER)]
    count = len(LIVELINK_SHAPE_COLUMNS) + len(LIVELINK_ROTATION_COLUMNS)
    for t, row in enumerate(aligned.coeffs):
        values = ",".join(("%.10f" % v).replace("-0.0000000000", "0.0000000000") for v in np.r_[row, rotations])
        lines.append(f"{livelink_timecode(t, fps)},{count},{values}")
    return "\n".join(lines) + "\n", aligned


def write_livelink_csv(path, coeffs, names: Sequence[str], fps: float = 60.0) -> AlignedTrack:
    """Write a Live Link Face CSV, atomically; returns the track as written (52 columns)."""
    text, aligned = format_livelink_csv(coeffs, names, fps)
    with atomic_write(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    return aligned


def read_livelink_csv(path, fps: float = 60.0) -> tuple[np.ndarray, tuple[str, ...], np.ndarray]:
    """Read a Live Link Face CSV.

    Returns
    -------
    coeffs : (T, 52) float64 ndarray, columns in ARKit's order (the ``arkit52`` convention)
    names : the 52 camelCase names
    times : (T,) float64 ndarray, seconds of each row's timecode at ``fps``
    """
    coeffs, names = read_coeffs_csv(path, names="arkit52")
    with open(path, newline="", encoding="utf-8-sig") as f:
        reader = csv.reader(f)
        header = [h.strip() for h in next(reader)]
        if "Timecode" not in header:
            raise DataError(f"{path}: no Timecode column; expected Live Link Face's header {LIVELINK_HEADER[:3]}...")
        column = header.index("Timecode")
        times = []
        for t, row in enumerate(r for r in reader if r):
            try:
                times.append(parse_livelink_timecode(row[column], fps))
            except ValueError as error:
                raise DataError(f"{path}: row {t + 2} (frame {t}): {error}") from None
    return coeffs, names, np.asarray(times, dtype=np.float64)


class LiveLinkCsv(ExportFormat):
    """``livelink``: Live Link Face CSV (Unreal, MetaHuman)."""

    name, suffix = "livelink", ".csv"

    def write(self, out, coeffs, names, options: ExportOptions) -> AlignedTrack:
        return write_livelink_csv(out, coeffs, names, options.fps)

    def read(self, path, *, fps: float):
        coeffs, names, _ = read_livelink_csv(path, fps)
        return coeffs, names, fps
