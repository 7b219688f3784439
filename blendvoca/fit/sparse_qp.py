"""The same QP handed to general-purpose solvers (through qpsolvers).

Used as selectable alternatives to the banded interior point method and as
references in tests and the perf/ scripts: sparse formulations (``kron(I_T, G)``
Hessian, banded difference constraints) for OSQP / Clarabel / PIQP / cvxopt,
and the published dense formulation (one dense block-diagonal P over all
frames, cvxopt).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from blendvoca.errors import UserError

from ._checks import check_rate_bound, check_system
from ._renamed import renamed_keywords

#: Solver options that make each general solver's answer match an exact solver.
SOLVER_OPTIONS = {
    "piqp": {"eps_abs": 1e-10, "eps_rel": 1e-10},
    "clarabel": {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12, "tol_feas": 1e-12},
    "osqp": {"eps_abs": 1e-9, "eps_rel": 1e-9, "polishing": True, "max_iter": 200000},
    "cvxopt": {"abstol": 1e-9, "reltol": 1e-9, "feastol": 1e-9, "maxiters": 200},
}


def difference_operator(num_frames: int, num_shapes: int) -> sp.csc_matrix:
    """Return the sparse forward difference ``(T-1) K x T K`` on row-major ``(T, K)``."""
    diff = sp.eye(num_frames - 1, num_frames, 1) - sp.eye(num_frames - 1, num_frames)
    return sp.kron(diff, sp.identity(num_shapes), format="csc")


def _qp_matrices(gram, rhs, lower, upper, rate_bound, dense):
    num_frames, k = rhs.shape
    n = num_frames * k
    if dense:
        hessian = np.kron(np.eye(num_frames), gram)
    else:
        hessian = sp.kron(sp.identity(num_frames), sp.csc_matrix(gram), format="csc")
    g_ineq = h_ineq = None
    if rate_bound is not None and num_frames > 1:
        diff = difference_operator(num_frames, k)
        g_ineq = sp.vstack([diff, -diff], format="csc")
        h_ineq = np.full(g_ineq.shape[0], rate_bound)
        if dense:
            g_ineq = g_ineq.toarray()
    lb = None if lower is None else np.broadcast_to(np.asarray(lower, float), rhs.shape).ravel().copy()
    ub = None if upper is None else np.broadcast_to(np.asarray(upper, float), rhs.shape).ravel().copy()
    if lb is not None and lb.size != n or ub is not None and ub.size != n:  # pragma: no cover
        raise ValueError("bounds do not match the problem size")
    return hessian, -rhs.ravel(), g_ineq, h_ineq, lb, ub


@renamed_keywords(delta="rate_bound")
def solve_sparse_qp(
    gram, rhs, *, lower=0.0, upper=1.0, rate_bound=0.1, solver="piqp", warm_start=None, **options
) -> np.ndarray:
    """Solve the temporally constrained QP with a general solver from qpsolvers.

    ``gram``, ``rhs``, ``lower``, ``upper`` and ``rate_bound`` as in :func:`blendvoca.fit.solve_banded_qp`.

    Parameters
    ----------
    solver : {"piqp", "clarabel", "osqp", "cvxopt"}
        qpsolvers backend; "cvxopt" gets dense matrices.
    warm_start : (T, K) array_like, optional
        Passed as ``initvals``.
    **options
        Override :data:`SOLVER_OPTIONS`.

    Returns
    -------
    (T, K) ndarray
    """
    import qpsolvers

    where = "solve_sparse_qp"
    gram, rhs = check_system(gram, rhs, where)
    rate_bound = check_rate_bound(rate_bound, where)
    if solver not in SOLVER_OPTIONS:
        raise UserError(f"{where}: solver must be one of {sorted(SOLVER_OPTIONS)}, got {solver!r}")
    if solver not in qpsolvers.available_solvers:
        raise UserError(f"{where}: solver {solver!r} is not installed (pip install {solver})")
    opts = {**SOLVER_OPTIONS[solver], **options}
    # Unit Hessian diagonal: the solvers' absolute tolerances then mean the
    # same thing whatever the mesh units.
    scale = float(np.max(np.abs(np.diag(gram)))) or 1.0
    gram, rhs = gram / scale, rhs / scale
    P, q, G, h, lb, ub = _qp_matrices(gram, rhs, lower, upper, rate_bound, dense=solver == "cvxopt")
    init = None if warm_start is None else np.asarray(warm_start, float).ravel()
    x = qpsolvers.solve_qp(P, q, G, h, lb=lb, ub=ub, solver=solver, initvals=init, **opts)
    if x is None:
        raise RuntimeError(f"{where}: {solver} found no solution ({rhs.shape[0]} frames)")
    return x.reshape(rhs.shape)


@renamed_keywords(delta="rate_bound")
def solve_published_qp(neutral, deltas, frames, *, rate_bound=0.1) -> np.ndarray:
    """The published BlendVOCA formulation, as a reference for the perf/ scripts.

    One dense block-diagonal P over all frames (``T K x T K``), q from every
    frame's 3V-long offset, sparse difference constraints, bounds, solved by
    cvxopt through qpsolvers at its default tolerances and clipped to [0, 1].

    Parameters as :func:`blendvoca.fit.fit_coefficients` (arrays, float ``rate_bound``).

    Returns
    -------
    (T, K) ndarray
    """
    import qpsolvers
    from scipy.linalg import block_diag

    num_shapes = deltas.shape[0]
    basis = deltas.reshape(num_shapes, -1).T  # (3V, K)
    neutral_vec = neutral.reshape(-1, 1)
    btb = basis.T @ basis
    num_frames = frames.shape[0]
    p = block_diag(*[btb for _ in range(num_frames)])
    q = np.vstack([basis.T @ (neutral_vec - f.reshape(-1, 1)) for f in frames]).reshape(-1)
    diff = difference_operator(num_frames, num_shapes)
    g = sp.vstack([diff, -diff], format="csc")
    h = np.full(g.shape[0], rate_bound)
    lb = np.zeros(num_shapes * num_frames)
    ub = np.ones(num_shapes * num_frames)
    x = qpsolvers.solve_qp(P=p, q=q, G=g, h=h, lb=lb, ub=ub, solver="cvxopt")
    return np.clip(x, lb, ub).reshape(num_frames, num_shapes)
