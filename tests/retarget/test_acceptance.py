"""Acceptance tests: self-transfer onto a remeshed, moved copy and the FLAME template."""

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from blendvoca.assets import load_index_list, resolve
from blendvoca.io.mesh import read_mesh
from blendvoca.names import BLENDVOCA_NAMES, MIRROR_PAIRS
from blendvoca.retarget import (
    correspondence_for_target,
    retarget_report,
    retarget_rig,
    seam_distances,
)
from blendvoca.retarget.report import LANDMARK_REGIONS, flipped_faces
from blendvoca.rig import load_arkit_reference

# figures reached (see docs/retarget.md); the tests allow a margin above them
SELF_TRANSFER_TOLERANCE = 1e-9  # of each shape's largest displacement (measured: 1e-13)
MIRROR_RMS_TOLERANCE = 0.25  # FLAME_sample itself is asymmetric by ~1 mm


@pytest.fixture(scope="module")
def source(assets_dir):
    return load_arkit_reference("all")


@pytest.fixture(scope="module")
def self_transfer(source):
    """The ARKit rig onto its own neutral, subdivided (new topology) and moved by a similarity."""
    V, F = trimesh.remesh.subdivide(source.neutral, source.faces)
    # subdivide keeps the original vertices first, in order, and appends edge midpoints
    np.testing.assert_array_equal(V[: source.num_vertices], source.neutral)
    R = Rotation.from_rotvec([0.4, -0.3, 0.2]).as_matrix()
    s, t = 2.5, np.array([0.3, -1.0, 0.7])
    target = s * V @ R.T + t
    landmarks = load_index_list("arkit-landmarks")
    rig = retarget_rig(source, target, F, landmarks, landmarks, shapes="all")
    # ground truth: each original shape subdivided the same way and moved by the similarity
    truth = []
    for delta in source.deltas:
        Vd, _ = trimesh.remesh.subdivide(source.neutral + delta, source.faces)
        truth.append(s * (Vd - V) @ R.T)
    return rig, np.array(truth), target, F


def test_self_transfer_reproduces_the_moved_shapes(self_transfer):
    rig, truth, target, F = self_transfer
    np.testing.assert_array_equal(rig.neutral, target)
    np.testing.assert_array_equal(rig.faces, F)
    err = np.linalg.norm(rig.deltas - truth, axis=2).max(axis=1)
    scale = np.linalg.norm(truth, axis=2).max(axis=1)
    relative = err / scale
    # each child triangle pairs with its parent, whose gradient it shares: exact up to round-off
    assert relative.max() < SELF_TRANSFER_TOLERANCE, dict(zip(rig.names, relative.round(4)))


