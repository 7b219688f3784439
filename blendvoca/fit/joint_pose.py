"""Joint head-pose and expression fit: rigid alignment and coefficient fit, alternated.

:func:`blendvoca.fit.remove_head_pose` aligns each frame to the *neutral* on
vertices assumed not to move with speech, then the coefficients are fitted to
the aligned frames. Whatever the expression moves inside that region (the brows
and lids reach the forehead, the jaw the cheeks) biases the pose, and the bias
is then explained by mouth and brow shapes. The joint fit removes that bias by
alternating two steps until neither changes:

1. fit the coefficients to the frames unposed with the current pose (the
   project's temporally constrained QP, :func:`blendvoca.fit.fit_sequence`);
2. re-estimate each frame's pose by a robust weighted Kabsch alignment of the
   rig's *prediction* for that frame (neutral plus the fitted deformation) to
   the posed frame on the head region, with iteratively re-weighted least
   squares (Geman-McClure or Huber weights on the per-vertex residuals) so that
   what the rig cannot explain (hair, noise, tongue) loses its influence.

Each step lowers the same objective, the robustly weighted residual between
the posed frames and the posed rig, so the alternation settles; on frames the
rig can reproduce exactly, the true pose and coefficients are its fixed point.

Convention as :mod:`blendvoca.fit.pose`: ``frames[t] ~= rig(u_t) @ R_t.T + t_t``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from blendvoca.errors import UserError

from ._checks import as_float_array, region_indices
from ._renamed import renamed_keywords
from .pose import FLAME_NUM_VERTICES, HeadPose, remove_head_pose
from .qp_fit import FitResult, fit_unposed
from .resample import resample_sequence

#: Accepted values of ``robust``.
ROBUST_LOSSES = ("geman-mcclure", "huber", "none")


@dataclass(frozen=True)
class JointFit:
    """Coefficients and head pose fitted together, with how the alternation went.

    Attributes
    ----------
    coeffs : (T, K) ndarray
        The coefficients (60 fps).
    pose : HeadPose
        The pose: ``rotations (T, 3, 3)``, ``translations (T, 3)``, the unposed
        ``frames (T, V, 3)``, the alignment region (``stable``) and the final
        robust weights of its vertices.
    fit : FitResult
        The last coefficient fit (on the frames unposed with the final pose),
        its ``pose`` set to :attr:`pose`.
    iterations : int
        Alternations made.
    converged : bool
        True when the last alternation changed the pose and the coefficients by
        less than the tolerances.
    history : tuple of dict
        Per alternation: ``rotation_change_deg`` (largest over frames),
        ``translation_change`` (mesh units), ``coeff_change`` (largest
        absolute), ``rmse`` (mean per-frame RMSE of the fit on the fitted vertices).
    """

    coeffs: np.ndarray
    pose: HeadPose
    fit: FitResult
    iterations: int
    converged: bool
    history: tuple


def _rotation_angles_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-frame angle (degrees) of the rotation taking ``a[t]`` to ``b[t]``."""
    trace = np.einsum("tji,tji->t", a, b)
    return np.degrees(np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0)))


def kabsch_per_frame(src: np.ndarray, dst: np.ndarray, weights: np.ndarray):
    """Weighted rigid fit ``dst[t] ~= src[t] @ R_t.T + t_t`` for every frame.

    Unlike the alignment of :func:`remove_head_pose` the source changes from
    frame to frame (the rig's prediction of each frame).

    Parameters
    ----------
    src, dst : (T, S, 3) ndarray
    weights : (T, S) ndarray
        Non-negative, at least three positive per frame.

    Returns
    -------
    rotations : (T, 3, 3) ndarray
        Proper rotations (determinant +1).
    translations : (T, 3) ndarray
    """
    wn = weights / weights.sum(axis=1, keepdims=True)
    cs = np.matmul(wn[:, None, :], src)[:, 0]               # (T, 3)
    cd = np.matmul(wn[:, None, :], dst)[:, 0]
    # sum_s w_s (x_s - cs)(y_s - cd)^T = sum_s w_s x_s y_s^T - cs cd^T (weights sum to 1)
    cross = np.einsum("tsi,tsj->tij", wn[:, :, None] * src, dst, optimize=True) - cs[:, :, None] * cd[:, None, :]
    u, _, vt = np.linalg.svd(cross)
    # V diag(1, 1, d) U^T with d fixing a reflection
    d = np.sign(np.linalg.det(np.matmul(u, vt)))
    v = vt.transpose(0, 2, 1).copy()
    v[:, :, 2] *= d[:, None]
    rotations = np.matmul(v, u.transpose(0, 2, 1))
    translations = cd - np.einsum("tij,tj->ti", rotations, cs)
    return rotations, translations


