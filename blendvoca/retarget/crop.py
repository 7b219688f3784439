"""Cropping a target mesh to the region that takes part in the transfer, and re-attaching."""

from __future__ import annotations

from dataclasses import dataclass

import igl
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra

from blendvoca import assets
from blendvoca.errors import UserError
from blendvoca.io.mesh import read_ply

from ._checks import as_faces, as_indices, as_vertices


@dataclass(frozen=True)
class Crop:
    """A sub-mesh of a target mesh.

    Attributes
    ----------
    vertex_index : (Vc,) int64 ndarray
        Indices into the full mesh of the kept vertices, in cropped order.
    faces : (Fc, 3) int64 ndarray
        Faces of the full mesh whose three vertices are kept, re-indexed into the crop.
    face_index : (Fc,) int64 ndarray
        Index of each cropped face in the full mesh's faces.
    seam : (S,) int64 ndarray
        Cropped-vertex indices that share a face with a removed vertex.
    """

    vertex_index: np.ndarray
    faces: np.ndarray
    face_index: np.ndarray
    seam: np.ndarray


def crop_mesh(faces: np.ndarray, n_vertices: int, keep: np.ndarray) -> Crop:
    """The sub-mesh spanned by the vertices ``keep``.

    Parameters
    ----------
    faces : (F, 3) int ndarray
        Faces of the full mesh.
    n_vertices : int
        Vertex count of the full mesh.
    keep : (Vc,) int ndarray
        Vertex indices to keep, in the order the crop uses; no duplicates.

    Returns
    -------
    Crop
    """
    F = as_faces(faces, n_vertices, "crop_mesh")
    idx = as_indices(keep, n_vertices, "crop_mesh", name="keep")
    if len(np.unique(idx)) != len(idx):
        raise UserError("crop_mesh: keep lists some vertex more than once")
    remap = np.full(n_vertices, -1, dtype=np.int64)
    remap[idx] = np.arange(len(idx))
    inside = remap[F] >= 0
    kept = inside.all(axis=1)
    touching = inside.any(axis=1) & ~kept
    seam_full = np.unique(F[touching][inside[touching]])
    return Crop(vertex_index=idx, faces=remap[F[kept]], face_index=np.flatnonzero(kept).astype(np.int64),
                seam=np.sort(remap[seam_full]))