def test_self_transfer_onto_a_remesh_that_cuts_across_the_original_triangles(source):
    """Edge midpoints slid into a neighbouring face: children no longer sit inside one parent.

    The truth is the original shapes interpolated at the new vertices' surface points;
    a deformation-gradient transfer can only approach it (a child straddling two parents
    gets one gradient), so the tolerance is that of the method, not of round-off.
    """
    from scipy.spatial import cKDTree

    N, Fs = source.neutral, source.faces
    V, F = trimesh.remesh.subdivide(N, Fs)
    nv = len(N)
    # every directed edge (a, b) of a face with the face's third corner
    corners = np.concatenate([Fs[:, [0, 1, 2]], Fs[:, [1, 2, 0]], Fs[:, [2, 0, 1]]])
    _, which = cKDTree((N[corners[:, 0]] + N[corners[:, 1]]) / 2).query(V[nv:])
    a = np.random.default_rng(0).uniform(0, 0.2, size=len(which))
    bary = np.stack([0.5 - a / 2, 0.5 - a / 2, a], axis=1)
    P = V.copy()
    P[nv:] = np.einsum("vj,vjc->vc", bary, N[corners[which]])
    truth = np.zeros((len(source.deltas), len(V), 3))
    truth[:, :nv] = source.deltas
    truth[:, nv:] = np.einsum("vj,kvjc->kvc", bary, source.deltas[:, corners[which]])
    R = Rotation.from_rotvec([-0.2, 0.5, 0.1]).as_matrix()
    lm = load_index_list("arkit-landmarks")
    rig = retarget_rig(source, 0.8 * P @ R.T - 0.2, F, lm, lm, shapes="all")
    truth = 0.8 * truth @ R.T
    err = np.linalg.norm(rig.deltas - truth, axis=2)
    size = np.linalg.norm(truth, axis=2)
    relative_max = err.max(axis=1) / size.max(axis=1)
    relative_rms = np.sqrt(np.mean(err**2, axis=1) / np.mean(size**2, axis=1))
    # measured: max 22 % (eyeBlinkRight; 6 % for the mouth shapes), median 3 %; RMS at most 7 %, median 2 %
    # the closing eyelids (thin, rotating by ~90 degrees) are the hardest
    assert relative_max.max() < 0.3, dict(zip(rig.names, relative_max.round(3)))
    not_eyes = np.array([not n.startswith("eye") for n in rig.names])
    assert relative_max[not_eyes].max() < 0.12, dict(zip(rig.names, relative_max.round(3)))
    assert np.median(relative_max) < 0.05
    assert relative_rms.max() < 0.08
    assert np.median(relative_rms) < 0.025


def test_self_transfer_mirror_pairs_are_mirror_images(self_transfer, source):
    rig, _truth, _target, _F = self_transfer
    # in the source's own frame the ARKit mesh is symmetric about x = 0
    back = (rig.deltas @ Rotation.from_rotvec([0.4, -0.3, 0.2]).as_matrix()) / 2.5
    from blendvoca.rig import Rig

    n = source.num_vertices
    local = Rig(source.neutral, back[:, :n], rig.names, source.faces)
    report = retarget_report(local, load_index_list("arkit-landmarks"))
    worst = report["summary"]["worst_mirror_rms_relative"]
    assert worst < 0.05, report["mirror"]["pairs"]


@pytest.fixture(scope="module")
def flame(source):
    V, F = read_mesh(resolve("flame-sample"))
    lm_s, lm_t = load_index_list("arkit-landmarks"), load_index_list("flame-landmarks")
    crop = load_index_list("flame-head-idx")
    corr = correspondence_for_target(source.neutral, source.faces, V, F, lm_s, lm_t, crop=crop)
    rig = retarget_rig(source, V, F, lm_s, lm_t, crop=crop, shapes="all", correspondence=corr)
    return rig, V, F, lm_t, crop, corr


def test_flame_neutral_maps_to_template_exactly(flame, source):
    rig, V, F, lm, crop, corr = flame
    np.testing.assert_array_equal(rig.neutral, V)
    np.testing.assert_array_equal(rig.faces, F)
    assert rig.names == tuple(sorted(rig.names, key=list(rig.names).index)) and len(rig.names) == 51
    # a zero source shape transfers to exactly zero
    zero = source.select(["jawOpen"])
    zero = zero.__class__(zero.neutral, np.zeros_like(zero.deltas), zero.names, zero.faces)
    out = retarget_rig(zero, V, F, load_index_list("arkit-landmarks"), lm, crop=crop, shapes=["jawOpen"],
                       correspondence=corr)
    assert np.all(out.deltas == 0.0)


def test_flame_speech_shapes_in_blendvoca_order(flame, source):
    rig, V, F, lm, crop, corr = flame
    speech = retarget_rig(source, V, F, load_index_list("arkit-landmarks"), lm, crop=crop, correspondence=corr)
    assert speech.names == BLENDVOCA_NAMES
    np.testing.assert_allclose(speech.deltas, rig.select(BLENDVOCA_NAMES).deltas, atol=1e-12)


