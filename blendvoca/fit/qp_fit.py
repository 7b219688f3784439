"""The coefficient fit of frames that carry no head pose: the QP, its solver and diagnostics.

The public entry points (:mod:`blendvoca.fit.coefficients`) unpose posed frames
first and call :func:`fit_unposed`; so does the joint pose fit at each alternation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from blendvoca.errors import UserError
from blendvoca.runtime.threads import one_blas_thread

from ._checks import check_rate_bound
from .banded_qp import solve_banded_qp
from .diagnostics import constraint_activity, vertex_errors_of_checked
from .framewise import framewise_coefficients
from .least_squares import least_squares_coefficients
from .normal_equations import check_rig_and_frames, normal_equations_of_checked
from .pose import HeadPose
from .resample import resample_sequence
from .sparse_qp import SOLVER_OPTIONS, solve_sparse_qp

#: Accepted values of ``solver``.
SOLVERS = ("banded",) + tuple(SOLVER_OPTIONS)


@dataclass(frozen=True)
class FitResult:
    """A fitted coefficient track with its diagnostics.

    Attributes
    ----------
    coeffs : (T, K) ndarray
        The coefficients.
    objective : float
        ``sum_t ||B u_t - (p_t - n)||^2`` on the fitted vertices (mesh units squared).
    rmse : (T,) ndarray
        Per-frame root mean square vertex error (mesh units).
    max_error : (T,) ndarray
        Per-frame largest vertex error (mesh units).
    activity : dict
        Per-blendshape fraction of frames with the lower / upper / rate
        constraint active (:func:`constraint_activity`).
    solver : str
        What produced the coefficients.
    iterations : int
        Solver iterations (0 for closed forms).
    converged : bool
        False when the solver stopped without its optimality certificate.
    pose : HeadPose or None
        The head pose removed before fitting (``pose.summary()``: degrees, mm);
        None when the frames were declared unposed.
    """

    coeffs: np.ndarray
    objective: float
    rmse: np.ndarray
    max_error: np.ndarray
    activity: dict = field(repr=False)
    solver: str
    iterations: int
    converged: bool
    pose: HeadPose | None = field(default=None, repr=False)


def fit_unposed(neutral, deltas, frames, *, rate_bound, vertex_subset, bounds, rate, solver, warm_start, framewise,
                fps, where, diagnostics=True, pose=None):
    """The fit of unposed ``frames`` (parameters as :func:`blendvoca.fit.fit_sequence`).

    Returns
    -------
    FitResult (its ``pose`` set to ``pose``), or with ``diagnostics=False`` only the
    ``(T, K)`` coefficients (no objective, so no ``||p_t - n||^2`` pass).
    """
    if solver not in SOLVERS:
        raise UserError(f"{where}: solver must be one of {SOLVERS}, got {solver!r}")
    rate_bound = check_rate_bound(rate_bound, where) if rate else None
    if rate and rate_bound is None:
        raise UserError(f"{where}: rate=True needs a rate_bound, got None")
    if framewise and not bounds:
        raise UserError(f"{where}: framewise mode needs bounds=True")
    # Frames as stored are cropped chunk by chunk (60 fps, no pose removed before).
    neutral, deltas, frames = check_rig_and_frames(neutral, deltas, frames, vertex_subset, where,
                                                   lazy=fps == 60.0 and pose is None)
    if fps != 60.0:
        frames = resample_sequence(frames, fps, 60.0)
    lower, upper = (0.0, 1.0) if bounds else (None, None)
    # BLAS on one thread: the small banded factorizations run several times slower with two (DESIGN.md).
    with one_blas_thread():
        system = normal_equations_of_checked(neutral, deltas, frames, offset_sq=diagnostics)
        iterations, converged = 0, True
        if framewise:
            coeffs = framewise_coefficients(system.gram, system.rhs, rate_bound=rate_bound, warm_start=warm_start)
            used = "framewise"
        elif not bounds and rate_bound is None:
            coeffs = least_squares_coefficients(system.gram, system.rhs)
            used = "least-squares"
        elif solver == "banded":
            solution = solve_banded_qp(system.gram, system.rhs, lower=lower, upper=upper, rate_bound=rate_bound,
                                       warm_start=warm_start)
            coeffs, used = solution.coeffs, solution.solver
            iterations, converged = solution.iterations, solution.converged
        else:
            coeffs = solve_sparse_qp(system.gram, system.rhs, lower=lower, upper=upper, rate_bound=rate_bound,
                                     solver=solver, warm_start=warm_start)
            coeffs, used = (np.clip(coeffs, 0.0, 1.0) if bounds else coeffs), solver
        if not diagnostics:
            return coeffs
        rmse, max_error = vertex_errors_of_checked(neutral, deltas, frames, coeffs)
    return FitResult(coeffs=coeffs, objective=system.objective(coeffs), rmse=rmse, max_error=max_error,
                     activity=constraint_activity(coeffs, rate_bound=rate_bound), solver=used,
                     iterations=iterations, converged=converged, pose=pose)
