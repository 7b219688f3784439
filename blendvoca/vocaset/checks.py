"""Pure checks of loaded VOCASET arrays and files."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np


def first_bad_frame(frames: np.ndarray) -> int | None:
    """Index of the first frame of ``(T, V, 3)`` holding a NaN or infinity, else None."""
    bad = ~np.isfinite(np.asarray(frames)).reshape(len(frames), -1).all(axis=1)
    hits = np.flatnonzero(bad)
    return int(hits[0]) if len(hits) else None


def frame_gaps(numbers: np.ndarray, limit: int | None = None) -> list[int]:
    """Frame numbers missing from a sorted ``(T,)`` integer sequence that should be contiguous.

    Parameters
    ----------
    numbers : (T,) array of int
        Frame numbers, sorted ascending.
    limit : int, optional
        Return at most this many (the first ones): the work stays proportional to
        ``T`` however far apart two numbers are.
    """
    numbers = np.asarray(numbers, dtype=np.int64)
    missing: list[int] = []
    for j in np.flatnonzero(np.diff(numbers) > 1):
        start, stop = int(numbers[j]) + 1, int(numbers[j + 1])
        if limit is not None:
            stop = min(stop, start + limit - len(missing))
        missing.extend(range(start, stop))
        if limit is not None and len(missing) >= limit:
            break
    return missing


def wav_truncation(path) -> str | None:
    """Why a RIFF/WAVE file is shorter than its header says, or None if it is whole.

    libsndfile silently reads what is there when the ``data`` chunk is cut, so
    truncation has to be checked against the declared chunk size.
    """
    data = Path(path).read_bytes()
    if len(data) < 12 or data[:4] not in (b"RIFF", b"RF64") or data[8:12] != b"WAVE":
        return None  # not RIFF: let the decoder judge it
    offset = 12
    while offset + 8 <= len(data):
        chunk, size = data[offset:offset + 4], struct.unpack("<I", data[offset + 4:offset + 8])[0]
        if chunk == b"data":
            available = len(data) - offset - 8
            if size != 0xFFFFFFFF and available < size:
                return f"data chunk declares {size} bytes, only {available} present"
            return None
        offset += 8 + size + (size & 1)
    return "no 'data' chunk before the end of the file"


#: Root-mean-square distance of FLAME's vertices from their centroid, in metres
#: (the ``flame-sample`` asset: 0.0834 m; VOCASET's speakers lie within a few per cent of it).
FLAME_RMS_RADIUS = 0.0834
#: How far a template's size may be from FLAME's (a factor, either way) before it is taken
#: for another unit: heads differ by far less, millimetres are 1000x and centimetres 100x.
SCALE_TOLERANCE = 4.0
#: How far an audio clip's duration may be from its motion's before it is reported (a fraction).
DURATION_TOLERANCE = 0.05


def rms_radius(vertices: np.ndarray) -> float:
    """Root-mean-square distance of ``(V, 3)`` vertices from their centroid."""
    vertices = np.asarray(vertices, dtype=np.float64)
    return float(np.sqrt(np.mean(np.sum((vertices - vertices.mean(axis=0)) ** 2, axis=1))))


def template_scale_problem(template: np.ndarray, tolerance: float = SCALE_TOLERANCE) -> str | None:
    """Why a FLAME template's size is implausible (in another unit than metres), or None.

    Parameters
    ----------
    template : (V, 3) ndarray
        A speaker's neutral mesh, in metres.
    tolerance : float
        The factor by which its RMS radius may differ from FLAME's.
    """
    radius = rms_radius(template)
    ratio = radius / FLAME_RMS_RADIUS
    if np.isfinite(ratio) and 1.0 / tolerance <= ratio <= tolerance:
        return None
    unit = {1000: " (millimetres?)", 100: " (centimetres?)"}.get(int(round(ratio, -2)) if ratio > 50 else 0, "")
    factor = f"{ratio:.0f}" if ratio >= 10 else f"{ratio:.3g}"
    return (f"template scale implausible: RMS radius {radius:.4g} m is {factor}x FLAME's "
            f"{FLAME_RMS_RADIUS} m{unit}; expected a FLAME head in metres")


def duration_mismatch(num_frames: int, fps: float, num_samples: int, rate: float,
                      tolerance: float = DURATION_TOLERANCE) -> str | None:
    """Why a sentence's audio and motion differ in length by more than ``tolerance``, or None.

    Parameters
    ----------
    num_frames, fps : motion frames and their rate.
    num_samples, rate : audio samples and their rate.
    tolerance : float
        Largest accepted difference, as a fraction of the motion's duration.
    """
    motion = num_frames / float(fps)
    audio = num_samples / float(rate)
    if motion > 0 and abs(audio - motion) <= tolerance * motion:
        return None
    off = (audio - motion) / motion * 100 if motion > 0 else float("inf")
    return (f"audio lasts {audio:.3f} s, motion {motion:.3f} s ({num_frames} frames at {fps:g} fps): "
            f"{off:+.1f} % (more than {tolerance * 100:g} % apart)")
