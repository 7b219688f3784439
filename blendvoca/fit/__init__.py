"""Coefficient fitting: the temporally constrained QP of BlendVOCA.

``fit_coefficients(neutral, deltas, frames, *, rate_bound=0.1, vertex_subset=None)``
returns the ``(T, K)`` track minimising ``sum_t ||B u_t - (p_t - n)||^2``
subject to ``0 <= u <= 1`` and ``|u_{t+1} - u_t| <= rate_bound``; ``fit_sequence``
returns it with diagnostics (``solver=`` picks the QP solver, :data:`SOLVERS`).  Building blocks (one file per step):
:func:`normal_equations` (the 3V products, once per sentence),
:func:`solve_banded_qp` (banded interior point + certified active-set polish),
:func:`solve_sparse_qp` (general solvers), :func:`least_squares_coefficients`,
:func:`framewise_coefficients`, :func:`resample_sequence`,
:func:`vertex_errors`, :func:`constraint_activity`, 
:func:`remove_head_pose` (robust rigid alignment of posed frames to the neutral)
and :func:`fit_pose_and_coefficients` (the head pose and the coefficients fitted
together: the entry points' default on posed frames, unless declared unposed).
``python -m blendvoca.fit`` fits a mesh sequence frame by frame as a stream
(:class:`StreamingSolver`). Old keyword spellings ``delta=`` (now ``rate_bound=``)
and ``method=`` (now ``solver=``) and the name ``METHODS`` (now ``SOLVERS``) warn,
and go after 2027-06-30.
"""

import warnings

from ._renamed import REMOVED_AFTER
from .banded_qp import QPSolution, solve_banded_qp
from .coefficients import POSE_FITS, SOLVERS, FitResult, fit_coefficients, fit_rig, fit_sequence
from .diagnostics import constraint_activity, vertex_errors
from .framewise import framewise_coefficients
from .joint_pose import JointFit, fit_pose_and_coefficients
from .least_squares import least_squares_coefficients
from .normal_equations import NormalEquations, normal_equations
from .pose import HeadPose, flame_stable_vertices, least_moving_vertices, remove_head_pose
from .resample import resample_sequence
from .sparse_qp import solve_published_qp, solve_sparse_qp
from .streaming import StreamingSolver, StreamingSolverConfig

__all__ = [
    "FitResult",
    "HeadPose",
    "JointFit",
    "POSE_FITS",
    "SOLVERS",
    "NormalEquations",
    "QPSolution",
    "StreamingSolver",
    "StreamingSolverConfig",
    "constraint_activity",
    "flame_stable_vertices",
    "least_moving_vertices",
    "fit_coefficients",
    "fit_pose_and_coefficients",
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


def __getattr__(name):
    # The old name of SOLVERS, kept with a warning until REMOVED_AFTER.
    if name == "METHODS":
        warnings.warn(f"blendvoca.fit.METHODS is now blendvoca.fit.SOLVERS; METHODS is removed after {REMOVED_AFTER}",
                      DeprecationWarning, stacklevel=2)
        return SOLVERS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
