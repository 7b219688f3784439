"""Unconstrained fit: the per-frame least-squares coefficients (the floor under the QP)."""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve, lstsq

from blendvoca.errors import UserError

from ._checks import as_float_array


def least_squares_coefficients(gram, rhs) -> np.ndarray:
    """Return the unconstrained minimiser ``u_t = G^{-1} c_t`` of every frame.

    ``gram (K, K)`` and ``rhs (T, K)`` as in :func:`blendvoca.fit.solve_banded_qp`.

    Returns
    -------
    (T, K) ndarray
        Coefficients (unbounded; the minimum-norm solution if G is singular).
    """
    gram = as_float_array(gram, "gram", 2, "least_squares_coefficients")
    rhs = as_float_array(rhs, "rhs", 2, "least_squares_coefficients")
    if gram.shape != (rhs.shape[1], rhs.shape[1]):
        raise UserError(
            f"least_squares_coefficients: gram must be ({rhs.shape[1]}, {rhs.shape[1]}) to "
            f"match rhs {rhs.shape}, got {gram.shape}"
        )
    try:
        return cho_solve(cho_factor(gram, check_finite=False), rhs.T, check_finite=False).T
    except np.linalg.LinAlgError:
        return lstsq(gram, rhs.T, check_finite=False)[0].T
