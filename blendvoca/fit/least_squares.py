"""Unconstrained fit: the per-frame least-squares coefficients (the floor under the QP)."""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve, lstsq

from ._checks import check_system


def least_squares_coefficients(gram, rhs) -> np.ndarray:
    """Return the unconstrained minimiser ``u_t = G^{-1} c_t`` of every frame.

    ``gram (K, K)`` and ``rhs (T, K)`` as in :func:`blendvoca.fit.solve_banded_qp`.

    Returns
    -------
    (T, K) ndarray
        Coefficients (unbounded; the minimum-norm solution if G is singular).
    """
    gram, rhs = check_system(gram, rhs, "least_squares_coefficients")
    try:
        return cho_solve(cho_factor(gram, check_finite=False), rhs.T, check_finite=False).T
    except np.linalg.LinAlgError:
        return lstsq(gram, rhs.T, check_finite=False)[0].T
