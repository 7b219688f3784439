"""Vertex sequences -> BlendVOCA coefficient tracks through a speaker's rig.

The one place where meshes become coefficients for scoring: the runner uses it for
``output = "vertices"`` methods and the ``mesh-adapter`` plug-in for stored outputs.
The fit is :func:`blendvoca.fit.fit_sequence` (bounded, rate-constrained QP,
``|u[t+1] - u[t]| <= delta``), the protocol the SAiD paper scores VOCA, FaceFormer
and CodeTalker with; FLAME-topology outputs are first rigidly unposed
(:func:`blendvoca.fit.remove_head_pose`), and on FLAME rigs the fit uses the
4580-vertex head crop that the BlendVOCA build fits with (asset ``flame-head-idx``).
"""

from __future__ import annotations

import numpy as np

from blendvoca.assets import load_index_list

from .coefficients import fit_sequence
from .pose import FLAME_NUM_VERTICES
from .resample import resample_sequence

__all__ = ["FLAME_NUM_VERTICES", "adapted_coefficients", "fitted_sample_tracks", "rig_fit_vertices"]

def rig_fit_vertices(num_vertices: int):
    """Vertices a fit on a rig with ``num_vertices`` uses: the FLAME head crop on a
    full FLAME rig (as ``blendvoca.build`` fits), else None (all vertices).

    Returns
    -------
    (4580,) int64 ndarray or None
    """
    if int(num_vertices) != FLAME_NUM_VERTICES:
        return None
    return load_index_list("flame-head-idx")


def adapted_coefficients(frames, neutral, deltas, *, fps: float = 60.0, template: str = "absolute",
                         delta: float | None = 0.1, vertex_subset=None, unposed: bool | None = None,
                         poses: list | None = None) -> np.ndarray:
    """The coefficient track that best reproduces a vertex sequence with a rig.

    Parameters
    ----------
    frames : (T, V, 3) ndarray
        Absolute positions at ``fps``, or offsets from the speaker's neutral when
        ``template == "offsets"``.
    neutral : (V, 3) ndarray
        Rig neutral (the speaker's template).
    deltas : (K, V, 3) ndarray
        Rig blendshape offsets, in the output column order.
    fps : float
        Frame rate of ``frames``; the track is fitted at 60 fps after linear resampling.
    template : {"absolute", "offsets"}
    delta : float or None
        Rate bound ``|u[t+1] - u[t]| <= delta`` of the QP (None: bounds only).
    vertex_subset : (M,) int ndarray, optional
        Vertices used in the fit.
    unposed : bool or None
        Whether the output is known to carry no head pose; None (default): the
        head pose is removed for FLAME-topology outputs
        (:func:`blendvoca.fit.remove_head_pose`), see :func:`blendvoca.fit.fit_sequence` (``pose_fit="remove"``).
    poses : list, optional
        When given, the removed :class:`blendvoca.fit.HeadPose` (or None) is
        appended to it, so callers can report it (``pose.summary()``: degrees, mm).

    Returns
    -------
    (T60, K) float64 ndarray in [0, 1]
    """
    frames = np.asarray(frames, dtype=np.float64)
    neutral = np.asarray(neutral, dtype=np.float64)
    if frames.ndim != 3 or frames.shape[1:] != neutral.shape:
        raise ValueError(
            f"adapted_coefficients: expected frames (T, {neutral.shape[0]}, 3) matching the rig's topology, "
            f"got {frames.shape}"
        )
    if template == "offsets":
        frames = frames + neutral[None]
    elif template != "absolute":
        raise ValueError(f"adapted_coefficients: template must be 'absolute' or 'offsets', got {template!r}")
    if fps != 60.0:
        frames = resample_sequence(frames, fps, 60.0)
    # the benchmark's protocol: posed outputs are rigidly unposed first (pose_fit="remove")
    kwargs = {"vertex_subset": vertex_subset, "unposed": unposed, "pose_fit": "remove"}
    if delta is None:
        kwargs["rate"] = False
    else:
        kwargs["rate_bound"] = delta
    result = fit_sequence(neutral, deltas, frames, **kwargs)
    if poses is not None:
        poses.append(result.pose)
    return np.asarray(result.coeffs, dtype=np.float64)


def fitted_sample_tracks(vertices, rig, names, *, delta: float = 0.1) -> np.ndarray:
    """Coefficient tracks of every sample of a vertex-output method.

    Parameters
    ----------
    vertices : (S, T, V, 3) ndarray
        Metres on the rig's topology, 60 fps.
    rig : blendvoca.rig.Rig
        The speaker's rig.
    names : sequence of str
        Output column order.
    delta : float
        Rate bound of the QP (the build's default).

    Returns
    -------
    (S, T, K) float64 ndarray in [0, 1]
    """
    rig = rig.select(tuple(names)) if tuple(rig.names) != tuple(names) else rig
    subset = rig_fit_vertices(rig.num_vertices)
    return np.stack([adapted_coefficients(v, rig.neutral, rig.deltas, delta=delta, vertex_subset=subset)
                     for v in np.asarray(vertices)])
