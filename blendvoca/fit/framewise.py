"""Frame-by-frame (causal) fit: each frame's box QP given the previous frame's answer."""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError

from ._checks import check_rate_bound, check_system
from ._renamed import renamed_keywords
from .banded_qp import solve_banded_qp


@renamed_keywords(delta="rate_bound")
def framewise_coefficients(gram, rhs, *, lower=0.0, upper=1.0, rate_bound=0.1, warm_start=None) -> np.ndarray:
    """Fit frames one after the other, each constrained to the previous frame.

    Frame ``t`` solves ``min 1/2 u^T G u - c_t . u`` subject to
    ``max(lower, u_{t-1} - rate_bound) <= u <= min(upper, u_{t-1} + rate_bound)``: the
    streaming variant (no look-ahead) of the temporally constrained fit.  The
    first frame is bounded by ``lower``/``upper`` only (or by ``warm_start``'s
    first row +- rate_bound when given, e.g. the last frame of a previous chunk).

    ``gram``, ``rhs`` as in :func:`solve_banded_qp`; ``lower``, ``upper`` float box bounds;
    ``rate_bound`` None gives independent per-frame box QPs.

    Parameters
    ----------
    warm_start : (1, K) or (K,) array_like, optional
        The frame before the first one.

    Returns
    -------
    (T, K) ndarray
    """
    where = "framewise_coefficients"
    gram, rhs = check_system(gram, rhs, where)
    rate_bound = check_rate_bound(rate_bound, where)
    lower = float(lower)
    upper = float(upper)
    num_frames, k = rhs.shape
    out = np.empty((num_frames, k))
    previous = None
    if warm_start is not None:
        previous = np.asarray(warm_start, dtype=np.float64).reshape(-1)
        if previous.shape != (k,):
            raise UserError(f"{where}: warm_start must hold {k} coefficients, got {previous.shape}")
    for t in range(num_frames):
        lo = np.full((1, k), lower)
        hi = np.full((1, k), upper)
        if previous is not None and rate_bound is not None:
            lo = np.maximum(lo, previous - rate_bound)
            hi = np.minimum(hi, previous + rate_bound)
            # The previous frame may lie outside [lower, upper] when given by
            # the caller; keep the box non-empty.
            lo = np.minimum(lo, hi)
        solution = solve_banded_qp(gram, rhs[t : t + 1], lower=lo, upper=hi, rate_bound=None)
        out[t] = solution.coeffs[0]
        previous = out[t]
    return out
