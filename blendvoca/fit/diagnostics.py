"""Fit diagnostics: reconstruction errors and constraint activity."""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError

from ._renamed import renamed_keywords
from .frame_crop import FrameCrop
from .normal_equations import check_rig_and_frames


def vertex_errors(neutral, deltas, frames, coeffs, *, vertex_subset=None):
    """Return per-frame RMSE and maximum vertex error of a coefficient track.

    ``neutral``, ``deltas``, target ``frames`` and ``vertex_subset`` (measure on these vertices
    only) as in :func:`blendvoca.fit.normal_equations`; ``coeffs (T, K)`` the fitted track.

    Returns
    -------
    rmse : (T,) ndarray
        ``sqrt(mean_v ||x_v - p_v||^2)`` per frame, in mesh units.
    max_error : (T,) ndarray
        ``max_v ||x_v - p_v||`` per frame, in mesh units.
    """
    neutral, deltas, frames = check_rig_and_frames(
        neutral, deltas, frames, vertex_subset, "vertex_errors"
    )
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.shape != (frames.shape[0], deltas.shape[0]):
        raise UserError(
            f"vertex_errors: coeffs must be ({frames.shape[0]}, {deltas.shape[0]}), got {coeffs.shape}"
        )
    return vertex_errors_of_checked(neutral, deltas, frames, coeffs)


def vertex_errors_of_checked(neutral, deltas, frames, coeffs):
    """:func:`vertex_errors` of checked arrays (C-contiguous, float64, matching shapes).

    ``frames`` may be a :class:`FrameCrop`: the errors are then computed chunk by
    chunk of frames (the same values, bit for bit).
    """
    if isinstance(frames, FrameCrop):
        rmse, max_error = np.empty(frames.shape[0]), np.empty(frames.shape[0])
        for start, crop in frames.chunks():
            stop = start + crop.shape[0]
            rmse[start:stop], max_error[start:stop] = _frame_errors(neutral, deltas, crop, coeffs[start:stop])
        return rmse, max_error
    return _frame_errors(neutral, deltas, frames, coeffs)


def _frame_errors(neutral, deltas, frames, coeffs):
    num_shapes = deltas.shape[0]
    # In place: the reconstruction, its offset from the targets, the squares.
    diff = (coeffs @ deltas.reshape(num_shapes, -1)).reshape(frames.shape)
    diff += neutral
    diff -= frames
    np.square(diff, out=diff)
    # ||d||^2 per vertex as (x^2 + y^2) + z^2: the order np.sum(axis=2) adds in
    # (bit for bit), without its slow length-3 inner loop.
    dist_sq = diff[..., 0] + diff[..., 1]  # (T, V)
    dist_sq += diff[..., 2]
    return np.sqrt(dist_sq.mean(axis=1)), np.sqrt(dist_sq.max(axis=1))


@renamed_keywords(delta="rate_bound")
def constraint_activity(coeffs, *, lower=0.0, upper=1.0, rate_bound=0.1, tol=1e-6):
    """Return, per blendshape, how often each constraint is active.

    Parameters
    ----------
    coeffs : (T, K) array_like
    lower, upper : float
    rate_bound : float or None
    tol : float
        A constraint counts as active within ``tol`` of its bound.

    Returns
    -------
    dict
        ``"lower"``, ``"upper"`` : (K,) fraction of frames at the bound;
        ``"rate"`` : (K,) fraction of frame transitions with
        ``|u_{t+1} - u_t| >= rate_bound - tol`` (zeros when rate_bound is None or T == 1).
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.ndim != 2 or coeffs.shape[0] == 0:
        raise UserError(f"constraint_activity: coeffs must be (T, K) with T >= 1, got {coeffs.shape}")
    out = {
        "lower": np.mean(coeffs <= lower + tol, axis=0),
        "upper": np.mean(coeffs >= upper - tol, axis=0),
    }
    if rate_bound is None or coeffs.shape[0] < 2:
        out["rate"] = np.zeros(coeffs.shape[1])
    else:
        out["rate"] = np.mean(np.abs(np.diff(coeffs, axis=0)) >= rate_bound - tol, axis=0)
    return out
