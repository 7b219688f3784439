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


def check_delta(delta, where: str) -> float | None:
    """Return the rate bound as a positive float, or None for no rate constraint."""
    if delta is None:
        return None
    if isinstance(delta, (bool, np.bool_)) or not isinstance(delta, numbers.Real):
        raise TypeError(f"{where}: delta must be a positive number or None, got {delta!r}")
    delta = float(delta)
    if not np.isfinite(delta) or delta <= 0.0:
        raise UserError(f"{where}: delta must be a positive finite number, got {delta}")
    return delta
