"""Sentence stage: a coefficient track fitted to one 60 fps mesh sequence, with statistics."""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError
from blendvoca.fit import fit_pose_and_coefficients, fit_sequence
from blendvoca.rig import Rig

#: How posed input is unposed: ``joint`` alternates the rigid alignment and the coefficient fit
#: (:func:`blendvoca.fit.joint_pose.fit_pose_and_coefficients`, the default); ``remove`` aligns to
#: the neutral on stable vertices first, then fits (:func:`blendvoca.fit.remove_head_pose`).
POSE_FITS = ("joint", "remove")


def lip_aperture(frames: np.ndarray, upper_lip: int, lower_lip: int) -> np.ndarray:
    """Return the per-frame distance between an upper and a lower lip vertex.

    Parameters
    ----------
    frames : (T, V, 3) ndarray
    upper_lip, lower_lip : int
        Vertex indices (e.g. inner-lip landmarks 62 and 66 of the 68-point scheme).

    Returns
    -------
    (T,) float64 ndarray
        In mesh units.
    """
    frames = np.asarray(frames)
    upper, lower = (np.asarray(frames[:, v], dtype=np.float64) for v in (upper_lip, lower_lip))
    return np.linalg.norm(upper - lower, axis=1)


def sentence_fit(rig: Rig, frames: np.ndarray, head_index, *, delta: float = 0.1, posed: bool = False,
                 pose_fit: str = "joint", stable=None):
    """Fit one sentence on the head crop and summarise the fit.

    Parameters
    ----------
    rig : Rig
        The speaker's full-topology rig.
    frames : (T, V, 3) ndarray
        The sentence's meshes at 60 fps (metres), float64 or as stored (float32:
        cropped and converted to float64 a few frames at a time by the fit).
    head_index : (S,) ndarray of int
        Vertices the fit uses (FLAME head crop).
    delta : float
        Rate bound.
    posed : bool
        The frames carry a head pose (the corpus reader's ``posed``); False:
        they are fitted as they are.
    pose_fit : {"joint", "remove"}
        How posed frames are unposed (:data:`POSE_FITS`).
    stable : (S,) ndarray of int, optional
        Stable vertices of the starting (``joint``) or only (``remove``) rigid
        alignment; default as :func:`blendvoca.fit.remove_head_pose`.

    Returns
    -------
    coeffs : (T, K) ndarray
    stats : dict
        JSON-ready: ``frames``, ``rmse_mm`` (mean over frames of the per-frame
        RMSE), ``max_error_mm``, ``active`` (fractions of lower / upper / rate
        constraints active), ``usage`` (per-shape mean coefficient),
        ``active_per_shape`` and ``solver``; for posed frames also ``pose``
        (the removed pose's summary, ``method``, and for ``joint`` its
        ``iterations`` and ``converged``).
    """
    if pose_fit not in POSE_FITS:
        raise UserError(f"--pose-fit: expected one of {', '.join(POSE_FITS)}, got {pose_fit!r}")
    pose = None
    if not posed:
        # VOCASET's unposedcleaneddata (and the synthetic corpus's) carry no head pose.
        result = fit_sequence(rig.neutral, rig.deltas, frames, rate_bound=delta, vertex_subset=head_index, unposed=True)
    elif pose_fit == "joint":
        joint = fit_pose_and_coefficients(rig.neutral, rig.deltas, frames, rate_bound=delta, vertex_subset=head_index,
                                          stable=stable)
        result = joint.fit
        pose = {**joint.pose.summary(), "method": "joint", "iterations": joint.iterations,
                "converged": joint.converged}
    else:
        result = fit_sequence(rig.neutral, rig.deltas, frames, rate_bound=delta, vertex_subset=head_index,
                              unposed=False, stable=stable, pose_fit="remove")
        pose = {**result.pose.summary(), "method": "remove"}
    activity = result.activity
    stats = {
        "frames": int(frames.shape[0]),
        "rmse_mm": float(np.mean(result.rmse) * 1000.0),
        "max_error_mm": float(np.max(result.max_error) * 1000.0),
        "active": {name: float(np.mean(values)) for name, values in activity.items()},
        "active_per_shape": {name: [float(v) for v in values] for name, values in activity.items()},
        "usage": [float(v) for v in result.coeffs.mean(axis=0)],
        "solver": result.solver,
        "converged": bool(result.converged),
    }
    if pose is not None:
        stats["pose"] = pose
    return result.coeffs, stats
