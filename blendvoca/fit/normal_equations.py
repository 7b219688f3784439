"""The fitting objective reduced to K x K: Gram matrix and per-frame right-hand sides.

The objective ``sum_t ||B u_t - (p_t - n)||^2`` only ever needs ``G = B^T B``
(K x K), ``c_t = B^T (p_t - n)`` and ``||p_t - n||^2``; these are the only
products with the 3V-long vectors, done once per sentence, so no solver ever
sees 3V.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blendvoca.errors import UserError

from ._checks import as_float_array, vertex_indices
from .frame_crop import FrameCrop


@dataclass(frozen=True)
class NormalEquations:
    """The fitting objective in K x K form.

    ``objective(u) = sum_t u_t^T G u_t - 2 c_t . u_t + r_t``.

    Attributes
    ----------
    gram : (K, K) ndarray
        ``B^T B`` over the fitted vertices.
    rhs : (T, K) ndarray
        ``c_t = B^T (p_t - n)``.
    offset_sq : (T,) ndarray or None
        ``r_t = ||p_t - n||^2`` (None when not computed: no :meth:`objective`).
    num_vertices : int
        Number of fitted vertices (for RMSE).
    """

    gram: np.ndarray
    rhs: np.ndarray
    offset_sq: np.ndarray
    num_vertices: int

    def objective(self, coeffs: np.ndarray) -> float:
        """Return ``sum_t ||B u_t - (p_t - n)||^2`` for ``coeffs (T, K)``."""
        coeffs = np.asarray(coeffs, dtype=np.float64)
        quad = np.einsum("tk,kl,tl->", coeffs, self.gram, coeffs)
        return float(quad - 2.0 * np.sum(coeffs * self.rhs) + np.sum(self.offset_sq))


def check_rig(neutral, deltas, where: str) -> tuple[np.ndarray, np.ndarray]:
    """Return ``neutral (V, 3)`` and ``deltas (K >= 1, V, 3)`` as finite float64 arrays, or a
    :class:`UserError` naming ``where`` and the shapes."""
    neutral = as_float_array(neutral, "neutral", 2, where)
    deltas = as_float_array(deltas, "deltas", 3, where)
    if neutral.shape[1] != 3:
        raise UserError(f"{where}: neutral must be (V, 3), got shape {neutral.shape}")
    if deltas.shape[1:] != neutral.shape or deltas.shape[0] == 0:
        raise UserError(f"{where}: deltas must be (K >= 1, {neutral.shape[0]}, 3) to match neutral, "
                        f"got {deltas.shape}")
    return neutral, deltas


def check_rig_and_frames(neutral, deltas, frames, vertex_subset=None, where="fit", *, lazy=False):
    """Validate and convert rig arrays and frames; apply the vertex subset.

    Parameters
    ----------
    neutral : (V, 3) array_like
    deltas : (K, V, 3) array_like
    frames : (T, V, 3) array_like
    vertex_subset : (S,) array_like of int, optional
        Vertex indices to keep (e.g. the 4580-vertex FLAME head).
    lazy : bool, default False
        With a subset: return the frames as a :class:`FrameCrop` of the frames in
        their own float dtype (cropped and converted chunk by chunk when used).

    Returns
    -------
    neutral : (S, 3) ndarray
    deltas : (K, S, 3) ndarray
    frames : (T, S, 3) ndarray, or FrameCrop
    """
    lazy = bool(lazy and vertex_subset is not None)
    neutral, deltas = check_rig(neutral, deltas, where)
    frames = as_float_array(frames, "frames", 3, where, keep_float=lazy)
    num_vertices = neutral.shape[0]
    if frames.shape[1:] != neutral.shape:
        raise UserError(
            f"{where}: frames must be (T, {num_vertices}, 3) to match neutral, got {frames.shape}"
        )
    if frames.shape[0] == 0:
        raise UserError(f"{where}: frames must hold at least one frame, got {frames.shape}")
    if vertex_subset is not None:
        subset = vertex_indices(vertex_subset, num_vertices, where)
        # np.take along the vertex axis gives C-contiguous crops (frames[:, subset]
        # does not), so the reshapes of the fit are views, not copies.
        neutral = np.take(neutral, subset, axis=0)
        deltas = np.take(deltas, subset, axis=1)
        frames = FrameCrop(frames, subset) if lazy else np.take(frames, subset, axis=1)
    return neutral, deltas, frames


def normal_equations(neutral, deltas, frames, *, vertex_subset=None) -> NormalEquations:
    """Return the K x K normal equations of the per-sentence fitting objective.

    ``neutral (V, 3)``, ``deltas (K, V, 3)``, ``frames (T, V, 3)`` and ``vertex_subset`` (fit on
    these vertices only) as in :func:`check_rig_and_frames`.

    Returns
    -------
    NormalEquations
        ``gram (K, K)``, ``rhs (T, K)``, ``offset_sq (T,)``.
    """
    neutral, deltas, frames = check_rig_and_frames(
        neutral, deltas, frames, vertex_subset, "normal_equations"
    )
    return normal_equations_of_checked(neutral, deltas, frames)


def normal_equations_of_checked(neutral, deltas, frames, *, offset_sq: bool = True) -> NormalEquations:
    """:func:`normal_equations` of arrays :func:`check_rig_and_frames` returned (no second check).

    ``frames`` may be a :class:`FrameCrop`: the products are then made chunk by
    chunk of frames (the same rows, bit for bit). ``offset_sq=False`` leaves
    ``offset_sq`` None (no objective value): a caller that only needs the
    minimiser saves a pass over the frames.
    """
    num_shapes = deltas.shape[0]
    basis = deltas.reshape(num_shapes, -1)  # (K, 3S)
    gram = basis @ basis.T
    if isinstance(frames, FrameCrop):
        rhs = np.empty((frames.shape[0], num_shapes))
        squares = np.empty(frames.shape[0]) if offset_sq else None
        for start, crop in frames.chunks():
            crop -= neutral[None]  # the chunk is ours: the offsets in place
            offsets = crop.reshape(crop.shape[0], -1)
            rhs[start:start + crop.shape[0]] = offsets @ basis.T
            if offset_sq:
                squares[start:start + crop.shape[0]] = np.einsum("ij,ij->i", offsets, offsets)
    else:
        offsets = (frames - neutral[None]).reshape(frames.shape[0], -1)  # (T, 3S)
        rhs = offsets @ basis.T
        squares = np.einsum("ij,ij->i", offsets, offsets) if offset_sq else None
    return NormalEquations(gram=0.5 * (gram + gram.T), rhs=rhs, offset_sq=squares, num_vertices=neutral.shape[0])
