"""Input validation shared by the retargeting steps (private)."""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError
from blendvoca.io.arrays import float_array


def as_vertices(array, where: str, *, name: str = "vertices") -> np.ndarray:
    """Return ``array`` as a C-contiguous ``(V, 3)`` float64 array or raise.

    Parameters
    ----------
    array : array_like, (V, 3)
        Any real dtype (float32 is converted).
    where : str
        Name of the calling function, used in the error message.
    name : str
        Name of the argument, used in the error message.
    """
    out = float_array(array, where=where, name=name, shape="(V, 3)")
    if out.ndim != 2 or out.shape[1] != 3:
        raise UserError(f"{where}: expected {name} of shape (V, 3), got {out.shape}")
    if not np.all(np.isfinite(out)):
        raise UserError(f"{where}: {name} contains NaN or infinite values")
    return out


def as_faces(array, n_vertices: int, where: str, *, name: str = "faces") -> np.ndarray:
    """Return ``array`` as a C-contiguous ``(F, 3)`` int64 array indexing ``n_vertices``."""
    arr = np.asarray(array)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise UserError(f"{where}: expected {name} of shape (F, 3), got {arr.shape}")
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"{where}: expected integer {name}, got dtype {arr.dtype}")
    out = np.ascontiguousarray(arr, dtype=np.int64)
    if out.size and (out.min() < 0 or out.max() >= n_vertices):
        raise UserError(
            f"{where}: {name} index vertices in [{out.min()}, {out.max()}], "
            f"expected indices in [0, {n_vertices - 1}]"
        )
    return out


def as_indices(array, n: int, where: str, *, name: str = "indices") -> np.ndarray:
    """Return ``array`` as a 1-D int64 array of indices into ``range(n)``."""
    arr = np.asarray(array)
    if arr.ndim != 1:
        raise UserError(f"{where}: expected 1-D {name}, got shape {arr.shape}")
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"{where}: expected integer {name}, got dtype {arr.dtype}")
    out = arr.astype(np.int64)
    if out.size and (out.min() < 0 or out.max() >= n):
        raise UserError(
            f"{where}: {name} range over [{out.min()}, {out.max()}], expected indices in [0, {n - 1}]"
        )
    return out
