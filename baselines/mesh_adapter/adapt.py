"""Vertex sequence -> BlendVOCA coefficient track through the speaker's rig."""

from __future__ import annotations

import numpy as np

__all__ = ["adapted_coefficients", "resolve_vertex_subset"]


def resolve_vertex_subset(subset):
    """Vertex indices for a config's ``vertex_subset`` (None, ``"flame-head"`` or a list)."""
    if subset is None:
        return None
    if subset == "flame-head":
        from blendvoca.assets import load_index_list

        return load_index_list("flame-head-idx")
    return np.asarray(subset, dtype=np.int64)


def adapted_coefficients(frames, neutral, deltas, *, fps: float = 60.0, template: str = "absolute",
                         delta: float | None = 0.1, vertex_subset=None, unposed: bool | None = None,
                         poses: list | None = None) -> np.ndarray:
    """The coefficient track that best reproduces a vertex sequence with a rig.

    Parameters
    ----------
    frames : (T, V, 3) ndarray
        The method's output at ``fps``: absolute positions, or offsets from the
        speaker's neutral when ``template == "offsets"``.
    neutral : (V, 3) ndarray
        Rig neutral (the speaker's template).
    deltas : (K, V, 3) ndarray
        Rig blendshape offsets, in the output column order.
    fps : float
        Frame rate of ``frames``; the track is fitted at 60 fps after linear
        resampling.
    template : {"absolute", "offsets"}
    delta : float or None
        Rate bound ``|u[t+1] - u[t]| <= delta`` of the QP (None: bounds only).
    vertex_subset : (M,) int ndarray, optional
        Vertices used in the fit.
    unposed : bool or None
        Whether the output is known to carry no head pose; None (default): the
        head pose is removed for FLAME-topology outputs
        (:func:`blendvoca.fit.remove_head_pose`), see :func:`blendvoca.fit.fit_sequence`.
    poses : list, optional
        When given, the removed :class:`blendvoca.fit.HeadPose` (or None) is
        appended to it, so callers can report it (``pose.summary()``: degrees, mm).

    Returns
    -------
    (T60, K) float64 ndarray in [0, 1]
    """
    from blendvoca.fit import fit_sequence, resample_sequence

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
    kwargs = {"vertex_subset": vertex_subset, "unposed": unposed}
    if delta is None:
        kwargs["rate"] = False
    else:
        kwargs["delta"] = delta
    result = fit_sequence(neutral, deltas, frames, **kwargs)
    if poses is not None:
        poses.append(result.pose)
    return np.asarray(result.coeffs, dtype=np.float64)
