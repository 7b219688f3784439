"""Frames cropped to a vertex subset, made a few frames at a time.

A sentence's frames cropped to the FLAME head are tens of MB in float64, and the
fit reads them twice (the normal equations, then the errors of the fitted
track).  :class:`FrameCrop` gives the crop in chunks of frames instead: each
chunk is taken from the frames as stored (VOCASET keeps float32), converted to
float64 (exactly) and consumed while it is still in cache, so no whole crop, and
no float64 copy of the uncropped frames, is ever made.  The products computed
from the chunks are the rows of the whole-array products, bit for bit.
"""

from __future__ import annotations

import numpy as np

#: Frames per chunk: large enough that every matrix product keeps the
#: arithmetic of the whole-array product, small enough to stay in cache.
CHUNK_FRAMES = 32


class FrameCrop:
    """``frames[:, subset]`` as float64, produced :data:`CHUNK_FRAMES` frames at a time.

    Parameters
    ----------
    frames : (T, V, 3) ndarray
        Any float dtype (checked by the caller).
    subset : (S,) ndarray of int
        Vertex indices (checked by the caller).
    """

    def __init__(self, frames: np.ndarray, subset: np.ndarray):
        self.frames = frames
        self.subset = np.asarray(subset)
        self.shape = (frames.shape[0], self.subset.shape[0], frames.shape[2])

    def chunks(self, size: int = CHUNK_FRAMES):
        """Yield ``(start, (n, S, 3) float64 C-contiguous crop of frames start .. start + n - 1)``, each a new
        array the caller may overwrite."""
        for start in range(0, self.shape[0], size):
            crop = np.take(self.frames[start:start + size], self.subset, axis=1)
            yield start, crop.astype(np.float64, copy=False)  # float32 -> float64 is exact
