"""Input validation shared by the fitting functions (private)."""

from __future__ import annotations

import numbers

import numpy as np

from blendvoca.errors import UserError


def as_float_array(value, name: str, ndim: int, where: str, *, keep_float: bool = False) -> np.ndarray:
    """Return ``value`` as a finite float64 array with ``ndim`` dimensions.

    ``keep_float``: a floating array keeps its dtype (float32 stays float32).

    Raises
    ------
    TypeError
        If ``value`` is not numeric (any float or integer dtype converts).
    UserError
        If the number of dimensions is wrong or it holds NaN / inf (a ``ValueError``).
    """
    try:
        array = np.asarray(value)
    except Exception as exc:  # pragma: no cover - numpy accepts nearly anything
        raise TypeError(f"{where}: {name} must be array-like, got {type(value).__name__}") from exc
    if array.dtype == object or not (
        np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)
    ):
        raise TypeError(f"{where}: {name} must be a numeric array, got dtype {array.dtype}")
    if not (keep_float and np.issubdtype(array.dtype, np.floating)):
        array = np.asarray(array, dtype=np.float64)
    if array.ndim != ndim:
        raise UserError(
            f"{where}: {name} must have {ndim} dimensions, got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise UserError(f"{where}: {name} holds a non-finite value at index {tuple(bad)}")
    return array


def check_system(gram, rhs, where: str) -> tuple[np.ndarray, np.ndarray]:
    """Return the normal equations' ``gram (K, K)`` and ``rhs (T, K)`` as finite float64 arrays
    (:func:`as_float_array`), or a :class:`UserError` when their shapes disagree."""
    gram = as_float_array(gram, "gram", 2, where)
    rhs = as_float_array(rhs, "rhs", 2, where)
    k = rhs.shape[1]
    if gram.shape != (k, k):
        raise UserError(f"{where}: gram must be ({k}, {k}) to match rhs {rhs.shape}, got {gram.shape}")
    return gram, rhs


def check_rate_bound(rate_bound, where: str) -> float | None:
    """Return the rate bound as a positive float, or None for no rate constraint."""
    if rate_bound is None:
        return None
    if isinstance(rate_bound, (bool, np.bool_)) or not isinstance(rate_bound, numbers.Real):
        raise TypeError(f"{where}: rate_bound must be a positive number or None, got {rate_bound!r}")
    rate_bound = float(rate_bound)
    if not np.isfinite(rate_bound) or rate_bound <= 0.0:
        raise UserError(f"{where}: rate_bound must be a positive finite number, got {rate_bound}")
    return rate_bound


def region_indices(indices, num_vertices: int, name: str, where: str) -> np.ndarray:
    """Return ``indices`` (integers of any shape, or a boolean mask) as ``(N,) int64`` vertex indices:
    at least 3 in ``[0, num_vertices)``, as a rigid alignment needs, else a :class:`UserError`."""
    indices = np.asarray(indices)
    if indices.dtype == bool:
        indices = np.flatnonzero(indices)
    indices = indices.astype(np.int64).reshape(-1)
    if len(indices) < 3 or indices.min() < 0 or indices.max() >= num_vertices:
        raise UserError(f"{where}: {name} must hold at least 3 vertex indices in [0, {num_vertices}), "
                        f"got {len(indices)} indices")
    return indices


def vertex_indices(indices, num_vertices: int, where: str, name: str = "vertex_subset") -> np.ndarray:
    """Return ``indices`` as a non-empty 1-D integer array of vertex indices in ``0 .. num_vertices - 1``.

    Raises
    ------
    TypeError
        Not a 1-D integer array.
    UserError
        Empty, or an index out of range (naming the range found).
    """
    subset = np.asarray(indices)
    if subset.ndim != 1 or not np.issubdtype(subset.dtype, np.integer):
        raise TypeError(f"{where}: {name} must be a 1-D integer array, got dtype {subset.dtype} and shape "
                        f"{subset.shape}")
    if subset.size == 0 or subset.min() < 0 or subset.max() >= num_vertices:
        found = f"[{subset.min()}, {subset.max()}]" if subset.size else "no index"
        raise UserError(f"{where}: {name} must index 0..{num_vertices - 1}, got {found}")
    return subset