def test_flame_jaw_open_moves_jaw_and_lower_lip_not_forehead(flame):
    rig, V, _F, lm, crop, _corr = flame
    d = np.linalg.norm(rig.deltas[rig.names.index("jawOpen")], axis=1)
    chin, lower_lip, upper_lip = lm[8], lm[[56, 57, 58, 65, 66, 67]], lm[[50, 51, 52, 61, 62, 63]]
    assert d[chin] > 0.015  # the chin drops by centimetres
    assert d[lower_lip].min() > 0.01
    assert d[upper_lip].max() < 0.5 * d[lower_lip].min()
    brows_top = V[lm[17:27], 1].max()
    forehead = np.intersect1d(np.flatnonzero(V[:, 1] > brows_top + 0.01), crop)
    assert len(forehead) > 100
    # still, to within 2.5 % of the chin's travel (measured: max 0.7 mm, mean 0.3 mm)
    assert d[forehead].max() < 0.025 * d[chin]
    assert d[forehead].mean() < 0.0005


def test_flame_shapes_are_plausible(flame, source):
    rig, V, F, _lm, crop, _corr = flame
    assert np.all(np.isfinite(rig.deltas))
    inside = np.zeros(len(V), dtype=bool)
    inside[crop] = True
    crop_faces = inside[F].all(axis=1)
    band = seam_distances(V, F, crop)
    for name, delta in zip(rig.names, rig.deltas):
        src = source.deltas[source.names.index(name)]
        top, src_top = np.linalg.norm(delta, axis=1).max(), np.linalg.norm(src, axis=1).max()
        # a human face moves by at most a few centimetres; transfer keeps the magnitude
        assert 0.5 * src_top < top < 1.2 * src_top, name
        assert top < 0.05, name
        flips = flipped_faces(V, delta, F)
        source_flips = flipped_faces(source.neutral, src, source.faces)
        # inside the transferred head, only shapes whose source folds a triangle fold one
        in_crop = flips[crop_faces[flips]]
        if len(source_flips) == 0:
            assert len(in_crop) == 0, name
        else:
            assert len(in_crop) <= 4 * len(source_flips) + 4, name
        # folds outside the crop stay in the 2 cm band where re-attached vertices blend
        # back to rest (inner lips, under the jaw), and only for mouth and jaw shapes
        outside = flips[~crop_faces[flips]]
        if len(outside):
            assert name.startswith(("mouth", "jaw")), name
            assert np.all(band[F[outside]].min(axis=1) < 0.02), name


def test_flame_mirror_pairs_and_regions(flame, source):
    rig, _V, _F, lm, _crop, corr = flame
    report = retarget_report(rig, lm, source=source, coverage=corr.coverage())
    assert len(MIRROR_PAIRS) == 11
    for left, right in MIRROR_PAIRS:
        pair = report["mirror"]["pairs"][f"{left}/{right}"]
        assert pair["rms_relative"] < MIRROR_RMS_TOLERANCE, (left, pair)
    assert "brows" in report["shapes"]["browInnerUp"]["region"]
    assert "jaw" in report["shapes"]["jawOpen"]["region"]
    assert "eyes" in report["shapes"]["eyeBlinkLeft"]["region"]
    assert set(report["shapes"]["mouthPucker"]["region"]) <= {"outer lips", "inner lips", "nose", "jaw"}
    assert set(LANDMARK_REGIONS) == set(report["shapes"]["jawOpen"]["landmark_groups_mm"])
    cov = report["coverage"]
    assert cov["source_faces_paired"] > 0.95
    assert cov["target_faces_paired"] > 0.3