def connected_pieces(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """Label of the connected piece (through shared vertices) of every vertex.

    Parameters
    ----------
    faces : (F, 3) int ndarray
    n_vertices : int

    Returns
    -------
    labels : (V,) int64 ndarray
        Pieces numbered from 0 by decreasing vertex count; vertices used by no face
        form their own single-vertex pieces.
    """
    F = as_faces(faces, n_vertices, "connected_pieces")
    i = F.ravel()
    j = np.roll(F, 1, axis=1).ravel()
    graph = sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(n_vertices, n_vertices))
    _, labels = connected_components(graph, directed=False)
    counts = np.bincount(labels)
    order = np.argsort(-counts, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[labels].astype(np.int64)


def reattach_deltas(deltas_cropped: np.ndarray, vertex_index: np.ndarray, n_vertices: int) -> np.ndarray:
    """Full-topology blendshape displacements with every removed vertex left at rest.

    Parameters
    ----------
    deltas_cropped : (K, Vc, 3) float ndarray
        Displacements of the cropped vertices.
    vertex_index : (Vc,) int ndarray
        Full-mesh index of each cropped vertex.
    n_vertices : int
        Vertex count of the full mesh.

    Returns
    -------
    deltas : (K, V, 3) float64 ndarray
        ``deltas[:, vertex_index] == deltas_cropped``, zero elsewhere.
    """
    d = np.asarray(deltas_cropped, dtype=np.float64)
    idx = as_indices(vertex_index, n_vertices, "reattach_deltas", name="vertex_index")
    if d.ndim != 3 or d.shape[1:] != (len(idx), 3):
        raise ValueError(f"reattach_deltas: expected deltas_cropped of shape (K, {len(idx)}, 3), got {d.shape}")
    out = np.zeros((len(d), n_vertices, 3))
    out[:, idx] = d
    return out


def seam_distances(vertices: np.ndarray, faces: np.ndarray, vertex_index: np.ndarray) -> np.ndarray:
    """Shortest distance along the mesh's edges from the crop to every removed vertex.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
        Full mesh.
    faces : (F, 3) int ndarray
        Full mesh.
    vertex_index : (Vc,) int ndarray
        Kept (cropped) vertices.

    Returns
    -------
    distance : (V,) float64 ndarray
        0 on kept vertices; for a removed vertex the length of the shortest edge
        path to a kept vertex that runs through removed vertices only; ``inf`` when
        there is none (a removed piece that never touches the crop).
    """
    V = as_vertices(vertices, "seam_distances")
    F = as_faces(faces, len(V), "seam_distances")
    idx = as_indices(vertex_index, len(V), "seam_distances", name="vertex_index")
    kept = np.zeros(len(V), dtype=bool)
    kept[idx] = True
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    e = e[~(kept[e[:, 0]] & kept[e[:, 1]])]  # paths run through removed vertices
    length = np.linalg.norm(V[e[:, 0]] - V[e[:, 1]], axis=1)
    # one super-source joined to every kept vertex at zero length (stored as tiny
    # positive, since csgraph drops explicit zeros)
    n = len(V)
    src = np.full(len(idx), n)
    rows = np.concatenate([e[:, 0], e[:, 1], src])
    cols = np.concatenate([e[:, 1], e[:, 0], idx])
    w = np.concatenate([length, length, np.full(len(idx), 1e-300)])
    graph = sp.csr_matrix((w, (rows, cols)), shape=(n + 1, n + 1))
    dist = dijkstra(graph, directed=True, indices=n)[:n]
    dist[kept] = 0.0
    return dist


def reattached_deltas(
    deltas_cropped: np.ndarray,
    vertex_index: np.ndarray,
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    falloff: float = 0.02,
) -> np.ndarray:
    """Full-topology displacements: removed vertices near the crop follow it smoothly.

    Removed vertices farther than ``falloff`` (along the mesh) from the crop stay at
    rest; nearer ones take the harmonic (cotangent Laplace) interpolation between the
    crop's displacements and rest, so a lip's inner surface or the neck below a
    moving jaw bends along instead of tearing at the seam. ``falloff=0`` leaves
    every removed vertex at rest (`reattach_deltas`).

    Parameters
    ----------
    deltas_cropped, vertex_index
        As in `reattach_deltas`.
    vertices : (V, 3) float ndarray
        Full mesh rest shape.
    faces : (F, 3) int ndarray
        Full mesh.
    falloff : float
        Distance along the mesh over which removed vertices blend to rest, in the
        mesh's units.

    Returns
    -------
    deltas : (K, V, 3) float64 ndarray
        ``deltas[:, vertex_index] == deltas_cropped``.
    """
    V = as_vertices(vertices, "reattached_deltas")
    F = as_faces(faces, len(V), "reattached_deltas")
    if not np.isfinite(falloff) or falloff < 0:
        raise UserError(f"reattached_deltas: expected a non-negative finite falloff, got {falloff}")
    full = reattach_deltas(deltas_cropped, vertex_index, len(V))
    if falloff == 0 or len(full) == 0:
        return full
    dist = seam_distances(V, F, vertex_index)
    free = (dist > 0) & (dist < falloff)
    if not free.any():
        return full
    L = igl.cotmatrix(V, F)
    known = np.flatnonzero(~free).astype(np.int64)
    K = full.shape[0]
    Y = full[:, known].transpose(1, 0, 2).reshape(len(known), 3 * K)
    B = np.zeros((len(V), 3 * K))
    Z = igl.min_quad_with_fixed((-L).tocsc(), B, known, np.ascontiguousarray(Y), sp.csc_matrix((0, len(V))),
                                np.zeros((0, 3 * K)), True)
    return Z.reshape(len(V), K, 3).transpose(1, 0, 2).copy()


FLAME_VERTEX_COUNT = 5023
FLAME_FACE_COUNT = 9976


def is_flame_topology(faces: np.ndarray, n_vertices: int) -> bool:
    """Whether a mesh has FLAME's topology: 5023 vertices and the triangles of the
    FLAME sample mesh (asset ``flame-sample``), in any order and winding.

    With the asset absent, the vertex and face counts alone decide.
    """
    faces = np.asarray(faces, dtype=np.int64)
    if n_vertices != FLAME_VERTEX_COUNT or faces.shape != (FLAME_FACE_COUNT, 3):
        return False
    try:
        reference = read_ply(assets.resolve("flame-sample", download_missing=False))[1]
    except (assets.AssetError, FileNotFoundError, OSError):
        return True
    key = lambda f: np.unique(np.sort(f, axis=1), axis=0)  # noqa: E731 - a one-line helper
    return reference.shape == faces.shape and np.array_equal(key(reference), key(faces))


def default_crop(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray | None, str | None]:
    """The crop to use when none is given, and a note saying what was chosen.

    A FLAME-topology target gets FLAME's head crop (asset ``flame-head-idx``: face,
    scalp and ears without the neck and eyeballs), so jaw shapes do not drag the neck.

    Returns
    -------
    keep : (N,) int64 ndarray or None (no crop: the whole mesh takes part)
    note : str or None, a line for the user
    """
    if not is_flame_topology(faces, n_vertices):
        return None, None
    try:
        keep = assets.load_index_list("flame-head-idx")
    except (assets.AssetError, FileNotFoundError, OSError) as error:
        return None, ("warning: the target has FLAME's topology but the FLAME head crop (asset flame-head-idx) "
                      f"is unavailable ({error}); jaw shapes will drag the neck. Pass --crop FLAME_head_idx.txt "
                      "(python -m blendvoca.assets fetch flame-head-idx)")
    return keep, (f"note: the target has FLAME's topology: using the FLAME head crop ({len(keep)} of "
                  f"{n_vertices} vertices, asset flame-head-idx); pass --crop to choose another")
