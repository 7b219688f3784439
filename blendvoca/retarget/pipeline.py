"""ARKit-to-any-mesh retargeting: the steps put together.

The per-target work is split in two so that it can be shared:

* `correspondence_for_target` (registration + triangle and vertex correspondence)
  depends only on the two topologies and roughly on the shapes: compute it once on a
  template (the FLAME template) and pass it to every speaker of that topology;
* `plan_retarget` (alignment, crop, one sparse factorization) is per target mesh;
  `retargeted_deltas` then costs one multi-column solve for any number of shapes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from blendvoca.errors import UserError
from blendvoca.rig import Rig, shape_names

from ._checks import as_faces, as_indices, as_vertices
from .alignment import Similarity, similarity_transform
from .correspondence import VertexCorrespondence, triangle_correspondence, vertex_correspondence
from .crop import Crop, connected_pieces, crop_mesh, reattached_deltas
from .deformation_gradient import deformation_gradient_displacements
from .registration import register_source_to_target
from .transfer import TransferSystem, anchored_deltas, transfer_system, transferred_deltas


@dataclass(frozen=True)
class Correspondence:
    """Source-to-target correspondence for one pair of topologies (reusable across identities).

    Attributes
    ----------
    pairs : (P, 2) int64 ndarray
        ``(source_face, target_face)`` pairs; target faces index the cropped target.
    vertex : VertexCorrespondence
        Closest source point of every cropped target vertex (used to anchor translation).
    n_source_vertices, n_source_faces : int
    n_target_vertices, n_target_faces : int
        Sizes of the cropped target it was computed on.
    registered_source : (Vs, 3) float64 ndarray
        The source neutral deformed onto the target it was computed on (for inspection).
    """

    pairs: np.ndarray
    vertex: VertexCorrespondence
    n_source_vertices: int
    n_source_faces: int
    n_target_vertices: int
    n_target_faces: int
    registered_source: np.ndarray

    def coverage(self) -> dict[str, float]:
        """Fractions of target faces, source faces and target vertices with a partner."""
        return {
            "target_faces_paired": len(np.unique(self.pairs[:, 1])) / self.n_target_faces,
            "source_faces_paired": len(np.unique(self.pairs[:, 0])) / self.n_source_faces,
            "target_vertices_matched": float(np.mean(self.vertex.valid)),
        }


@dataclass(frozen=True)
class RetargetPlan:
    """Everything about one target that does not depend on the shapes being transferred.

    Attributes
    ----------
    similarity : Similarity
        Source-to-target landmark alignment.
    target_vertices : (V, 3) float64 ndarray
    target_faces : (F, 3) int64 ndarray
        The full target.
    crop : Crop
        The transferred region (the whole mesh when no crop was given).
    transferred : (Vc,) bool ndarray
        Cropped vertices that deform (pieces holding a landmark); the rest stay at rest.
    correspondence : Correspondence
    system : TransferSystem
        The factorized deformation-transfer system of the cropped target.
    source_neutral_aligned : (Vs, 3) float64 ndarray
    source_faces : (Fs, 3) int64 ndarray
    falloff : float
        Blend distance of removed vertices back to rest (see `reattached_deltas`).
    """

    similarity: Similarity
    target_vertices: np.ndarray
    target_faces: np.ndarray
    crop: Crop
    transferred: np.ndarray
    correspondence: Correspondence
    system: TransferSystem
    source_neutral_aligned: np.ndarray
    source_faces: np.ndarray
    falloff: float


def _checked_inputs(source_neutral, source_faces, source_landmarks, target_vertices, target_faces, target_landmarks,
                    crop, where):
    """``(Vs, Fs, lm_s, V, F, lm_t, crop, lm_c, transferred)``: the checked source and full target, the
    `Crop`, the target landmarks in the crop and the cropped vertices that deform."""
    Vs = as_vertices(source_neutral, where, name="source_neutral")
    Fs = as_faces(source_faces, len(Vs), where, name="source_faces")
    lm_s = as_indices(source_landmarks, len(Vs), where, name="source_landmarks")
    V = as_vertices(target_vertices, where, name="target_vertices")
    F = as_faces(target_faces, len(V), where, name="target_faces")
    lm = as_indices(target_landmarks, len(V), where, name="target_landmarks")
    keep = np.arange(len(V)) if crop is None else as_indices(crop, len(V), where, name="crop")
    c = crop_mesh(F, len(V), keep)
    position = np.full(len(V), -1, dtype=np.int64)
    position[c.vertex_index] = np.arange(len(c.vertex_index))
    lm_c = position[lm]
    if np.any(lm_c < 0):
        raise UserError(f"{where}: target landmarks {lm[lm_c < 0].tolist()} lie outside the crop")
    pieces = connected_pieces(c.faces, len(c.vertex_index))
    # pieces without a landmark (eyeballs of FLAME) have no known counterpart on the
    # source face mask: they are carried at rest
    transferred = np.isin(pieces, np.unique(pieces[lm_c]))
    if len(lm_s) != len(lm):
        raise UserError(f"{where}: {len(lm_s)} source landmarks but {len(lm)} target landmarks")
    return Vs, Fs, lm_s, V, F, lm, c, lm_c, transferred


def _default_max_distance(points: np.ndarray) -> float:
    """10 % of the landmarks' RMS radius: about 6 mm on a human head."""
    return 0.1 * float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))