def test_correspondence_is_reusable_across_identities(flame, source):
    """A correspondence from the template serves another identity of the same topology."""
    _rig, V, F, lm, crop, corr = flame
    # another "speaker": wider, shorter face with a smooth bump
    other = V * np.array([1.08, 0.95, 1.02]) + 0.004 * np.sin(20 * V[:, [1, 2, 0]])
    lm_s = load_index_list("arkit-landmarks")
    shared = retarget_rig(source, other, F, lm_s, lm, crop=crop, shapes=["jawOpen", "mouthSmileLeft"],
                          correspondence=corr)
    fresh = retarget_rig(source, other, F, lm_s, lm, crop=crop, shapes=["jawOpen", "mouthSmileLeft"])
    scale = np.linalg.norm(fresh.deltas, axis=2).max(axis=1)
    err = np.linalg.norm(shared.deltas - fresh.deltas, axis=2)
    assert np.all(np.sqrt(np.mean(err**2, axis=1)) < 0.05 * scale)
    with pytest.raises(ValueError, match="correspondence was computed"):
        retarget_rig(source, source.neutral, source.faces, lm_s, lm_s, correspondence=corr)


# iBUG 68 landmark order under a left-right mirror
IBUG_MIRROR = np.array(
    [*range(16, -1, -1), *range(26, 16, -1), 27, 28, 29, 30, 35, 34, 33, 32, 31,
     45, 44, 43, 42, 47, 46, 39, 38, 37, 36, 41, 40,
     54, 53, 52, 51, 50, 49, 48, 59, 58, 57, 56, 55, 64, 63, 62, 61, 60, 67, 66, 65]
)


def test_flame_mirror_pairs_are_mirror_equivariant(flame, source):
    """Left shape on the head == mirror of the right shape on the mirrored head.

    On a symmetric target the two heads coincide, so this is the mirror-pair property
    without FLAME_sample's own ~1 mm asymmetry. What remains comes from the meshes'
    triangulations, which are not mirror-symmetric (16 % of the ARKit triangles are
    split along the other diagonal on the other side). Measured: RMS error 2 to 9 % of
    the shape's RMS displacement, at most 1.7 mm.
    """
    rig, V, F, lm, crop, _corr = flame
    assert sorted(IBUG_MIRROR) == list(range(68))
    lm_s = load_index_list("arkit-landmarks")
    mirrored = retarget_rig(source, V * [-1, 1, 1], F[:, ::-1], lm_s, lm[IBUG_MIRROR], crop=crop)
    for left, right in MIRROR_PAIRS:
        expected = rig.deltas[rig.names.index(left)] * [-1, 1, 1]
        err = np.linalg.norm(mirrored.deltas[mirrored.names.index(right)] - expected, axis=1)
        rms = np.sqrt(np.mean(err**2) / np.mean(np.sum(expected**2, axis=1)))
        assert rms < 0.12, (left, rms)
        assert err.max() < 0.003, (left, err.max())


def test_flame_with_its_head_crop_raises_no_warning(flame, source):
    """The warnings' limits sit above what the FLAME template with its crop reaches (the
    rig the build makes): no dragged neck, folds and mirror error within bounds."""
    from blendvoca.retarget import crop_mesh
    from blendvoca.retarget.report import FLIP_SHAPE_LIMIT, FLIP_TOTAL_LIMIT, MIRROR_LIMIT

    rig, V, F, lm, crop, corr = flame
    pairs = np.stack([corr.pairs[:, 0], crop_mesh(F, len(V), crop).face_index[corr.pairs[:, 1]]], axis=1)
    report = retarget_report(rig, lm, source=source, coverage=corr.coverage(), face_pairs=pairs)
    assert report["warnings"] == [], [w["message"] for w in report["warnings"]]
    s = report["summary"]
    assert report["neck"]["vertices"] > 50 and s["worst_neck_mm"] < 0.1
    assert s["worst_flipped_fraction"] < FLIP_SHAPE_LIMIT / 1.4
    assert s["flipped_faces_new_total"] / len(F) < FLIP_TOTAL_LIMIT / 1.4
    assert s["worst_mirror_rms_relative"] < MIRROR_LIMIT / 1.4
