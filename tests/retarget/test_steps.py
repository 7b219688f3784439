"""Ground-truth tests of the single retargeting steps (closed forms, round trips)."""

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from blendvoca.retarget import (
    anchored_deltas,
    connected_pieces,
    crop_mesh,
    deformation_gradient_displacements,
    deformation_gradient_operator,
    deformation_gradients,
    fourth_vertices,
    reattach_deltas,
    reattached_deltas,
    similarity_transform,
    transfer_system,
    transferred_deltas,
)
from blendvoca.retarget.contact_sheet import rasterise_front
from blendvoca.retarget.registration import face_adjacency_pairs
from blendvoca.retarget.report import mirror_vertex_map


def sphere(subdivisions=2):
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


def test_similarity_recovers_known_transform():
    rng = np.random.default_rng(0)
    P = rng.normal(size=(68, 3))
    R = Rotation.from_rotvec([0.3, -0.5, 0.9]).as_matrix()
    Q = 1.7 * P @ R.T + np.array([0.1, -2.0, 3.0])
    S = similarity_transform(P, Q)
    assert S.scale == pytest.approx(1.7, rel=1e-12)
    np.testing.assert_allclose(S.rotation, R, atol=1e-12)
    np.testing.assert_allclose(S.translation, [0.1, -2.0, 3.0], atol=1e-12)
    assert S.max_residual < 1e-12
    np.testing.assert_allclose(S.apply(P), Q, atol=1e-12)


def test_similarity_never_reflects_and_reports_residual():
    rng = np.random.default_rng(1)
    P = rng.normal(size=(20, 3))
    Q = P * np.array([-1.0, 1.0, 1.0])  # a mirror image: best proper rotation leaves residuals
    S = similarity_transform(P, Q)
    assert np.linalg.det(S.rotation) == pytest.approx(1.0)
    assert S.rms_residual > 0.1
    np.testing.assert_allclose(S.residuals, np.linalg.norm(S.apply(P) - Q, axis=1))


