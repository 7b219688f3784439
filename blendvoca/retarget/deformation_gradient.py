"""Per-triangle deformation gradients as in Sumner and Popovic (2004), section 3.

Every triangle gets a fourth vertex ``v4 = v1 + n / sqrt(|n|)`` (``n`` the unnormalised
normal), so that the affine map between a rest and a deformed triangle is a full
3x3 matrix ``Q = [v2-v1, v3-v1, v4-v1]_deformed @ inv([v2-v1, v3-v1, v4-v1]_rest)``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from blendvoca.errors import DataError

from ._checks import as_faces, as_vertices


def fourth_vertices(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The fourth vertex of every triangle, offset along its normal.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
    faces : (F, 3) int ndarray

    Returns
    -------
    v4 : (F, 3) float64 ndarray
        ``v1 + n / sqrt(|n|)`` with ``n = (v2 - v1) x (v3 - v1)``; the offset has the
        length ``sqrt(|n|)``, which scales like the triangle's edges.
    """
    V = as_vertices(vertices, "fourth_vertices")
    F = as_faces(faces, len(V), "fourth_vertices")
    v1, v2, v3 = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(v2 - v1, v3 - v1)
    length = np.linalg.norm(n, axis=1)
    if np.any(length <= 0):
        bad = np.flatnonzero(length <= 0)[:5]
        raise DataError(f"fourth_vertices: degenerate (zero-area) triangles, e.g. faces {bad.tolist()}")
    return v1 + n / np.sqrt(length)[:, None]


def triangle_frames(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Edge frames ``[v2-v1, v3-v1, v4-v1]`` (as columns) of every triangle (parameters as in `fourth_vertices`).

    Returns
    -------
    frames : (F, 3, 3) float64 ndarray
        ``frames[f][:, k]`` is the k-th edge vector of triangle ``f``.
    """
    V = as_vertices(vertices, "triangle_frames")
    F = as_faces(faces, len(V), "triangle_frames")
    v4 = fourth_vertices(V, F)
    v1 = V[F[:, 0]]
    return np.stack([V[F[:, 1]] - v1, V[F[:, 2]] - v1, v4 - v1], axis=2)


def deformation_gradients(rest: np.ndarray, deformed: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Affine maps taking every rest triangle (with its fourth vertex) to the deformed one.

    Parameters
    ----------
    rest, deformed : (V, 3) float ndarray
        Same topology.
    faces : (F, 3) int ndarray

    Returns
    -------
    Q : (F, 3, 3) float64 ndarray
        ``Q[f] @ (x - v1_rest) + v1_deformed`` maps triangle ``f`` of ``rest`` onto
        triangle ``f`` of ``deformed``; the identity for undeformed triangles.
    """
    R = as_vertices(rest, "deformation_gradients", name="rest")
    D = as_vertices(deformed, "deformation_gradients", name="deformed")
    if R.shape != D.shape:
        raise ValueError(f"deformation_gradients: rest {R.shape} and deformed {D.shape} differ in shape")
    return triangle_frames(D, faces) @ np.linalg.inv(triangle_frames(R, faces))


def deformation_gradient_displacements(rest: np.ndarray, deltas: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``Q - I`` for a batch of blendshapes, computed from displacements.

    Computing ``Q - I`` from the displacement of the edge frame (rather than
    ``Q`` from deformed positions, then subtracting ``I``) makes a zero displacement
    give exactly zero, so a neutral pose transfers to exactly the neutral target.

    Parameters
    ----------
    rest : (V, 3) float ndarray
    deltas : (K, V, 3) float ndarray
        Blendshape displacements from ``rest``.
    faces : (F, 3) int ndarray

    Returns
    -------
    dQ : (K, F, 3, 3) float64 ndarray
        ``Q_k - I`` per blendshape and triangle.
    """
    R = as_vertices(rest, "deformation_gradient_displacements", name="rest")
    d = np.asarray(deltas, dtype=np.float64)
    if d.ndim != 3 or d.shape[1:] != R.shape:
        raise ValueError(
            f"deformation_gradient_displacements: expected deltas of shape (K, {len(R)}, 3), got {d.shape}"
        )
    F = as_faces(faces, len(R), "deformation_gradient_displacements")
    inv_rest = np.linalg.inv(triangle_frames(R, F))
    frames_rest = triangle_frames(R, F)
    out = np.empty((len(d), len(F), 3, 3))
    for k, delta in enumerate(d):
        # frame(rest + delta) - frame(rest): exactly zero where delta is zero
        out[k] = (triangle_frames(R + delta, F) - frames_rest) @ inv_rest
    return out


def deformation_gradient_operator(vertices: np.ndarray, faces: np.ndarray) -> sp.csr_matrix:
    """Sparse linear map from unknown positions to deformation gradient entries.

    The unknowns of one coordinate are ``x = [x_vertices (V,), x_fourth (F,)]``;
    the operator returns ``(A @ x)[3 f + c] = Q_f[r, c]`` when ``x`` holds coordinate
    ``r`` of the deformed vertices and fourth vertices, ``Q_f`` the deformation
    gradient of triangle ``f`` relative to ``vertices``. The same operator applies
    to all three coordinates.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
        Rest positions.
    faces : (F, 3) int ndarray

    Returns
    -------
    A : (3 F, V + F) scipy.sparse.csr_matrix, float64
    """
    V = as_vertices(vertices, "deformation_gradient_operator")
    F = as_faces(faces, len(V), "deformation_gradient_operator")
    nv, nf = len(V), len(F)
    inv = np.linalg.inv(triangle_frames(V, F))  # (F, 3, 3); row k pairs with edge k
    cols = np.stack([F[:, 1], F[:, 2], nv + np.arange(nf), F[:, 0]], axis=1)  # (F, 4)
    # Q[r, c] = sum_k (e_k)_r inv[k, c], e_k = x_{k+1} - x_1
    coeff = np.concatenate([inv, -inv.sum(axis=1, keepdims=True)], axis=1)  # (F, 4, 3)
    rows = 3 * np.arange(nf)[:, None, None] + np.arange(3)[None, None, :]  # (F, 1, 3)
    rows = np.broadcast_to(rows, (nf, 4, 3))
    cols = np.broadcast_to(cols[:, :, None], (nf, 4, 3))
    return sp.csr_matrix((coeff.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * nf, nv + nf))
