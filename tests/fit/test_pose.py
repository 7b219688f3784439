"""Head-pose removal: closed-form rigid motions, the synthetic corpus's true head motion,
and fits on posed frames against fits on the unposed ones."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from blendvoca.fit import fit_sequence, flame_stable_vertices, least_moving_vertices, remove_head_pose
from blendvoca.synthetic import generate_corpus, read_npz
from blendvoca.synthetic.headpose import apply_pose
from blendvoca.vocaset import open_vocaset


def _angle_between(a, b):
    """Angle (degrees) of a[t]^T b[t] per frame."""
    rel = np.einsum("tji,tjk->tik", a, b)
    return np.degrees(np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)))


def _random_pose(rng, num_frames, angle=0.08, shift=0.01):
    return Rotation.from_rotvec(rng.normal(size=(num_frames, 3)) * angle).as_matrix(), rng.normal(
        size=(num_frames, 3)) * shift


def test_exact_rigid_motion_is_recovered_and_undone():
    rng = np.random.default_rng(0)
    neutral = rng.normal(size=(200, 3)) * 0.05
    frames = np.repeat(neutral[None], 6, axis=0)
    frames[:, :50] += rng.normal(size=(6, 50, 3)) * 0.01  # a quarter of the vertices deform
    rot, trans = _random_pose(rng, 6)
    pose = remove_head_pose(apply_pose(frames, rot, trans), neutral, stable=np.arange(50, 200))
    np.testing.assert_allclose(pose.rotations, rot, atol=1e-12)
    np.testing.assert_allclose(pose.translations, trans, atol=1e-12)
    np.testing.assert_allclose(pose.frames, frames, atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(pose.rotations), 1.0)
    np.testing.assert_allclose(pose.angles_deg, np.degrees(np.linalg.norm(Rotation.from_matrix(rot).as_rotvec(),
                                                                          axis=1)), atol=1e-9)


def test_robust_weights_ignore_moving_vertices_in_the_stable_set():
    rng = np.random.default_rng(1)
    neutral = rng.normal(size=(300, 3)) * 0.05
    frames = np.repeat(neutral[None], 4, axis=0)
    frames[:, :60] += rng.normal(size=(4, 60, 3)) * 0.01  # 20 % outliers of ~1 cm
    rot, trans = _random_pose(rng, 4)
    posed = apply_pose(frames, rot, trans)
    plain = remove_head_pose(posed, neutral, stable=np.arange(300), iterations=0)
    robust = remove_head_pose(posed, neutral, stable=np.arange(300))
    assert _angle_between(plain.rotations, rot).max() > 0.1
    assert _angle_between(robust.rotations, rot).max() < 1e-4  # Cauchy weights are small, never 0
    assert robust.weights[:, :60].max() < 0.05 < robust.weights[:, 60:].min()


def test_automatic_stable_choice_finds_the_rigid_part():
    rng = np.random.default_rng(2)
    neutral = rng.normal(size=(400, 3)) * 0.05
    t = np.arange(30)[:, None, None]
    frames = np.repeat(neutral[None], 30, axis=0)
    frames[:, :150] += 0.01 * np.sin(0.3 * t + rng.uniform(0, 6, size=(1, 150, 3)))
    stable = least_moving_vertices(frames, neutral)
    assert stable.min() >= 150 and len(stable) == 120
    rot, trans = _random_pose(rng, 30)
    pose = remove_head_pose(apply_pose(frames, rot, trans), neutral)
    assert _angle_between(pose.rotations, rot).max() < 1e-5  # arccos round-off


def test_bad_input_names_the_problem():
    neutral = np.zeros((10, 3))
    with pytest.raises(ValueError, match="remove_head_pose: expected frames"):
        remove_head_pose(np.zeros((2, 9, 3)), neutral)
    with pytest.raises(ValueError, match="at least 3 vertex indices"):
        remove_head_pose(np.zeros((2, 10, 3)), neutral, stable=[0, 1])
    line = np.zeros((10, 3))
    line[:, 0] = np.arange(10)
    with pytest.raises(ValueError, match="collinear"):
        remove_head_pose(line[None], line, stable=np.arange(10))


@pytest.fixture(scope="module")
def posed_corpus(tmp_path_factory, assets_dir):
    """Three speakers, one 1-1.2 s sentence each, with head motion (seed 0: the speakers
    of the shared synthetic corpus fixtures)."""
    return generate_corpus(tmp_path_factory.mktemp("posed") / "official", speakers=3, sentences=1, seed=0,
                           duration=(1.0, 1.2), head_motion=True)


def test_synthetic_head_motion_is_recovered(posed_corpus):
    corpus = open_vocaset(posed_corpus)
    assert corpus.synthetic["head_motion"]["max_angle_deg"] == 3.0
    for subject in corpus.subjects:
        truth = read_npz(posed_corpus / "groundtruth" / subject / "sentence01.npz")
        posed = corpus.posed_frames(subject, "sentence01")
        unposed = corpus.frames(subject, "sentence01")
        neutral = corpus.template(subject)
        true_angles = _angle_between(np.eye(3)[None], truth["head_rotations"])
        assert 0.5 < true_angles.max() < 5.2  # a real motion of a few degrees
        # The stored posed frames are the unposed ones moved by the recorded pose (float32 PLY).
        np.testing.assert_allclose(posed, apply_pose(unposed, truth["head_rotations"], truth["head_translations"]),
                                   atol=2e-7)
        pose = remove_head_pose(posed, neutral)
        assert np.array_equal(pose.stable, flame_stable_vertices(neutral))
        assert _angle_between(pose.rotations, truth["head_rotations"]).max() < 0.2
        assert np.abs(pose.translations - truth["head_translations"]).max() < 2e-4  # 0.2 mm
        assert np.abs(pose.frames - unposed).max() < 1e-4
    assert not corpus.has_posed(subject, "sentence02")


def test_unposed_corpus_is_unchanged_by_head_motion(posed_corpus, synthetic_corpus):
    plain, posed = open_vocaset(synthetic_corpus), open_vocaset(posed_corpus)
    subject = plain.subjects[0]
    np.testing.assert_array_equal(plain.template(subject), posed.template(subject))
    assert not plain.has_posed(subject, "sentence01")


def test_fit_on_posed_frames_matches_fit_on_unposed(posed_corpus, built_dataset):
    from benchmark.data import open_blendvoca

    rig = open_blendvoca(built_dataset).rig("Synth_000_TA")
    corpus = open_vocaset(posed_corpus)
    posed = corpus.posed_frames("Synth_000_TA", "sentence01")
    unposed = corpus.frames("Synth_000_TA", "sentence01")
    np.testing.assert_allclose(rig.neutral, corpus.template("Synth_000_TA"), atol=1e-6)
    reference = fit_sequence(rig.neutral, rig.deltas, unposed, unposed=True)
    fitted = fit_sequence(rig.neutral, rig.deltas, posed, pose_fit="remove")  # rigid pose removal, as the adapter
    kept = fit_sequence(rig.neutral, rig.deltas, posed, unposed=True)
    assert fitted.pose is not None and reference.pose is None
    assert 0.5 < fitted.pose.summary()["rotation_deg_max"] < 5.2
    change = np.linalg.norm(fitted.coeffs - reference.coeffs) / np.linalg.norm(reference.coeffs)
    assert change < 0.05
    assert fitted.rmse.mean() < 1.05 * reference.rmse.mean()
    # Without the pose removal the same frames fit far worse.
    assert np.linalg.norm(kept.coeffs - reference.coeffs) / np.linalg.norm(reference.coeffs) > 0.2
    assert kept.rmse.mean() > 2 * reference.rmse.mean()
    # The mesh adapter (method outputs) removes it too and hands the pose back.
    from baselines.mesh_adapter.adapt import adapted_coefficients

    poses = []
    adapted = adapted_coefficients(posed, rig.neutral, rig.deltas, poses=poses)
    np.testing.assert_allclose(adapted, fitted.coeffs, atol=1e-9)
    assert poses[0].summary() == fitted.pose.summary()


def test_head_motion_in_the_processed_layout_goes_beside_data_verts(tmp_path, assets_dir):
    root = generate_corpus(tmp_path / "p", speakers=3, sentences=1, layout="processed", head_motion=True,
                           duration=(1.0, 1.0))
    posed = np.load(root / "data_verts_posed.npy", mmap_mode="r")
    assert posed.shape == np.load(root / "data_verts.npy", mmap_mode="r").shape
    corpus = open_vocaset(root)
    truth = read_npz(root / "groundtruth" / "Synth_001_TA" / "sentence01.npz")
    rows = corpus.frame_rows("Synth_001_TA", "sentence01")
    np.testing.assert_allclose(posed[rows], apply_pose(corpus.frames("Synth_001_TA", "sentence01"),
                                                       truth["head_rotations"], truth["head_translations"]), atol=2e-7)