def test_similarity_rejects_bad_input():
    with pytest.raises(ValueError, match="pair up"):
        similarity_transform(np.zeros((5, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="collinear"):
        similarity_transform(np.outer(np.arange(5.0), [1, 0, 0]), np.outer(np.arange(5.0), [0, 1, 0]))


def test_deformation_gradient_of_affine_map_is_its_matrix():
    V, F = sphere(1)
    M = np.array([[1.2, 0.1, 0.0], [0.0, 0.9, 0.3], [0.2, 0.0, 1.1]])
    # the fourth vertex follows the normal, so only a similarity is reproduced exactly
    R = 1.3 * Rotation.from_rotvec([0.2, 0.1, -0.4]).as_matrix()
    Q = deformation_gradients(V, V @ R.T + 1.0, F)
    np.testing.assert_allclose(Q, np.broadcast_to(R, Q.shape), atol=1e-12)
    # the operator agrees with the direct computation for any deformation
    D = V @ M.T + 0.05 * np.sin(5 * V)
    A = deformation_gradient_operator(V, F)
    x = np.vstack([D, fourth_vertices(D, F)])
    direct = deformation_gradients(V, D, F)
    for r in range(3):
        np.testing.assert_allclose((A @ x[:, r]).reshape(-1, 3), direct[:, r, :], atol=1e-10)


def test_zero_deltas_give_exactly_zero_gradients():
    V, F = sphere(1)
    dQ = deformation_gradient_displacements(V, np.zeros((2, *V.shape)), F)
    assert np.all(dQ == 0.0)


def test_transfer_onto_itself_reproduces_shapes_up_to_translation():
    V, F = sphere(2)
    rng = np.random.default_rng(2)
    deltas = np.stack([0.1 * np.sin(3 * V + rng.normal(size=3)) for _ in range(3)])
    pairs = np.stack([np.arange(len(F)), np.arange(len(F))], axis=1)
    system = transfer_system(V, F, pairs, len(F))
    dQ = deformation_gradient_displacements(V, deltas, F)
    out = transferred_deltas(system, dQ)
    # unique up to a translation per piece: anchor with the truth itself
    out = anchored_deltas(out, system.pieces, deltas, np.ones(len(V)))
    np.testing.assert_allclose(out, deltas, atol=1e-9)
    assert np.all(transferred_deltas(system, np.zeros_like(dQ)) == 0.0)


def test_fixed_vertices_stay_put_and_pieces_are_anchored():
    V1, F1 = sphere(1)
    V = np.vstack([V1, V1 + [5.0, 0, 0]])
    F = np.vstack([F1, F1 + len(V1)])
    labels = connected_pieces(F, len(V))
    assert np.bincount(labels).tolist() == [len(V1), len(V1)]
    pairs = np.stack([np.arange(len(F)), np.arange(len(F))], axis=1)
    fixed = np.flatnonzero(labels == 1)
    system = transfer_system(V, F, pairs, len(F), fixed_vertices=fixed)
    assert np.all(system.pieces[fixed] == -1) and np.all(system.pieces[labels == 0] == 0)
    shift = np.zeros((1, *V.shape))
    shift[0, labels == 0] = V[labels == 0] * 0.2  # scale the first sphere by 1.2
    out = transferred_deltas(system, deformation_gradient_displacements(V, shift, F))
    assert np.all(out[0, fixed] == 0.0)
    out = anchored_deltas(out, system.pieces, shift, (labels == 0).astype(float))
    np.testing.assert_allclose(out, shift, atol=1e-9)


def test_crop_and_reattach_round_trip():
    V, F = sphere(2)
    keep = np.flatnonzero(V[:, 2] > -0.3)[::-1].copy()  # any order
    c = crop_mesh(F, len(V), keep)
    np.testing.assert_array_equal(c.vertex_index, keep)
    np.testing.assert_array_equal(keep[c.faces], F[c.face_index])
    assert np.isin(c.face_index, np.flatnonzero(np.isin(F, keep).all(axis=1))).all()
    # seam vertices share a face with a removed vertex
    removed = ~np.isin(np.arange(len(V)), keep)
    touching = np.unique(F[removed[F].any(axis=1)])
    np.testing.assert_array_equal(np.sort(keep[c.seam]), np.intersect1d(touching, keep))
    d = np.random.default_rng(3).normal(size=(2, len(keep), 3))
    full = reattach_deltas(d, keep, len(V))
    np.testing.assert_array_equal(full[:, keep], d)
    assert np.all(full[:, removed] == 0)
    smooth = reattached_deltas(d, keep, V, F, falloff=1.2)
    np.testing.assert_array_equal(smooth[:, keep], d)
    assert np.abs(smooth[:, removed]).max() > 0  # removed vertices near the seam follow
    np.testing.assert_array_equal(reattached_deltas(d, keep, V, F, falloff=0.0), full)


def test_face_adjacency_pairs_of_closed_mesh():
    _V, F = sphere(1)
    pairs = face_adjacency_pairs(F)
    assert len(pairs) == 3 * len(F) // 2  # every edge of a closed mesh joins two faces


def test_rasteriser_fills_a_known_triangle():
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    F = np.array([[0, 1, 2]])
    img = rasterise_front(V, F, np.array([[1.0, 0.0, 0.0]]), (0, 1, 0, 1), (100, 100))
    red = (img[:, :, 0] == 1) & (img[:, :, 1] == 0)
    assert red.sum() == pytest.approx(5000, rel=0.03)  # half the square
    assert red[90, 5] and not red[5, 90]  # lower-left half (y up)
    back = rasterise_front(V, F[:, ::-1], np.array([[1.0, 0.0, 0.0]]), (0, 1, 0, 1), (100, 100))
    assert np.all(back == 1.0)  # back faces are culled


def test_mirror_map_of_symmetric_mesh_is_an_involution():
    V, F = sphere(2)
    partner, gap = mirror_vertex_map(V, F, 0.0)
    assert gap.max() < 1e-12
    np.testing.assert_array_equal(partner[partner], np.arange(len(V)))
    np.testing.assert_allclose(V[partner] * [-1, 1, 1], V, atol=1e-12)
