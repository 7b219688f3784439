"""A coefficient track as a grayscale image (one row per blendshape, one column per frame)."""

from __future__ import annotations

import numpy as np

from blendvoca.io.atomic import atomic_write


def coefficient_image(coeffs: np.ndarray) -> np.ndarray:
    """Return ``round(255 * coeffs.T)`` as uint8: row ``k`` is blendshape ``k``, column ``t`` frame ``t``.

    Parameters
    ----------
    coeffs : (T, K) ndarray in [0, 1]

    Returns
    -------
    image : (K, T) uint8 ndarray
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.ndim != 2:
        raise ValueError(f"coefficient_image: expected (T, K) coefficients, got shape {coeffs.shape}")
    return np.round(255.0 * np.clip(coeffs, 0.0, 1.0).T).astype(np.uint8)


def write_coefficient_image(path, coeffs: np.ndarray) -> None:
    """Write :func:`coefficient_image` of ``coeffs (T, K)`` as a PNG (atomically)."""
    from PIL import Image

    with atomic_write(path, "wb") as f:
        Image.fromarray(coefficient_image(coeffs)).save(f, format="PNG")
