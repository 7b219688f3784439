"""Public entry points: fit a coefficient track to a mesh sequence with a rig."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from blendvoca.errors import UserError

from ._checks import check_delta
from .banded_qp import solve_banded_qp
from .diagnostics import constraint_activity, vertex_errors_of_checked
from .framewise import framewise_coefficients
from .least_squares import least_squares_coefficients
from .normal_equations import check_rig_and_frames, normal_equations_of_checked
from .pose import FLAME_NUM_VERTICES, HeadPose, remove_head_pose
from .resample import resample_sequence
from .sparse_qp import SOLVER_OPTIONS, solve_sparse_qp

#: Accepted values of ``method``.
METHODS = ("banded",) + tuple(SOLVER_OPTIONS)

_CONTROLLER = None


def _one_blas_thread():
    """Context limiting BLAS to one thread: the small banded factorizations run
    several times slower with two threads on these machines (DESIGN.md)."""
    global _CONTROLLER
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - threadpoolctl comes with scikit-learn
        import contextlib

        return contextlib.nullcontext()
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")


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


def _checked_frames(neutral, deltas, frames, vertex_subset, unposed, stable, where, fps=60.0):
    """Validated rig and frames (subset applied), with the head pose removed unless ``unposed``.

    Unposed 60 fps frames with a subset come as a :class:`FrameCrop`, so that the
    crop is made chunk by chunk from the frames as stored.
    """
    if unposed is None:
        # Auto: FLAME meshes (captures, method outputs) have a known stable
        # region; other topologies are treated as rig-space data.
        unposed = np.shape(neutral)[0] != FLAME_NUM_VERTICES
    if unposed:
        return check_rig_and_frames(neutral, deltas, frames, vertex_subset, where, lazy=fps == 60.0), None
    check_rig_and_frames(neutral, deltas, frames, vertex_subset, where)
    pose = remove_head_pose(frames, neutral, stable=stable)
    return check_rig_and_frames(neutral, deltas, pose.frames, vertex_subset, where), pose


def fit_sequence(
    neutral,
    deltas,
    frames,
    *,
    delta=0.1,
    vertex_subset=None,
    bounds=True,
    rate=True,
    method="banded",
    warm_start=None,
    framewise=False,
    fps=60.0,
    unposed=None,
    stable=None,
) -> FitResult:
    """Fit a coefficient track and return it with its diagnostics.

    Solves ``min_u sum_t ||B u_t - (p_t - n)||^2`` subject to ``0 <= u <= 1``
    (``bounds``) and ``|u_{t+1} - u_t| <= delta`` (``rate``): the temporally
    constrained QP of SAiD (Eq. 2).  ``B^T B`` is positive definite for a rig
    with independent blendshapes, so the optimum is unique; the default solver
    returns it certified by the KKT conditions.

    Parameters
    ----------
    neutral : (V, 3) array_like
        Rig neutral.
    deltas : (K, V, 3) array_like
        Blendshape offsets from the neutral.
    frames : (T, V, 3) array_like
        Mesh sequence (same topology as the rig) at ``fps``.
    delta : float, optional
        Rate bound per 60 fps frame.
    vertex_subset : (S,) array_like of int, optional
        Fit (and measure) on these vertices only, e.g. the 4580-vertex head.
    bounds : bool, optional
        Impose ``0 <= u <= 1``.
    rate : bool, optional
        Impose ``|u_{t+1} - u_t| <= delta``.
    method : {"banded", "piqp", "clarabel", "osqp", "cvxopt"}, optional
        "banded": the structure-exploiting interior-point method with active-set
        polishing (default, fastest); the others hand the sparse QP to that
        general solver (cvxopt gets dense matrices).
    warm_start : (T, K) array_like, optional
        Initial coefficients (for "framewise", the frame before the first).
    framewise : bool, optional
        Fit frame after frame, each frame's box QP constrained by the previous
        frame's answer (causal, no look-ahead) instead of the whole sentence.
    fps : float, optional
        Frame rate of ``frames``; other rates are resampled to 60 fps first,
        and the result is at 60 fps.
    unposed : bool or None, optional
        True: the frames are known to carry no head pose (VOCASET's
        ``unposedcleaneddata``, rig outputs). False: each frame is first rigidly
        aligned to ``neutral`` by :func:`remove_head_pose` on stable vertices and
        the removed pose is returned in ``pose``. None (default): False for
        FLAME-topology meshes (5023 vertices, whose stable region is known),
        True for other topologies (rig-space data: with a rig whose shapes move
        every vertex a rigid alignment would absorb part of the expression).
    stable : (S,) array_like of int, optional
        Stable vertices for the pose removal (full topology indices); default
        as :func:`remove_head_pose`.

    Returns
    -------
    FitResult
    """
    where = "fit_coefficients"
    if method not in METHODS:
        raise UserError(f"{where}: method must be one of {METHODS}, got {method!r}")
    delta = check_delta(delta, where) if rate else None
    if rate and delta is None:
        raise UserError(f"{where}: rate=True needs a delta, got None")
    (neutral, deltas, frames), pose = _checked_frames(neutral, deltas, frames, vertex_subset, unposed, stable, where, fps)
    if fps != 60.0:
        frames = resample_sequence(frames, fps, 60.0)
    lower, upper = (0.0, 1.0) if bounds else (None, None)
    with _one_blas_thread():
        system = normal_equations_of_checked(neutral, deltas, frames)
        iterations, converged = 0, True
        if framewise:
            if not bounds:
                raise UserError(f"{where}: framewise mode needs bounds=True")
            coeffs = framewise_coefficients(
                system.gram, system.rhs, delta=delta, warm_start=warm_start
            )
            solver = "framewise"
        elif not bounds and delta is None:
            coeffs = least_squares_coefficients(system.gram, system.rhs)
            solver = "least-squares"
        elif method == "banded":
            solution = solve_banded_qp(
                system.gram, system.rhs, lower=lower, upper=upper, delta=delta,
                warm_start=warm_start,
            )
            coeffs, solver = solution.coeffs, solution.solver
            iterations, converged = solution.iterations, solution.converged
        else:
            coeffs = solve_sparse_qp(
                system.gram, system.rhs, lower=lower, upper=upper, delta=delta,
                solver=method, warm_start=warm_start,
            )
            if bounds:
                coeffs = np.clip(coeffs, 0.0, 1.0)
            solver = method
        rmse, max_error = vertex_errors_of_checked(neutral, deltas, frames, coeffs)
    activity = constraint_activity(coeffs, delta=delta if delta is not None else None)
    return FitResult(
        coeffs=coeffs,
        objective=system.objective(coeffs),
        rmse=rmse,
        max_error=max_error,
        activity=activity,
        solver=solver,
        iterations=iterations,
        converged=converged,
        pose=pose,
    )


def fit_coefficients(
    neutral,
    deltas,
    frames,
    *,
    delta=0.1,
    vertex_subset=None,
    bounds=True,
    rate=True,
    method="banded",
    warm_start=None,
    framewise=False,
    fps=60.0,
    unposed=None,
    stable=None,
) -> np.ndarray:
    """Return the coefficient track ``(T, K)`` that best reproduces ``frames``.

    Same parameters as :func:`fit_sequence` (which also returns diagnostics):
    ``neutral (V, 3)``, ``deltas (K, V, 3)``, ``frames (T, V, 3)``; by default
    the exact optimum of ``min sum_t ||B u_t - (p_t - n)||^2`` subject to
    ``0 <= u <= 1`` and ``|u_{t+1} - u_t| <= delta``, after removing the head
    pose unless ``unposed=True``.

    Returns
    -------
    (T, K) ndarray
        Coefficients at 60 fps, columns in the order of ``deltas``.
    """
    where = "fit_coefficients"
    if method not in METHODS:
        raise UserError(f"{where}: method must be one of {METHODS}, got {method!r}")
    delta = check_delta(delta, where) if rate else None
    (neutral, deltas, frames), _ = _checked_frames(neutral, deltas, frames, vertex_subset, unposed, stable, where, fps)
    if fps != 60.0:
        frames = resample_sequence(frames, fps, 60.0)
    lower, upper = (0.0, 1.0) if bounds else (None, None)
    with _one_blas_thread():
        # only the minimiser is returned: no objective, so no ||p_t - n||^2 pass
        system = normal_equations_of_checked(neutral, deltas, frames, offset_sq=False)
        if framewise:
            if not bounds:
                raise UserError(f"{where}: framewise mode needs bounds=True")
            return framewise_coefficients(system.gram, system.rhs, delta=delta, warm_start=warm_start)
        if not bounds and delta is None:
            return least_squares_coefficients(system.gram, system.rhs)
        if method == "banded":
            return solve_banded_qp(
                system.gram, system.rhs, lower=lower, upper=upper, delta=delta,
                warm_start=warm_start,
            ).coeffs
        coeffs = solve_sparse_qp(
            system.gram, system.rhs, lower=lower, upper=upper, delta=delta,
            solver=method, warm_start=warm_start,
        )
        return np.clip(coeffs, 0.0, 1.0) if bounds else coeffs


def fit_rig(rig, frames, **kwargs) -> np.ndarray:
    """:func:`fit_coefficients` with a :class:`blendvoca.rig.Rig` (uses its
    ``neutral`` and ``deltas``; columns follow ``rig.names``)."""
    return fit_coefficients(rig.neutral, rig.deltas, frames, **kwargs)
