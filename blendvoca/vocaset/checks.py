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


def frame_gaps(numbers: np.ndarray) -> list[int]:
    """Frame numbers missing from a sorted ``(T,)`` integer sequence that should be contiguous."""
    numbers = np.asarray(numbers, dtype=np.int64)
    if len(numbers) == 0:
        return []
    expected = np.arange(numbers[0], numbers[-1] + 1)
    return sorted(set(expected.tolist()) - set(numbers.tolist()))


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
