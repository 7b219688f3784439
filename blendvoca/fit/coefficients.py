"""Public entry points: fit a coefficient track to a mesh sequence with a rig.

Posed frames (FLAME meshes, unless declared unposed) get their head pose fitted
first, by default jointly with the coefficients as the build does
(:mod:`blendvoca.fit.joint_pose`); the fit itself is :func:`blendvoca.fit.qp_fit.fit_unposed`.
"""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError

from ._renamed import renamed_keywords
from .joint_pose import fit_pose_and_coefficients
from .normal_equations import check_rig_and_frames
from .pose import FLAME_NUM_VERTICES, remove_head_pose
from .qp_fit import SOLVERS, FitResult, fit_unposed

__all__ = ["POSE_FITS", "SOLVERS", "FitResult", "fit_coefficients", "fit_rig", "fit_sequence"]

#: How :func:`fit_sequence` unposes posed frames (see its ``pose_fit``).
POSE_FITS = ("joint", "remove")


@renamed_keywords(delta="rate_bound", method="solver")
def fit_sequence(
    neutral,
    deltas,
    frames,
    *,
    rate_bound=0.1,
    vertex_subset=None,
    bounds=True,
    rate=True,
    solver="banded",
    warm_start=None,
    framewise=False,
    fps=60.0,
    unposed=None,
    stable=None,
    pose_fit="joint",
) -> FitResult:
    """Fit a coefficient track and return it with its diagnostics.

    Solves ``min_u sum_t ||B u_t - (p_t - n)||^2`` subject to ``0 <= u <= 1``
    (``bounds``) and ``|u_{t+1} - u_t| <= rate_bound`` (``rate``): the temporally
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
    rate_bound : float, optional
        Rate bound per 60 fps frame (old spelling ``delta=``, removed after 2027-06-30).
    vertex_subset : (S,) array_like of int, optional
        Fit (and measure) on these vertices only, e.g. the 4580-vertex head.
    bounds : bool, optional
        Impose ``0 <= u <= 1``.
    rate : bool, optional
        Impose ``|u_{t+1} - u_t| <= rate_bound``.
    solver : {"banded", "piqp", "clarabel", "osqp", "cvxopt"}, optional
        The QP solver (old spelling ``method=``, removed after 2027-06-30).
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
        ``unposedcleaneddata``, rig outputs). False: the head pose is fitted as
        ``pose_fit`` says and returned in ``pose``. None (default): False for
        FLAME-topology meshes (5023 vertices, whose stable region is known),
        True for other topologies (rig-space data: with a rig whose shapes move
        every vertex a rigid alignment would absorb part of the expression).
    stable : (S,) array_like of int, optional
        Stable vertices for the (starting) rigid alignment (full topology
        indices); default as :func:`remove_head_pose`.
    pose_fit : {"joint", "remove"}, optional
        How posed frames are unposed. "joint" (default, the build's path): the
        pose and the coefficients fitted together
        (:func:`blendvoca.fit.joint_pose.fit_pose_and_coefficients` with its
        defaults, ``warm_start`` unused); "remove": each frame rigidly aligned to
        ``neutral`` on stable vertices by :func:`remove_head_pose`, then the fit
        (the only choice with ``framewise``, which sees no frame ahead).

    Returns
    -------
    FitResult
    """
    return _fit(neutral, deltas, frames, where="fit_sequence", diagnostics=True, **_options(locals()))


@renamed_keywords(delta="rate_bound", method="solver")
def fit_coefficients(neutral, deltas, frames, **options) -> np.ndarray:
    """Return the coefficient track ``(T, K)`` that best reproduces ``frames``.

    Same parameters and defaults as :func:`fit_sequence` (which also returns diagnostics):
    ``neutral (V, 3)``, ``deltas (K, V, 3)``, ``frames (T, V, 3)``; by default
    the exact optimum of ``min sum_t ||B u_t - (p_t - n)||^2`` subject to
    ``0 <= u <= 1`` and ``|u_{t+1} - u_t| <= rate_bound``, with the head pose
    fitted jointly unless ``unposed=True``.

    Returns
    -------
    (T, K) ndarray
        Coefficients at 60 fps, columns in the order of ``deltas``.
    """
    unknown = sorted(set(options) - set(_DEFAULTS))
    if unknown:
        raise TypeError(f"fit_coefficients() got unexpected keyword arguments {unknown}; it takes "
                        f"{sorted(_DEFAULTS)} (as fit_sequence)")
    return _fit(neutral, deltas, frames, where="fit_coefficients", diagnostics=False, **{**_DEFAULTS, **options})


def fit_rig(rig, frames, **kwargs) -> np.ndarray:
    """:func:`fit_coefficients` with a :class:`blendvoca.rig.Rig` (uses its
    ``neutral`` and ``deltas``; columns follow ``rig.names``)."""
    return fit_coefficients(rig.neutral, rig.deltas, frames, **kwargs)


def _options(arguments: dict) -> dict:
    """The keyword arguments of an entry point (its ``locals()`` on entry), rig and frames left out."""
    return {name: value for name, value in arguments.items() if name not in ("neutral", "deltas", "frames")}


#: The keywords of :func:`fit_sequence` and :func:`fit_coefficients` with their defaults.
_DEFAULTS = dict(fit_sequence.__wrapped__.__kwdefaults__)


def _fit(neutral, deltas, frames, *, where, diagnostics, unposed, stable, pose_fit, **options):
    """The entry points' fit: the frames unposed as asked (:data:`POSE_FITS`), then :func:`fit_unposed`."""
    if pose_fit not in POSE_FITS:
        raise UserError(f"{where}: pose_fit must be one of {POSE_FITS}, got {pose_fit!r}")
    if unposed is None:
        # Auto: FLAME meshes (captures, method outputs) have a known stable
        # region; other topologies are treated as rig-space data.
        unposed = np.shape(neutral)[0] != FLAME_NUM_VERTICES
    if unposed:
        return fit_unposed(neutral, deltas, frames, where=where, diagnostics=diagnostics, **options)
    if pose_fit == "joint" and not options["framewise"]:
        joint = fit_pose_and_coefficients(
            neutral, deltas, frames, vertex_subset=options["vertex_subset"], stable=stable,
            rate_bound=options["rate_bound"], bounds=options["bounds"], rate=options["rate"],
            solver=options["solver"], fps=options["fps"])
        return joint.fit if diagnostics else joint.coeffs
    if pose_fit == "joint":
        raise UserError(f"{where}: framewise=True on posed frames needs pose_fit='remove' (the joint pose fit "
                        f"sees the whole sentence) or unposed=True")
    check_rig_and_frames(neutral, deltas, frames, options["vertex_subset"], where)
    pose = remove_head_pose(frames, neutral, stable=stable)
    return fit_unposed(neutral, deltas, pose.frames, where=where, diagnostics=diagnostics, pose=pose, **options)
