"""The map between coefficients in [0, 1] and the diffusion's data space."""

from __future__ import annotations

import numpy as np
import torch

NORMALIZATIONS = ("unit-interval", "centered", "standardized")


def coefficient_normalization(tracks, kind: str = "centered") -> tuple[np.ndarray, np.ndarray]:
    """Return the per-column ``mean`` and ``scale`` with ``x = (u - mean) / scale``.

    Parameters
    ----------
    tracks : list of (T_i, K) ndarray
        Training coefficient tracks (only their number of columns is used for
        ``unit-interval``).
    kind : {"centered", "unit-interval", "standardized"}, default "centered"
        ``unit-interval``: ``x = 2 u - 1`` for every column.  ``centered``:
        ``x = 2 (u - mean)`` with each column's mean over all training frames, so a
        short CPU run need not learn the large constant offsets of rarely active
        blendshapes.  The scale stays 1/2 for every column, which keeps the data
        range within ``[-2, 2]``: the x0 predicted at nearly pure noise (where
        ``x0 = (x_t - sqrt(1 - a) eps) / sqrt(a)`` amplifies every error) is clipped
        to a range that the first sampling steps cannot blow up.  ``standardized``:
        ``x = (u - mean) / s`` with one scale ``s`` for all columns, the root mean
        square of the column standard deviations, so the data have unit variance
        overall, as the noise schedule assumes (BlendVOCA's coefficients vary by about
        0.04, so with scale 1/2 the data would be invisible under the noise of all but
        the last few percent of timesteps); the relative weights of the columns are
        kept.

    Returns
    -------
    mean, scale : (K,) float64 ndarray
    """
    if not tracks:
        raise ValueError("coefficient_normalization: expected at least one track, got none")
    k = np.asarray(tracks[0]).shape[-1]
    if kind == "unit-interval":
        return np.full(k, 0.5), np.full(k, 0.5)
    if kind not in NORMALIZATIONS:
        raise ValueError(f"coefficient_normalization: expected kind in {NORMALIZATIONS}, got {kind!r}")
    frames = np.concatenate([np.asarray(t, dtype=np.float64).reshape(-1, k) for t in tracks])
    mean = frames.mean(axis=0)
    if kind == "centered":
        return mean, np.full(k, 0.5)
    # one scale for all columns: the root mean square of the column standard deviations
    rms = float(np.sqrt(np.mean(frames.var(axis=0))))
    return mean, np.full(k, rms if rms > 1e-6 else 0.5)


def to_diffusion_space(coeffs: torch.Tensor, mean: torch.Tensor, scale: torch.Tensor) -> torch.Tensor:
    """Return ``(coeffs - mean) / scale``; coeffs ``(..., K)``, mean and scale ``(K,)``."""
    return (coeffs - mean.to(coeffs)) / scale.to(coeffs)


def from_diffusion_space(x: torch.Tensor, mean: torch.Tensor, scale: torch.Tensor) -> torch.Tensor:
    """Return ``x * scale + mean`` clipped to ``[0, 1]``; x ``(..., K)``."""
    return (x * scale.to(x) + mean.to(x)).clamp(0.0, 1.0)


def data_bounds(mean: torch.Tensor, scale: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Return the images ``(lo, hi)`` of coefficients 0 and 1 in diffusion space, each ``(K,)``."""
    return (0.0 - mean) / scale, (1.0 - mean) / scale
