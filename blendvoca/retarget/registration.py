"""Non-rigid registration of the source mesh onto the target (Sumner and Popovic 2004, section 5).

The source surface is deformed, with markers held exactly on their target
positions, by minimising

    w_s E_smooth + w_i E_identity + w_c E_closest

over the deformed vertices and the per-triangle fourth vertices. ``E_smooth`` sums
``||Q_i - Q_j||^2`` over triangles sharing an edge, ``E_identity`` sums
``||Q_i - I||^2`` and ``E_closest`` sums the squared distance of every vertex to its
closest valid point on the target (closer than a threshold, normals less than 90
degrees apart). ``w_c`` grows over the iterations. Every coordinate shares one
normal matrix, so each iteration is one sparse factorization and a 3-column solve.
"""

from __future__ import annotations

from collections.abc import Sequence

import igl
import numpy as np
import scipy.sparse as sp

from blendvoca.errors import UserError

from ._checks import as_faces, as_indices, as_vertices
from .deformation_gradient import deformation_gradient_operator, fourth_vertices

DEFAULT_CLOSEST_WEIGHTS: tuple[float, ...] = (1.0, 10.0, 100.0, 1000.0, 5000.0)


def face_adjacency_pairs(faces: np.ndarray) -> np.ndarray:
    """Pairs of faces sharing an edge.

    Parameters
    ----------
    faces : (F, 3) int ndarray

    Returns
    -------
    pairs : (P, 2) int64 ndarray
        ``pairs[:, 0] < pairs[:, 1]``; every interior manifold edge gives one pair.
    """
    F = np.asarray(faces, dtype=np.int64)
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    owner = np.tile(np.arange(len(F)), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    e, o = edges[order], owner[order]
    same = np.all(e[1:] == e[:-1], axis=1)
    pairs = np.stack([o[:-1][same], o[1:][same]], axis=1)
    return np.unique(np.sort(pairs, axis=1), axis=0)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals, ``(V, 3)`` float64 (zero for unused vertices)."""
    n = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    out = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(out, faces[:, k], n)
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, length, out=np.zeros_like(out), where=length > 0)


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit face normals, ``(F, 3)`` float64."""
    n = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def closest_valid_points(
    points: np.ndarray,
    normals: np.ndarray,
    target_vertices: np.ndarray,
    target_faces: np.ndarray,
    max_distance: float,
    *,
    target_face_normals: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Closest point on the target surface, kept when near and facing the same way.

    Parameters
    ----------
    points, normals : (N, 3) float ndarray
        Query points and their unit normals.
    target_vertices : (V, 3) float ndarray
    target_faces : (F, 3) int ndarray
    max_distance : float
        Farther closest points are rejected.
    target_face_normals : (F, 3) float ndarray, optional
        Precomputed unit face normals of the target.

    Returns
    -------
    closest : (N, 3) float64 ndarray
        Closest point on the target for every query.
    valid : (N,) bool ndarray
        Closer than ``max_distance`` and with normals less than 90 degrees apart.
    """
    sq, face, closest = igl.point_mesh_squared_distance(np.ascontiguousarray(points), target_vertices, target_faces)
    fn = face_normals(target_vertices, target_faces) if target_face_normals is None else target_face_normals
    valid = (sq <= max_distance**2) & (np.einsum("ij,ij->i", normals, fn[face]) > 0.0)
    return closest, valid


def register_source_to_target(
    source_vertices: np.ndarray,
    source_faces: np.ndarray,
    target_vertices: np.ndarray,
    target_faces: np.ndarray,
    source_markers: np.ndarray,
    target_marker_positions: np.ndarray,
    *,
    smoothness_weight: float = 1.0,
    identity_weight: float = 0.001,
    closest_weights: Sequence[float] = DEFAULT_CLOSEST_WEIGHTS,
    iterations_per_weight: int = 2,
    max_distance: float | None = None,
) -> np.ndarray:
    """Deform the source surface onto the target, markers fixed (Sumner and Popovic, section 5).

    Parameters
    ----------
    source_vertices : (Vs, 3) float ndarray
        Source rest vertices, already aligned with the target (see
        `similarity_transform`).
    source_faces : (Fs, 3) int ndarray
    target_vertices : (Vt, 3) float ndarray
    target_faces : (Ft, 3) int ndarray
    source_markers : (M,) int ndarray
        Source vertex indices held fixed at ``target_marker_positions``.
    target_marker_positions : (M, 3) float ndarray
    smoothness_weight, identity_weight : float
        ``w_s`` and ``w_i`` (the paper's 1.0 and 0.001).
    closest_weights : sequence of float
        ``w_c`` of each stage after the first marker-only solve (the paper: 1 to 5000).
        Positions are rescaled internally so that the markers have unit RMS radius,
        which makes these weights independent of the mesh's units.
    iterations_per_weight : int
        Closest-point searches (and solves) per value of ``w_c``.
    max_distance : float, optional
        Closest points farther than this are not valid; defaults to 10 % of the
        markers' RMS radius.

    Returns
    -------
    deformed : (Vs, 3) float64 ndarray
        The deformed source vertices; ``deformed[source_markers]`` equals
        ``target_marker_positions``.
    """
    where = "register_source_to_target"
    Vs = as_vertices(source_vertices, where, name="source_vertices")
    Fs = as_faces(source_faces, len(Vs), where, name="source_faces")
    Vt = as_vertices(target_vertices, where, name="target_vertices")
    Ft = as_faces(target_faces, len(Vt), where, name="target_faces")
    markers = as_indices(source_markers, len(Vs), where, name="source_markers")
    goal = as_vertices(target_marker_positions, where, name="target_marker_positions")
    if len(goal) != len(markers):
        raise UserError(f"{where}: {len(markers)} source markers but {len(goal)} target marker positions")
    if len(np.unique(markers)) != len(markers):
        raise UserError(f"{where}: source_markers lists some vertex more than once")

    # work in a unit-size frame so the weights do not depend on the units
    centre = goal.mean(axis=0)
    radius = float(np.sqrt(np.mean(np.sum((goal - centre) ** 2, axis=1))))
    if radius <= 0:
        raise UserError(f"{where}: target markers coincide; cannot set a scale")
    Vs_n, Vt_n, goal_n = (Vs - centre) / radius, (Vt - centre) / radius, (goal - centre) / radius
    threshold = 0.1 if max_distance is None else max_distance / radius

    nv, nf = len(Vs), len(Fs)
    n = nv + nf
    A = deformation_gradient_operator(Vs_n, Fs).tocsr()
    adj = face_adjacency_pairs(Fs)
    rows = np.arange(3 * len(adj))
    columns = np.concatenate([(3 * adj[:, [0]] + np.arange(3)).ravel(), (3 * adj[:, [1]] + np.arange(3)).ravel()])
    sel = sp.csr_matrix((np.concatenate([np.ones(3 * len(adj)), -np.ones(3 * len(adj))]),
                         (np.concatenate([rows, rows]), columns)), shape=(3 * len(adj), 3 * nf))
    Ds = sel @ A
    base = smoothness_weight * (Ds.T @ Ds) + identity_weight * (A.T @ A)
    identity = np.tile(np.eye(3), (nf, 1))  # (3F, 3): column r = coordinate r of Q = I
    base_rhs = identity_weight * (A.T @ identity)

    fixed = np.zeros(n, dtype=bool)
    fixed[markers] = True
    fixed_idx = np.flatnonzero(fixed).astype(np.int64)
    x = np.vstack([Vs_n, fourth_vertices(Vs_n, Fs)])
    x[markers] = goal_n
    tgt_fn = face_normals(Vt_n, Ft)

    def solve(wc: float) -> np.ndarray:
        M, rhs = base, base_rhs
        if wc > 0:
            closest, valid = closest_valid_points(x[:nv], vertex_normals(x[:nv], Fs), Vt_n, Ft, threshold,
                                                  target_face_normals=tgt_fn)
            w = np.zeros(n)
            w[:nv] = wc * valid
            M = M + sp.diags(w)
            rhs = rhs + w[:, None] * np.vstack([closest, np.zeros((nf, 3))])
        # libigl: sparse Cholesky with the markers eliminated (Eigen), faster than SuperLU
        return igl.min_quad_with_fixed(M.tocsc(), np.ascontiguousarray(-rhs), fixed_idx, np.ascontiguousarray(
            x[fixed_idx]), sp.csc_matrix((0, n)), np.zeros((0, 3)), True)

    x = solve(0.0)
    for wc in closest_weights:
        for _ in range(max(1, iterations_per_weight)):
            x = solve(float(wc))
    return x[:nv] * radius + centre
