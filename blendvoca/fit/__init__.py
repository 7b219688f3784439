"""Coefficient fitting: the temporally constrained QP of BlendVOCA.

``fit_coefficients(neutral, deltas, frames, *, delta=0.1, vertex_subset=None)``
returns the ``(T, K)`` track minimising ``sum_t ||B u_t - (p_t - n)||^2``
subject to ``0 <= u <= 1`` and ``|u_{t+1} - u_t| <= delta``; ``fit_sequence``
returns it with diagnostics.  Building blocks (one file per step):
:func:`normal_equations` (the 3V products, once per sentence),
:func:`solve_banded_qp` (banded interior point + certified active-set polish),
:func:`solve_sparse_qp` (general solvers), :func:`least_squares_coefficients`,
:func:`framewise_coefficients`, :func:`resample_sequence`,
:func:`vertex_errors`, :func:`constraint_activity`, and
:func:`remove_head_pose` (robust rigid alignment of posed frames to the neutral,
applied by the fit entry points unless the input is declared unposed).
"""

from .banded_qp import QPSolution, solve_banded_qp
from .coefficients import METHODS, FitResult, fit_coefficients, fit_rig, fit_sequence
from .diagnostics import constraint_activity, vertex_errors
from .framewise import framewise_coefficients
from .least_squares import least_squares_coefficients
from .normal_equations import NormalEquations, normal_equations
from .pose import HeadPose, flame_stable_vertices, least_moving_vertices, remove_head_pose
from .resample import resample_sequence
from .sparse_qp import solve_published_qp, solve_sparse_qp
from .streaming import StreamingSolver, StreamingSolverConfig

__all__ = [
    "FitResult",
    "HeadPose",
    "METHODS",
    "NormalEquations",
    "QPSolution",
    "StreamingSolver",
    "StreamingSolverConfig",
    "constraint_activity",
    "flame_stable_vertices",
    "least_moving_vertices",
    "fit_coefficients",
    "fit_rig",
    "fit_sequence",
    "framewise_coefficients",
    "least_squares_coefficients",
    "normal_equations",
    "remove_head_pose",
    "resample_sequence",
    "solve_banded_qp",
    "solve_published_qp",
    "solve_sparse_qp",
    "vertex_errors",
]
