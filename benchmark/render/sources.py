"""Frame sources: the vertices of a sequence one frame at a time, so that a render of any
length holds a few frames, not the clip.

A source has ``len(source)`` frames and ``source.frame(t)`` gives frame ``t`` as a
``(V, 3)`` float64 array; frames are asked for in order (each source keeps a small
window of them).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError

#: Frames evaluated or read at once (a window that bounds the memory a source holds).
CHUNK = 64


class ArraySource:
    """Frames of a ``(T, V, 3)`` array (in memory or memory-mapped); with ``path`` (the .npy
    it maps) it pickles as the path, so a worker process maps the file, not a copy."""

    def __init__(self, vertices, path=None):
        self.vertices = vertices
        self.path = path
        self.num_vertices = int(vertices.shape[1])

    def __getstate__(self):
        if self.path is None:
            return self.__dict__
        return {**self.__dict__, "vertices": None}

    def __setstate__(self, state):
        self.__dict__.update(state)
        if self.vertices is None:
            self.vertices = np.load(self.path, allow_pickle=False, mmap_mode="r")

    def __len__(self) -> int:
        return len(self.vertices)

    def frame(self, t: int) -> np.ndarray:
        return np.asarray(self.vertices[t], dtype=np.float64)


class RigSource:
    """Frames of a coefficient track ``(T, K)`` through a linear rig, evaluated ``CHUNK``
    frames at a time with ``rig.evaluate``."""

    def __init__(self, coeffs, rig):
        self.coeffs = np.asarray(coeffs, dtype=np.float64)
        self.rig = rig
        self.num_vertices = int(np.asarray(rig.neutral).shape[0])
        self._start = None
        self._chunk = None

    def __len__(self) -> int:
        return len(self.coeffs)

    def frame(self, t: int) -> np.ndarray:
        if self._start is None or not self._start <= t < self._start + len(self._chunk):
            self._chunk = None  # freed before the next window is made
            self._start = t
            self._chunk = self.rig.evaluate(self.coeffs[t:t + CHUNK])
        return self._chunk[t - self._start]


class FileSource:
    """Frames of a folder of mesh files (one file a frame), read ``CHUNK`` at a time."""

    def __init__(self, files: Sequence[Path], num_vertices: int):
        self.files = list(files)
        self.num_vertices = int(num_vertices)
        self._start = None
        self._chunk = None

    def __len__(self) -> int:
        return len(self.files)

    def _read(self, start: int) -> np.ndarray:
        from blendvoca.io.mesh import MeshFormatError, read_mesh, read_ply_vertices

        files = self.files[start:start + CHUNK]
        chunk = np.empty((len(files), self.num_vertices, 3))
        for k, path in enumerate(files):
            where = f"frame {start + k + 1} of {len(self.files)}"
            try:
                v = read_ply_vertices(path) if path.suffix.lower() == ".ply" else read_mesh(path)[0]
            except MeshFormatError as error:
                raise MeshFormatError(f"{where}: {error}") from None
            if v.shape != (self.num_vertices, 3):
                raise DataError(f"{where} ({path}): {len(v)} vertices, the first frame {self.files[0].name} has "
                                f"{self.num_vertices}; the frames of a sequence share one topology")
            chunk[k] = v
        return chunk

    def frame(self, t: int) -> np.ndarray:
        if self._start is None or not self._start <= t < self._start + len(self._chunk):
            self._chunk = None
            self._start = t
            self._chunk = self._read(t)
            bad = np.argwhere(~np.isfinite(self._chunk))
            if len(bad):
                k = int(bad[0][0])
                raise DataError(f"{self.files[t + k]}: NaN or infinite coordinates (frame {t + k})")
        return self._chunk[t - self._start]


class Resampled:
    """A source resampled linearly in time from ``src_fps`` to ``dst_fps``: frame ``t`` is
    at ``t / dst_fps``, as :func:`benchmark.render.timing.resample_frames` computes it."""

    def __init__(self, source, src_fps: float, dst_fps: float):
        from blendvoca.errors import UserError

        if len(source) == 0:
            raise UserError("resample: expected a non-empty sequence")
        if src_fps <= 0 or dst_fps <= 0:
            raise UserError(f"resample: frame rates must be positive, got {src_fps}, {dst_fps}")
        self.source = source
        self.num_vertices = source.num_vertices
        self.ratio = src_fps / dst_fps
        self._count = int(np.floor((len(source) - 1) * dst_fps / src_fps + 1e-9)) + 1

    def __len__(self) -> int:
        return self._count

    def frame(self, t: int) -> np.ndarray:
        pos = t * self.ratio
        lo = min(max(int(np.floor(pos)), 0), len(self.source) - 1)
        hi = min(lo + 1, len(self.source) - 1)
        w = pos - lo
        return (1 - w) * self.source.frame(lo) + w * self.source.frame(hi)


def resampled(source, src_fps: float, dst_fps: float):
    """``source`` at ``dst_fps`` (itself when the rates are equal)."""
    return source if src_fps == dst_fps else Resampled(source, src_fps, dst_fps)


def check_finite_chunks(vertices, where: str) -> None:
    """Raise :class:`DataError` naming the first frame of a ``(T, V, 3)`` (memory-mapped)
    array with a NaN or infinite coordinate, reading ``CHUNK`` frames at a time."""
    for start in range(0, len(vertices), CHUNK):
        chunk = np.asarray(vertices[start:start + CHUNK])
        bad = ~np.isfinite(chunk)
        if bad.any():
            raise DataError(f"{where}: NaN or infinite coordinates (first in frame "
                            f"{start + int(np.argwhere(bad)[0][0])})")