def correspondence_for_target(source_neutral: np.ndarray, source_faces: np.ndarray, target_vertices: np.ndarray,
                              target_faces: np.ndarray, source_landmarks: np.ndarray, target_landmarks: np.ndarray, *,
                              crop: np.ndarray | None = None, max_distance: float | None = None) -> Correspondence:
    """Triangle and vertex correspondence between a source face and a (cropped) target.

    Aligns the source to the target by the landmarks, deforms it onto the target
    (markers fixed, closest valid points; `register_source_to_target`) and pairs
    compatible triangles (`triangle_correspondence`).

    Parameters
    ----------
    source_neutral : (Vs, 3) float ndarray
    source_faces : (Fs, 3) int ndarray
    target_vertices : (V, 3) float ndarray
        Full target mesh.
    target_faces : (F, 3) int ndarray
    source_landmarks : (L,) int ndarray
        Source vertex indices.
    target_landmarks : (L,) int ndarray
        Full-target vertex indices, in the same order.
    crop : (Vc,) int ndarray, optional
        Full-target vertices that take part in the transfer.
    max_distance : float, optional
        Largest distance of a closest point or a triangle pair, in the target's
        units; default 10 % of the target landmarks' RMS radius.

    Returns
    -------
    Correspondence
        Valid for any target with the same topology, crop and landmarks.
    """
    Vs, Fs, lm_s, V, _F, lm_t, c, lm_c, transferred = _checked_inputs(
        source_neutral, source_faces, source_landmarks, target_vertices, target_faces, target_landmarks, crop,
        "correspondence_for_target")
    sim = similarity_transform(Vs[lm_s], V[lm_t])
    Vc = V[c.vertex_index]
    dist = _default_max_distance(V[lm_t]) if max_distance is None else float(max_distance)
    moving_faces = c.faces[transferred[c.faces].all(axis=1)]
    registered = register_source_to_target(sim.apply(Vs), Fs, Vc, moving_faces, lm_s, Vc[lm_c], max_distance=dist)
    pairs = triangle_correspondence(registered, Fs, Vc, c.faces, dist)
    pairs = pairs[transferred[c.faces[pairs[:, 1]]].all(axis=1)]
    vc = vertex_correspondence(registered, Fs, Vc, c.faces, dist)
    vc = VertexCorrespondence(vc.source_faces, vc.barycentric, vc.valid & transferred)
    return Correspondence(pairs=pairs, vertex=vc, n_source_vertices=len(Vs), n_source_faces=len(Fs),
                          n_target_vertices=len(Vc), n_target_faces=len(c.faces), registered_source=registered)


def plan_retarget(source_neutral: np.ndarray, source_faces: np.ndarray, target_vertices: np.ndarray,
                  target_faces: np.ndarray, source_landmarks: np.ndarray, target_landmarks: np.ndarray, *,
                  crop: np.ndarray | None = None, correspondence: Correspondence | None = None,
                  max_distance: float | None = None, falloff: float = 0.02) -> RetargetPlan:
    """Align, crop, correspond (unless given) and factorize for one target.

    Parameters
    ----------
    source_neutral : (Vs, 3) float ndarray
    source_faces : (Fs, 3) int ndarray
    target_vertices : (V, 3) float ndarray
    target_faces : (F, 3) int ndarray
    source_landmarks, target_landmarks : (L,) int ndarray
        Target landmarks index the full target.
    crop : (Vc,) int ndarray, optional
        Full-target vertices that take part in the transfer; the others are
        re-attached afterwards (`reattached_deltas`).
    correspondence : Correspondence, optional
        A correspondence computed on another target of the same topology (for
        example the FLAME template for every VOCASET speaker); computed here when None.
    max_distance : float, optional
        See `correspondence_for_target`.
    falloff : float
        Distance along the mesh over which re-attached vertices blend back to rest,
        in the target's units (0 leaves them all at rest).

    Returns
    -------
    RetargetPlan
    """
    where = "plan_retarget"
    Vs, Fs, lm_s, V, F, lm_t, c, _, transferred = _checked_inputs(
        source_neutral, source_faces, source_landmarks, target_vertices, target_faces, target_landmarks, crop, where)
    if correspondence is None:
        correspondence = correspondence_for_target(Vs, Fs, V, F, lm_s, lm_t, crop=crop, max_distance=max_distance)
    else:
        expected = (len(Vs), len(Fs), len(c.vertex_index), len(c.faces))
        got = (correspondence.n_source_vertices, correspondence.n_source_faces, correspondence.n_target_vertices,
               correspondence.n_target_faces)
        if got != expected:
            raise UserError(f"{where}: the correspondence was computed for (source vertices, source faces, cropped "
                            f"target vertices, cropped target faces) = {got}, this source and target have {expected}")
    sim = similarity_transform(Vs[lm_s], V[lm_t])
    system = transfer_system(V[c.vertex_index], c.faces, correspondence.pairs, len(Fs),
                             fixed_vertices=np.flatnonzero(~transferred))
    return RetargetPlan(similarity=sim, target_vertices=V, target_faces=F, crop=c, transferred=transferred,
                        correspondence=correspondence, system=system, source_neutral_aligned=sim.apply(Vs),
                        source_faces=Fs, falloff=float(falloff))