def robust_weights(residuals: np.ndarray, loss: str, floor: float) -> np.ndarray:
    """IRLS weights of per-vertex residual lengths ``(T, S)``, per frame.

    The scale is the frame's robust spread (1.4826 times the median residual),
    never below ``floor`` so that exactly explained frames keep uniform weights.
    Geman-McClure: ``1 / (1 + (r / c)^2)^2`` with ``c = 2.5 s`` (redescending:
    gross outliers get no say); Huber: ``min(1, k / r)`` with ``k = 1.345 s``.
    """
    if loss == "none":
        return np.ones_like(residuals)
    scale = np.maximum(1.4826 * np.median(residuals, axis=1, keepdims=True), floor)
    if loss == "huber":
        k = 1.345 * scale
        return np.minimum(1.0, k / np.maximum(residuals, 1e-300))
    c = 2.5 * scale
    return 1.0 / (1.0 + (residuals / c) ** 2) ** 2


@renamed_keywords(delta="rate_bound", method="solver")
def fit_pose_and_coefficients(
    neutral,
    deltas,
    frames,
    *,
    region=None,
    vertex_subset=None,
    stable=None,
    rate_bound=0.1,
    bounds=True,
    rate=True,
    solver="banded",
    fps=60.0,
    robust="geman-mcclure",
    max_iterations: int = 50,
    rotation_tol_deg: float = 1e-4,
    translation_tol: float = 1e-7,
    coeff_tol: float = 1e-5,
    irls_steps: int = 3,
    scale_floor: float = 1e-6,
    max_region_vertices: int | None = 5000,
) -> JointFit:
    """Fit the head pose and the coefficients of a posed mesh sequence together.

    Parameters
    ----------
    neutral : (V, 3) array_like
        Rig neutral (unposed).
    deltas : (K, V, 3) array_like
        Blendshape offsets.
    frames : (T, V, 3) array_like
        Posed mesh sequence at ``fps`` (same topology as the rig).
    region : (R,) array_like of int or bool, optional
        Vertices the pose is aligned on. Default ``vertex_subset`` (the head the
        coefficients are fitted on), else every vertex: the rig's prediction
        takes the expression out, so the whole head can carry the pose.
    vertex_subset : (S,) array_like of int, optional
        Vertices the coefficients are fitted on (as :func:`fit_sequence`).
    stable : (S,) array_like of int, optional
        Stable vertices for the starting pose (:func:`remove_head_pose`). Default:
        FLAME's stable region for FLAME meshes, else the least-moving 30 % of the
        alignment region.
    rate_bound, bounds, rate, solver
        As :func:`blendvoca.fit.fit_sequence` (old spellings ``delta=``, ``method=``: removed after 2027-06-30).
    fps : float
        Frame rate of ``frames``; other rates are resampled to 60 fps first
        (the pose is then per 60 fps frame).
    robust : {"geman-mcclure", "huber", "none"}
        Loss of the re-weighted alignment (see :func:`robust_weights`).
    max_iterations : int
        Most alternations.
    rotation_tol_deg, translation_tol, coeff_tol : float
        Stop once an alternation changes every frame's rotation by less than
        ``rotation_tol_deg`` degrees, its translation by less than
        ``translation_tol`` (mesh units) and every coefficient by less than ``coeff_tol``.
    irls_steps : int
        Re-weighting steps of the alignment per alternation (the weights carry
        over from one alternation to the next).
    scale_floor : float
        Smallest residual scale of the robust weights (mesh units).
    max_region_vertices : int or None
        Align on at most this many region vertices, evenly spread over the
        region's index order (a rigid motion is fixed by a few thousand points;
        on BIWI's 23,370-vertex meshes the alignment would otherwise cost more
        than the fit). None: every region vertex.

    Returns
    -------
    JointFit
    """
    where = "fit_pose_and_coefficients"
    if robust not in ROBUST_LOSSES:
        raise UserError(f"{where}: robust must be one of {ROBUST_LOSSES}, got {robust!r}")
    if int(max_iterations) < 1:
        raise UserError(f"{where}: max_iterations must be at least 1, got {max_iterations!r}")
    neutral = as_float_array(neutral, "neutral", 2, where)
    deltas = as_float_array(deltas, "deltas", 3, where)
    frames = as_float_array(frames, "frames", 3, where)
    if neutral.shape[1:] != (3,) or deltas.shape[1:] != neutral.shape or frames.shape[1:] != neutral.shape \
            or len(frames) == 0 or len(deltas) == 0:
        raise UserError(f"{where}: expected neutral (V, 3), deltas (K>0, V, 3) and frames (T>0, V, 3) of one "
                        f"topology, got {neutral.shape}, {deltas.shape} and {frames.shape}")
    if fps != 60.0:
        frames = resample_sequence(frames, fps, 60.0)
    num_vertices = len(neutral)
    if vertex_subset is not None:
        vertex_subset = region_indices(vertex_subset, num_vertices, "vertex_subset", where)
    if region is None:
        region = vertex_subset if vertex_subset is not None else np.arange(num_vertices)
    region = region_indices(region, num_vertices, "region", where)
    if max_region_vertices is not None and len(region) > int(max_region_vertices):
        if int(max_region_vertices) < 3:
            raise UserError(f"{where}: max_region_vertices must be at least 3, got {max_region_vertices!r}")
        region = region[np.unique(np.linspace(0, len(region) - 1, int(max_region_vertices)).round().astype(np.int64))]

    if stable is None and num_vertices != FLAME_NUM_VERTICES:
        # the starting pose only: found on the least-moving part of the (thinned) region
        start = remove_head_pose(np.take(frames, region, axis=1), neutral[region])
    else:
        start = remove_head_pose(frames, neutral, stable=stable)
    rotations, translations = start.rotations, start.translations
    weights = np.ones((len(frames), len(region)))
    posed_region = np.take(frames, region, axis=1)
    neutral_region = neutral[region]
    basis_region = np.take(deltas, region, axis=1).reshape(len(deltas), -1)  # (K, 3R)
    coeffs, fit, history, converged = None, None, [], False
    for _ in range(int(max_iterations)):
        unposed = np.matmul(frames - translations[:, None], rotations)
        fit = _fit_step(neutral, deltas, unposed, coeffs, rate_bound, vertex_subset, bounds, rate, solver)
        predicted = neutral_region[None] + (fit.coeffs @ basis_region).reshape(len(frames), -1, 3)
        new_rot, new_trans = rotations, translations
        for _ in range(max(1, int(irls_steps))):
            new_rot, new_trans = kabsch_per_frame(predicted, posed_region, weights)
            diff = posed_region - (np.matmul(predicted, new_rot.transpose(0, 2, 1)) + new_trans[:, None])
            # the three squares spelled out: a reduction over an axis of length 3 is slow in numpy
            lengths = np.sqrt(diff[..., 0] ** 2 + diff[..., 1] ** 2 + diff[..., 2] ** 2)
            weights = robust_weights(lengths, robust, scale_floor)
        step = {
            "rotation_change_deg": float(_rotation_angles_deg(rotations, new_rot).max()),
            "translation_change": float(np.abs(new_trans - translations).max()),
            "coeff_change": float(np.abs(fit.coeffs - coeffs).max()) if coeffs is not None else float("inf"),
            "rmse": float(fit.rmse.mean()),
        }
        history.append(step)
        rotations, translations, coeffs = new_rot, new_trans, fit.coeffs
        if (step["rotation_change_deg"] < rotation_tol_deg and step["translation_change"] < translation_tol
                and step["coeff_change"] < coeff_tol):
            converged = True
            break
    # The returned coefficients belong to the returned pose: one last fit when the pose moved after it.
    unposed = np.matmul(frames - translations[:, None], rotations)
    if not converged:
        fit = _fit_step(neutral, deltas, unposed, coeffs, rate_bound, vertex_subset, bounds, rate, solver)
    pose = HeadPose(frames=unposed, rotations=rotations, translations=translations, stable=region, weights=weights)
    return JointFit(coeffs=fit.coeffs, pose=pose, fit=replace(fit, pose=pose), iterations=len(history),
                    converged=converged, history=tuple(history))


def _fit_step(neutral, deltas, unposed, coeffs, rate_bound, vertex_subset, bounds, rate, solver) -> FitResult:
    """The coefficient step of the alternation: the fit of the frames as unposed so far."""
    return fit_unposed(neutral, deltas, unposed, rate_bound=rate_bound, vertex_subset=vertex_subset, bounds=bounds,
                       rate=rate, solver=solver, warm_start=coeffs, framewise=False, fps=60.0,
                       where="fit_pose_and_coefficients")
