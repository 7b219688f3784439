"""A small box-constrained QP, solved exactly by a warm-started active-set method.

The streaming solver (:mod:`blendvoca.fit.streaming`) solves, every frame, ::

    minimise   1/2 x^T H x - q . x     subject to   lower <= x <= upper

with H positive definite and K <= a few dozen unknowns.  From one frame to the next
the set of coefficients held at a bound rarely changes, so the set of the previous
frame is nearly always the answer or close to it: one K x K (or smaller) Cholesky
solve and a sign check of the gradient certify it.  An interior-point solver (PIQP)
is as fast per frame at K = 32 but stops inside the box, short of the exact optimum
(``perf/bench_stream.py --solvers`` and ``docs/streaming.md``); this gives the
optimum itself, with its zeros exactly 0.

Two phases, both ending with the KKT conditions checked:

1. primal-dual active-set steps (Hintermueller, Ito and Kunisch, SIAM J. Optim. 13(3),
   2002): solve on the face of the current set, then hold every free unknown that left
   its box and release every held bound whose gradient pushes the wrong way, all at
   once.  From a warm start this certifies in one or two solves; it is not guaranteed
   to end, so after a few steps, or when a set repeats,
2. the primal active-set method for bounds (Nocedal and Wright, *Numerical
   Optimization*, 2nd ed., Section 16.5) takes over: the iterate stays feasible, each
   step either stops at the first bound it meets and holds it or, at the minimiser of
   the current face, releases the held bounds with a wrongly signed gradient; the
   objective decreases from one face minimiser to the next, so it ends.

It is checked against ``scipy.optimize.lsq_linear`` in ``tests/fit/test_stream_box_qp.py``.
A warm start is a status per unknown (-1 at its lower bound, +1 at its upper bound,
0 free); without one the start is the clipped unconstrained minimiser.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dposv

from blendvoca.errors import UserError

#: Relative tolerance on bound feasibility of a face minimiser (coefficients are O(1)).
FEASIBILITY_TOL = 1e-12
#: Relative tolerance on the gradient sign of the bounds held (scaled by |H| and |q|).
GRADIENT_TOL = 1e-11
#: Primal-dual steps tried before the primal method (which always ends) takes over.
PRIMAL_DUAL_STEPS = 6


@dataclass(frozen=True)
class BoxQPSolution:
    """Result of :func:`solve_box_qp`.

    Attributes
    ----------
    x : (K,) ndarray
        The minimiser (exactly on its bounds where ``status`` is not 0).
    status : (K,) int8 ndarray
        -1 held at the lower bound, +1 at the upper bound, 0 free: the warm start of
        the next, similar problem.
    iterations : int
        Linear solves made.
    certified : bool
        False when the iteration limit was reached before the KKT conditions held.
    """

    x: np.ndarray
    status: np.ndarray
    iterations: int
    certified: bool


def _spd_solve(matrix, rhs):
    """``matrix^-1 rhs`` by LAPACK's Cholesky solve (a few microseconds at K = 32, where
    ``numpy.linalg.solve``'s wrapper costs more than the arithmetic); least squares if
    the matrix is not numerically positive definite."""
    _, x, info = dposv(matrix, rhs)
    if info != 0:
        return np.linalg.lstsq(matrix, rhs, rcond=None)[0]
    return x


def _face_minimiser(hessian, linear, x, free):
    """Minimiser over the free unknowns with the others held at their value in ``x``."""
    out = x.copy()
    if not free.any():
        return out
    if free.all():
        out[:] = _spd_solve(hessian, linear)
        return out
    rows = np.flatnonzero(free)
    held = np.flatnonzero(~free)
    block = hessian.take(rows, axis=0)
    rhs = linear[rows] - block.take(held, axis=1) @ x[held]
    out[rows] = _spd_solve(block.take(rows, axis=1), rhs)
    return out


def solve_box_qp(hessian, linear, lower, upper, *, status=None, max_iter=None) -> BoxQPSolution:
    """Minimise ``1/2 x^T H x - q . x`` subject to ``lower <= x <= upper``.

    Parameters
    ----------
    hessian : (K, K) ndarray
        Symmetric positive definite.
    linear : (K,) ndarray
        ``q``.
    lower, upper : (K,) ndarray
        Finite bounds with ``lower <= upper`` (equal bounds fix that unknown).
    status : (K,) array_like of {-1, 0, 1}, optional
        Warm start: which bounds to hold first (e.g. the previous frame's status).
    max_iter : int, optional
        Linear solves allowed (default ``4 K + 10``).

    Returns
    -------
    BoxQPSolution
    """
    hessian = np.asarray(hessian, dtype=np.float64)
    linear = np.asarray(linear, dtype=np.float64)
    lower = np.asarray(lower, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.float64)
    k = linear.shape[0]
    if hessian.shape != (k, k) or lower.shape != (k,) or upper.shape != (k,):
        raise UserError(f"solve_box_qp: expected hessian ({k}, {k}) and bounds ({k},) for linear ({k},), got "
                        f"{hessian.shape}, {lower.shape}, {upper.shape}")
    if np.any(lower > upper):
        raise UserError("solve_box_qp: every lower bound must not exceed its upper bound")
    if max_iter is None:
        max_iter = 4 * k + 10
    span = 1.0 + float(np.max(np.abs(np.concatenate([lower, upper]))))
    feas_tol = FEASIBILITY_TOL * span
    grad_tol = GRADIENT_TOL * (float(np.max(np.abs(hessian))) * span + float(np.max(np.abs(linear), initial=0.0)))
    fixed = lower == upper
    iterations = 0

    if status is None:
        start = _spd_solve(hessian, linear)
        iterations += 1
        state = np.where(start < lower, -1, np.where(start > upper, 1, 0)).astype(np.int8)
    else:
        state = np.asarray(status, dtype=np.int8).copy()
        if state.shape != (k,) or np.any(np.abs(state) > 1):
            raise UserError(f"solve_box_qp: status must be ({k},) values in -1, 0, 1, got shape {state.shape}")
    state[fixed & (state == 0)] = -1

    # Primal-dual active-set steps: from the face of ``state``, hold every free unknown
    # that left its box and release every bound pushing the wrong way, all at once.
    # Mostly certified in one or two solves; not guaranteed to end (it may cycle), so
    # after PRIMAL_DUAL_STEPS the primal method below takes over from the last face.
    seen = set()
    while True:
        x = np.where(state < 0, lower, np.where(state > 0, upper, 0.0))
        x = _face_minimiser(hessian, linear, x, state == 0)
        iterations += 1
        free = state == 0
        below = free & (x < lower - feas_tol)
        above = free & (x > upper + feas_tol)
        gradient = hessian @ x - linear
        wrong = ((state < 0) & ~fixed & (gradient < -grad_tol)) | ((state > 0) & ~fixed & (gradient > grad_tol))
        if not (below.any() or above.any() or wrong.any()):
            return BoxQPSolution(np.clip(x, lower, upper), state, iterations, True)
        seen.add(state.tobytes())
        following = state.copy()
        following[below], following[above], following[wrong] = -1, 1, 0
        if len(seen) >= PRIMAL_DUAL_STEPS or following.tobytes() in seen or iterations >= max_iter:
            break
        state = following

    # The primal method from a feasible first iterate: the last face minimiser, clipped,
    # with every clipped unknown held at the bound it was clipped to.
    below = (state == 0) & (x < lower)
    above = (state == 0) & (x > upper)
    state[below] = -1
    state[above] = 1
    x = np.clip(x, lower, upper)
    at_minimiser = not (below.any() or above.any())

    while iterations <= max_iter:
        free = state == 0
        if not at_minimiser:
            target = _face_minimiser(hessian, linear, x, free)
            iterations += 1
            step = target - x
            # Largest step in [0, 1] along which the free unknowns stay within bounds.
            with np.errstate(divide="ignore", invalid="ignore"):
                to_lower = np.where(free & (target < lower - feas_tol), (lower - x) / step, np.inf)
                to_upper = np.where(free & (target > upper + feas_tol), (upper - x) / step, np.inf)
            first_lower = int(np.argmin(to_lower))
            first_upper = int(np.argmin(to_upper))
            alpha = min(to_lower[first_lower], to_upper[first_upper], 1.0)
            if alpha >= 1.0:
                x = np.clip(target, lower, upper)
                at_minimiser = True
            else:
                alpha = max(alpha, 0.0)
                x = np.clip(x + alpha * step, lower, upper)
                if to_lower[first_lower] <= to_upper[first_upper]:
                    state[first_lower], x[first_lower] = -1, lower[first_lower]
                else:
                    state[first_upper], x[first_upper] = 1, upper[first_upper]
                continue
        # At the minimiser of the current face: the bounds held must push the right way.
        gradient = hessian @ x - linear
        wrong = np.where((state < 0) & ~fixed, -gradient, 0.0) + np.where((state > 0) & ~fixed, gradient, 0.0)
        release = wrong > grad_tol
        if not release.any():
            return BoxQPSolution(x, state, iterations, True)
        state[release] = 0
        at_minimiser = False
    return BoxQPSolution(x, state, iterations, False)