def retargeted_deltas(plan: RetargetPlan, source_deltas: np.ndarray) -> np.ndarray:
    """Transfer source blendshape displacements onto the planned target.

    Parameters
    ----------
    plan : RetargetPlan
    source_deltas : (K, Vs, 3) float ndarray
        Displacements of the source shapes from the source neutral (source frame).

    Returns
    -------
    deltas : (K, V, 3) float64 ndarray
        Target displacements in the full target's vertex order; exactly zero for a
        zero source shape.
    """
    d = np.asarray(source_deltas, dtype=np.float64)
    Vs = plan.source_neutral_aligned
    if d.ndim != 3 or d.shape[1:] != Vs.shape:
        raise ValueError(f"retargeted_deltas: expected source deltas of shape (K, {len(Vs)}, 3), got {d.shape}")
    aligned = plan.similarity.apply_vectors(d)
    dQ = deformation_gradient_displacements(Vs, aligned, plan.source_faces)
    cropped = transferred_deltas(plan.system, dQ)
    reference = plan.correspondence.vertex.interpolate(aligned, plan.source_faces)
    cropped = anchored_deltas(cropped, plan.system.pieces, reference, plan.correspondence.vertex.valid.astype(float))
    return reattached_deltas(cropped, plan.crop.vertex_index, plan.target_vertices, plan.target_faces,
                             falloff=plan.falloff)


def retarget_rig(source: Rig, target_vertices: np.ndarray, target_faces: np.ndarray, source_landmarks: np.ndarray,
                 target_landmarks: np.ndarray, *, crop: np.ndarray | None = None,
                 shapes: str | Sequence[str] = "speech", correspondence: Correspondence | None = None,
                 max_distance: float | None = None, falloff: float = 0.02) -> Rig:
    """Give a target mesh the source rig's blendshapes by deformation transfer.

    Parameters
    ----------
    source : Rig
        Source rig (the ARKit reference rig).
    target_vertices : (V, 3) float ndarray
        Target neutral, any topology; becomes the output rig's neutral unchanged.
    target_faces : (F, 3) int ndarray
    source_landmarks : (L,) int ndarray
        Source vertex indices.
    target_landmarks : (L,) int ndarray
        Full-target vertex indices of the same landmarks.
    crop : (Vc,) int ndarray, optional
        Full-target vertices that take part in the transfer (FLAME: ``flame-head-idx``).
    shapes : "speech", "all" or sequence of str
        The 32 BlendVOCA shapes in BlendVOCA order, all 51 ARKit shapes of the
        reference rig, or explicit names; each must be in ``source``.
    correspondence : Correspondence, optional
        Precomputed by `correspondence_for_target` on a target of the same topology.
    max_distance : float, optional
        See `correspondence_for_target`.
    falloff : float
        See `plan_retarget`.

    Returns
    -------
    Rig
        ``neutral == target_vertices``, ``faces == target_faces``, one displacement
        per name.
    """
    if not isinstance(source, Rig):
        raise TypeError(f"retarget_rig: expected a blendvoca.rig.Rig as source, got {type(source).__name__}")
    names = shape_names(shapes)
    missing = [n for n in names if n not in source.names]
    if missing:
        raise UserError(f"retarget_rig: the source rig has no shapes {missing}")
    src = source.select(names)
    plan = plan_retarget(src.neutral, src.faces, target_vertices, target_faces, source_landmarks, target_landmarks,
                         crop=crop, correspondence=correspondence, max_distance=max_distance, falloff=falloff)
    return Rig(plan.target_vertices, retargeted_deltas(plan, src.deltas), tuple(names), plan.target_faces)
