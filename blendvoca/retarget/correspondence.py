"""Triangle and vertex correspondence between a registered source and the target."""

from __future__ import annotations

from dataclasses import dataclass

import igl
import numpy as np

from blendvoca.errors import UserError

from ._checks import as_faces, as_vertices
from .registration import face_normals, vertex_normals


@dataclass(frozen=True)
class VertexCorrespondence:
    """Where each target vertex lies on the (registered) source surface.

    Attributes
    ----------
    source_faces : (Vt,) int64 ndarray
        Source face holding the closest point of each target vertex.
    barycentric : (Vt, 3) float64 ndarray
        Barycentric coordinates of that point in the source face.
    valid : (Vt,) bool ndarray
        The closest point is near enough, faces the same way and is not on the
        source's boundary.
    """

    source_faces: np.ndarray
    barycentric: np.ndarray
    valid: np.ndarray

    def interpolate(self, values: np.ndarray, faces: np.ndarray) -> np.ndarray:
        """Interpolate per-source-vertex ``values (..., Vs, C)`` at the target vertices -> ``(..., Vt, C)``."""
        corner = faces[self.source_faces]  # (Vt, 3)
        v = np.asarray(values)
        return np.einsum("...ijc,ij->...ic", v[..., corner, :], self.barycentric)


def _checked_meshes(deformed_source_vertices, source_faces, target_vertices, target_faces, where):
    """``(Vs, Fs, Vt, Ft)``: the registered source and the target of a correspondence, checked."""
    Vs = as_vertices(deformed_source_vertices, where, name="deformed_source_vertices")
    Fs = as_faces(source_faces, len(Vs), where, name="source_faces")
    Vt = as_vertices(target_vertices, where, name="target_vertices")
    return Vs, Fs, Vt, as_faces(target_faces, len(Vt), where, name="target_faces")


def triangle_correspondence(deformed_source_vertices: np.ndarray, source_faces: np.ndarray, target_vertices: np.ndarray,
                            target_faces: np.ndarray, max_distance: float) -> np.ndarray:
    """Compatible triangle pairs between the registered source and the target.

    Each target triangle is paired with the source triangle holding the closest
    point of the source surface to its centroid, and each source triangle likewise
    with a target triangle; a pair is kept when that point is within
    ``max_distance`` and the two normals are less than 90 degrees apart (Sumner and
    Popovic 2004, section 5). Closest points on the surface, rather than nearest
    centroids, pair a triangle with the one it lies on even where the two meshes'
    triangles differ much in size (a subdivided copy pairs every child with its parent).

    Parameters
    ----------
    deformed_source_vertices : (Vs, 3) float ndarray
        Source vertices after `register_source_to_target`.
    source_faces : (Fs, 3) int ndarray
    target_vertices : (Vt, 3) float ndarray
    target_faces : (Ft, 3) int ndarray
    max_distance : float
        Largest centroid-to-surface distance of a pair, in the meshes' units.

    Returns
    -------
    pairs : (P, 2) int64 ndarray
        ``(source_face, target_face)`` rows, unique, sorted by target face.
    """
    where = "triangle_correspondence"
    Vs, Fs, Vt, Ft = _checked_meshes(deformed_source_vertices, source_faces, target_vertices, target_faces, where)
    if not max_distance > 0:
        raise UserError(f"{where}: expected a positive max_distance, got {max_distance}")
    cs, ct = Vs[Fs].mean(axis=1), Vt[Ft].mean(axis=1)
    ns, nt = face_normals(Vs, Fs), face_normals(Vt, Ft)

    def onto(query_c, query_n, V, F, normals):
        sq, face, _ = igl.point_mesh_squared_distance(np.ascontiguousarray(query_c), V, F)
        face = face.astype(np.int64)
        ok = (sq <= max_distance**2) & (np.einsum("ij,ij->i", normals[face], query_n) > 0.0)
        return np.flatnonzero(ok), face[ok]

    t_idx, s_of_t = onto(ct, nt, Vs, Fs, ns)
    s_idx, t_of_s = onto(cs, ns, Vt, Ft, nt)
    pairs = np.concatenate([np.stack([s_of_t, t_idx], 1), np.stack([s_idx, t_of_s], 1)]).astype(np.int64)
    pairs = np.unique(pairs.reshape(-1, 2), axis=0)
    return pairs[np.lexsort((pairs[:, 0], pairs[:, 1]))]


def vertex_correspondence(deformed_source_vertices: np.ndarray, source_faces: np.ndarray, target_vertices: np.ndarray,
                          target_faces: np.ndarray, max_distance: float) -> VertexCorrespondence:
    """Closest point on the registered source surface for every target vertex.

    Parameters
    ----------
    deformed_source_vertices, source_faces, target_vertices, target_faces, max_distance
        As in `triangle_correspondence`; ``target_faces`` give the target's vertex
        normals (vertices in no face are never valid).

    Returns
    -------
    VertexCorrespondence
    """
    Vs, Fs, Vt, Ft = _checked_meshes(deformed_source_vertices, source_faces, target_vertices, target_faces,
                                     "vertex_correspondence")
    sq, face, closest = igl.point_mesh_squared_distance(Vt, Vs, Fs)
    face = face.astype(np.int64)
    a, b, c = (np.ascontiguousarray(Vs[Fs[face, k]]) for k in range(3))
    bary = igl.barycentric_coordinates(np.ascontiguousarray(closest), a, b, c)
    bary = np.clip(np.asarray(bary, dtype=np.float64), 0.0, 1.0)
    bary /= bary.sum(axis=1, keepdims=True)
    facing = np.einsum("ij,ij->i", vertex_normals(Vt, Ft), face_normals(Vs, Fs)[face]) > 0.0
    # a closest point on the source's open boundary means the target vertex lies
    # beyond the source surface: no correspondence there
    edges = igl.boundary_facets(Fs)
    edges = np.asarray(edges[0] if isinstance(edges, tuple) else edges, dtype=np.int64)
    n = len(Vs)
    boundary_keys = np.sort(edges, axis=1) @ np.array([n, 1], dtype=np.int64)
    on_edge = np.zeros(len(Vt), dtype=bool)
    for k in range(3):
        # the closest point sits on the edge opposite corner k when that weight vanishes
        j, l = Fs[face, (k + 1) % 3], Fs[face, (k + 2) % 3]
        keys = np.minimum(j, l) * n + np.maximum(j, l)
        on_edge |= (bary[:, k] < 1e-9) & np.isin(keys, boundary_keys)
    valid = (sq <= max_distance**2) & facing & ~on_edge
    return VertexCorrespondence(source_faces=face, barycentric=bary, valid=valid)
