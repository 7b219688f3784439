"""The streaming solver: per-frame bounded least squares with the Audio2Face-3D SDK's terms."""

import json

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from blendvoca.errors import DataError, UserError
from blendvoca.fit import StreamingSolver, StreamingSolverConfig, fit_sequence, framewise_coefficients, normal_equations
from blendvoca.fit.streaming import A2F_DEFAULTS, default_cancel_pairs, default_symmetry_pairs
from blendvoca.names import BLENDVOCA_NAMES

from .conftest import drive, make_rig

#: Documented in docs/streaming.md: on every sentence, the mean absolute difference
#: between the streaming coefficients (SDK defaults) and the offline QP's.
OFFLINE_DISTANCE_MEAN = 0.02
#: The same for the plain bounded least squares (no regulariser).
OFFLINE_DISTANCE_MEAN_PLAIN = 0.002


def _scale(neutral, tbb=A2F_DEFAULTS["template_bb_size"]):
    return (np.linalg.norm(neutral.max(0) - neutral.min(0)) / tbb) ** 2


def _speech_rig(rng, num_vertices=120):
    """A random rig with BlendVOCA's 32 names (so the name tables give pairs)."""
    return make_rig(rng, num_vertices=num_vertices, num_shapes=len(BLENDVOCA_NAMES))


def _frames(rng, neutral, deltas, num_frames=40, spread=0.6):
    """Frames whose fit hits both bounds: fast targets beyond [0, 1], plus noise."""
    k = deltas.shape[0]
    t = np.arange(num_frames)[:, None]
    target = 0.4 + (0.5 + spread) * np.sin(2 * np.pi * rng.uniform(0.02, 0.1, k) * t + rng.uniform(0, 6, k))
    return drive(neutral, deltas, target) + rng.normal(size=(num_frames, *neutral.shape)) * 1e-3


def _weights(config, scale):
    return dict(l1=config.l1 ** 2 * 0.25 * scale, l2=config.l2 * 10 * scale,
                temporal=config.temporal * 100 * scale, symmetry=config.symmetry * 10 * scale)


def _pair_matrix(pairs, k):
    rows = np.zeros((len(pairs), k))
    for r, (i, j) in enumerate(pairs):
        rows[r, i], rows[r, j] = 1.0, -1.0
    return rows


def _reference_stream(neutral, deltas, frames, config, symmetry, cancel):
    """The streaming problem written as stacked least squares and solved by lsq_linear, frame by frame."""
    k = deltas.shape[0]
    basis = deltas.reshape(k, -1).T
    w = _weights(config, _scale(neutral))
    pair_rows = _pair_matrix(symmetry, k)
    previous = np.zeros(k)
    out = []
    for frame in frames:
        offsets = (frame - neutral).ravel()
        if config.objective == "mesh":
            matrix = np.vstack([basis, np.sqrt(w["l1"]) * np.ones((1, k)), np.sqrt(w["l2"]) * np.eye(k),
                                np.sqrt(w["temporal"]) * np.eye(k), np.sqrt(w["symmetry"]) * pair_rows])
            target = np.concatenate([offsets, [0.0], np.zeros(k), np.sqrt(w["temporal"]) * previous,
                                     np.zeros(len(symmetry))])
        else:  # the SDK's BVLS on its normal system, with its right-hand side's temporal scale
            matrix = (basis.T @ basis + w["l1"] * np.ones((k, k)) + (w["l2"] + w["temporal"]) * np.eye(k)
                      + w["symmetry"] * pair_rows.T @ pair_rows)
            target = basis.T @ offsets + config.temporal * _scale(neutral) * previous
        x = lsq_linear(matrix, target, bounds=(0, 1), method="bvls", tol=1e-14).x
        if cancel:
            free = np.ones(k, dtype=bool)
            for i, j in cancel:
                free[j if x[i] >= x[j] else i] = False  # held at 0 (lsq_linear wants lower < upper)
            x = np.zeros(k)
            x[free] = lsq_linear(matrix[:, free], target, bounds=(0, 1), method="bvls", tol=1e-14).x
        previous = x
        out.append(x)
    return np.array(out)


# ------------------------------------------------------------------ the optimum


def test_without_regularisers_each_frame_is_the_bounded_least_squares_optimum(active_problem):
    neutral, deltas, frames = active_problem
    solver = StreamingSolver(neutral, deltas, StreamingSolverConfig.bounded_least_squares())
    basis = deltas.reshape(deltas.shape[0], -1).T
    coeffs = solver.solve_sequence(frames)
    for t, frame in enumerate(frames):
        reference = lsq_linear(basis, (frame - neutral).ravel(), bounds=(0, 1), method="bvls", tol=1e-14).x
        np.testing.assert_allclose(coeffs[t], reference, atol=1e-9)
    assert coeffs.min() == 0.0 and coeffs.max() == 1.0  # both bounds bind


@pytest.mark.parametrize("objective", ["mesh", "a2f"])
def test_regularised_frames_match_the_stacked_least_squares(rng, objective):
    neutral, deltas = _speech_rig(rng)
    frames = _frames(rng, neutral, deltas)
    config = StreamingSolverConfig(temporal=0.3, l1=2.0, objective=objective)
    solver = StreamingSolver(neutral, deltas, config)
    index = {n: i for i, n in enumerate(BLENDVOCA_NAMES)}
    symmetry = [(index[a], index[b]) for a, b in default_symmetry_pairs(BLENDVOCA_NAMES)]
    cancel = [(index[a], index[b]) for a, b in default_cancel_pairs(BLENDVOCA_NAMES)]
    assert solver.symmetry_pairs == tuple(symmetry) and solver.cancel_pairs == tuple(cancel)
    coeffs = solver.solve_sequence(frames)
    reference = _reference_stream(neutral, deltas, frames, config, symmetry, cancel)
    np.testing.assert_allclose(coeffs, reference, atol=1e-7)


def test_defaults_are_the_sdk_defaults_and_stay_in_the_box(rng):
    config = StreamingSolverConfig()
    assert (config.l1, config.l2, config.symmetry, config.temporal, config.template_bb_size) == (1.0, 3.5, 100.0, 0.0, 54.7)
    neutral, deltas = _speech_rig(rng)
    coeffs = StreamingSolver(neutral, deltas).solve_sequence(_frames(rng, neutral, deltas, spread=2.0))
    assert coeffs.min() >= 0.0 and coeffs.max() <= 1.0


def test_default_pairs_from_the_name_tables():
    symmetry = default_symmetry_pairs(BLENDVOCA_NAMES)
    cancel = default_cancel_pairs(BLENDVOCA_NAMES)
    assert ("mouthSmileLeft", "mouthSmileRight") in symmetry and ("noseSneerLeft", "noseSneerRight") in symmetry
    assert len(symmetry) == 9
    assert cancel == (("jawLeft", "jawRight"), ("mouthLeft", "mouthRight"))


def test_cancel_pairs_leave_one_of_each_pair_at_zero(rng):
    neutral, deltas = _speech_rig(rng)
    frames = _frames(rng, neutral, deltas)
    solver = StreamingSolver(neutral, deltas, StreamingSolverConfig.bounded_least_squares(cancel_pairs=None))
    coeffs = solver.solve_sequence(frames)
    for a, b in default_cancel_pairs(BLENDVOCA_NAMES):
        i, j = BLENDVOCA_NAMES.index(a), BLENDVOCA_NAMES.index(b)
        assert np.all(np.minimum(coeffs[:, i], coeffs[:, j]) == 0.0)
    plain = StreamingSolver(neutral, deltas, StreamingSolverConfig.bounded_least_squares()).solve_sequence(frames)
    both = (plain[:, 1] > 0) & (plain[:, 2] > 0)  # jawLeft and jawRight both on without the pairs
    assert both.any()


def test_rate_bound_without_regularisers_is_the_framewise_fit(active_problem):
    neutral, deltas, frames = active_problem
    config = StreamingSolverConfig.bounded_least_squares(rate_bound=0.1)
    coeffs = StreamingSolver(neutral, deltas, config).solve_sequence(frames)
    system = normal_equations(neutral, deltas, frames)
    np.testing.assert_allclose(coeffs, framewise_coefficients(system.gram, system.rhs, rate_bound=0.1), atol=1e-8)
    assert np.abs(np.diff(coeffs, axis=0)).max() <= 0.1 + 1e-12


@pytest.mark.parametrize("config", [StreamingSolverConfig(), StreamingSolverConfig(temporal=1.0, rate_bound=0.1),
                                    StreamingSolverConfig(objective="a2f")])
def test_framewise_backend_gives_the_same_track(rng, config):
    neutral, deltas = _speech_rig(rng)
    frames = _frames(rng, neutral, deltas, num_frames=25)
    active = StreamingSolver(neutral, deltas, config).solve_sequence(frames)
    banded = StreamingSolver(neutral, deltas, _replace(config, backend="framewise")).solve_sequence(frames)
    np.testing.assert_allclose(active, banded, atol=1e-7)


def _replace(config, **changes):
    import dataclasses

    return dataclasses.replace(config, **changes)


# ------------------------------------------------------------- stream behaviour


@pytest.mark.parametrize("config", [StreamingSolverConfig(), StreamingSolverConfig(temporal=2.0, rate_bound=0.05)])
def test_causal_later_frames_do_not_change_earlier_output(rng, config):
    neutral, deltas = _speech_rig(rng)
    frames = _frames(rng, neutral, deltas)
    changed = frames.copy()
    changed[20:] = _frames(np.random.default_rng(99), neutral, deltas)[20:]
    a = StreamingSolver(neutral, deltas, config).solve_sequence(frames)
    b = StreamingSolver(neutral, deltas, config).solve_sequence(changed)
    np.testing.assert_array_equal(a[:20], b[:20])
    assert np.abs(a[20:] - b[20:]).max() > 0.01


def test_warm_start_does_not_change_the_answer(active_problem):
    neutral, deltas, frames = active_problem
    config = StreamingSolverConfig()
    streamed = StreamingSolver(neutral, deltas, config).solve_sequence(frames)
    cold = StreamingSolver(neutral, deltas, config)
    each = []
    for frame in frames:  # no temporal term: a fresh stream per frame is the same problem, cold
        cold.reset()
        each.append(cold.solve(frame))
    np.testing.assert_allclose(streamed, np.array(each), atol=1e-10)


def test_reset_and_previous(rng):
    neutral, deltas = _speech_rig(rng)
    frames = _frames(rng, neutral, deltas)
    config = StreamingSolverConfig(temporal=1.0)
    solver = StreamingSolver(neutral, deltas, config)
    whole = solver.solve_sequence(frames)
    np.testing.assert_array_equal(solver.previous, whole[-1])
    # Resuming from the previous frame continues the same stream.
    resumed = StreamingSolver(neutral, deltas, config)
    resumed.reset(previous=whole[14])
    np.testing.assert_allclose(resumed.solve_sequence(frames[15:]), whole[15:], atol=1e-10)
    solver.reset()
    assert solver.previous is None
    np.testing.assert_allclose(solver.solve_sequence(frames), whole, atol=1e-12)


def test_full_topology_and_crop_frames_give_the_same_fit(rng):
    neutral, deltas = make_rig(rng, num_vertices=300, num_shapes=8)
    subset = np.sort(rng.choice(300, size=200, replace=False))
    frames = _frames(rng, neutral, deltas, num_frames=10)
    full = StreamingSolver(neutral, deltas, vertex_subset=subset).solve_sequence(frames)
    crop = StreamingSolver(neutral, deltas, vertex_subset=subset).solve_sequence(frames[:, subset])
    np.testing.assert_allclose(full, crop, atol=1e-12)
    # Only the subset's vertices count: what the others do changes nothing.
    moved = frames.copy()
    moved[:, np.setdiff1d(np.arange(300), subset)] += 1.0
    np.testing.assert_allclose(StreamingSolver(neutral, deltas, vertex_subset=subset).solve_sequence(moved), full,
                               atol=1e-12)
    # The scale of the terms comes from the whole neutral, as in the SDK.
    assert StreamingSolver(neutral, deltas, vertex_subset=subset).scale_factor == pytest.approx(_scale(neutral))


def test_rig_units_do_not_matter(rng):
    """The strengths scale with the squared size of the neutral: metres and centimetres agree."""
    neutral, deltas = _speech_rig(rng)
    frames = _frames(rng, neutral, deltas)
    config = StreamingSolverConfig(temporal=0.5)
    metres = StreamingSolver(neutral, deltas, config).solve_sequence(frames)
    centimetres = StreamingSolver(100 * neutral, 100 * deltas, config).solve_sequence(100 * frames)
    np.testing.assert_allclose(metres, centimetres, atol=1e-9)


def test_masks_multipliers_and_offsets(rng):
    neutral, deltas = _speech_rig(rng)
    frames = _frames(rng, neutral, deltas, num_frames=15)
    config = StreamingSolverConfig(temporal=1.0, inactive=("cheekPuff", 0), multipliers={"jawOpen": 2.0, 5: 0.5},
                                   offsets={"jawOpen": 0.1, "cheekPuff": 0.25})
    coeffs = StreamingSolver(neutral, deltas, config).solve_sequence(frames)
    puff, jaw = BLENDVOCA_NAMES.index("cheekPuff"), BLENDVOCA_NAMES.index("jawOpen")
    assert np.all(coeffs[:, puff] == 0.25) and np.all(coeffs[:, 0] == 0.0)
    # The inactive shapes are left out of the solve: a rig without them gives the others.
    keep = [k for k in range(32) if k not in (0, puff)]
    names = [BLENDVOCA_NAMES[k] for k in keep]
    smaller = StreamingSolver(neutral, deltas[keep], _replace(config, inactive=(), multipliers={}, offsets={}),
                              names=names).solve_sequence(frames)
    expected = smaller.copy()
    expected[:, names.index("jawOpen")] = expected[:, names.index("jawOpen")] * 2.0 + 0.1
    expected[:, names.index(BLENDVOCA_NAMES[5])] *= 0.5
    np.testing.assert_allclose(coeffs[:, keep], expected, atol=1e-9)
    assert coeffs[:, jaw].min() >= 0.1  # applied after the solve (and the bounds), as in the SDK


def test_input_errors(rng):
    neutral, deltas = make_rig(rng, num_vertices=50, num_shapes=4)
    solver = StreamingSolver(neutral, deltas, StreamingSolverConfig.bounded_least_squares())
    with pytest.raises(UserError, match=r"expected a frame of \(50, 3\).*got shape \(49, 3\)"):
        solver.solve(neutral[:49])
    bad = neutral.copy()
    bad[7, 1] = np.nan
    with pytest.raises(UserError, match="non-finite value at vertex 7"):
        solver.solve(bad)
    with pytest.raises(UserError, match="names the shape 'jawOpen'"):
        StreamingSolver(neutral, deltas, StreamingSolverConfig(inactive=("jawOpen",)))
    with pytest.raises(UserError, match="shape index 9"):
        StreamingSolver(neutral, deltas, StreamingSolverConfig(symmetry_pairs=[(0, 9)]))
    with pytest.raises(UserError, match="objective"):
        StreamingSolverConfig(objective="qp")
    with pytest.raises(UserError, match="l2 must be >= 0"):
        StreamingSolverConfig(l2=-1)
    with pytest.raises(UserError, match="pairs of two different shapes"):
        StreamingSolverConfig(cancel_pairs=[("jawLeft",)])
    with pytest.raises(UserError, match="every shape is inactive"):
        StreamingSolver(neutral, deltas, StreamingSolverConfig(inactive=(0, 1, 2, 3)))


# ------------------------------------------------------------------ from_a2f


def _sdk_file(path, num_poses, **changes):
    """An Audio2Face-3D blendshape solver configuration in the SDK's layout (parse_helper.cpp)."""
    params = {
        "strengthL1regularization": 0.5,
        "strengthL2regularization": 2.0,
        "strengthTemporalSmoothing": 0.25,
        "strengthSymmetry": 50.0,
        "templateBBSize": 30.0,
        "numPoses": num_poses,
        "bsSolveActivePoses": [1] * num_poses,
        "bsSolveCancelPoses": [-1] * num_poses,
        "bsSolveSymmetryPoses": [-1] * num_poses,
        "bsWeightMultipliers": [1.0] * num_poses,
        "bsWeightOffsets": [0.0] * num_poses,
        "bsDataPath": "bs_skin.npz",  # other keys of the real files are ignored
    }
    params.update(changes)
    path.write_text(json.dumps({"blendshape_params": params}, indent=4))
    return path


def test_from_a2f_reads_the_sdk_layout(tmp_path):
    active = [1, 1, 0, 1, 1, 1]
    cancel = [0, -1, -1, 0, -1, -1]
    symmetry = [-1, 1, -1, -1, 1, -1]
    path = _sdk_file(tmp_path / "bs_skin_config.json", 6, bsSolveActivePoses=active, bsSolveCancelPoses=cancel,
                     bsSolveSymmetryPoses=symmetry, bsWeightMultipliers=[1, 2, 1, 1, 1, 0.5],
                     bsWeightOffsets=[0, 0, 0, 0.1, 0, 0])
    config = StreamingSolverConfig.from_a2f(path)
    assert (config.l1, config.l2, config.temporal, config.symmetry, config.template_bb_size) == (0.5, 2.0, 0.25, 50.0, 30.0)
    assert config.cancel_pairs == ((0, 3),) and config.symmetry_pairs == ((1, 4),) and config.inactive == (2,)
    assert config.multipliers[1] == 2.0 and config.multipliers[5] == 0.5 and config.offsets[3] == 0.1
    assert config.num_poses == 6 and config.pose_names is None
    # The same content as a dict, with or without the outer object, and overrides.
    data = json.loads(path.read_text())
    assert StreamingSolverConfig.from_a2f(data) == config
    assert StreamingSolverConfig.from_a2f(data["blendshape_params"], rate_bound=0.1).rate_bound == 0.1
    # templateBBSize is optional (the SDK's default).
    del data["blendshape_params"]["templateBBSize"]
    assert StreamingSolverConfig.from_a2f(data).template_bb_size == 54.7


def test_from_a2f_by_index_and_by_name(tmp_path, rng):
    neutral, deltas = _speech_rig(rng)
    frames = _frames(rng, neutral, deltas, num_frames=12)
    # By index: the file's poses are the rig's shapes in order.
    symmetry = [-1] * 32
    symmetry[BLENDVOCA_NAMES.index("mouthSmileLeft")] = symmetry[BLENDVOCA_NAMES.index("mouthSmileRight")] = 7
    by_index = StreamingSolverConfig.from_a2f(_sdk_file(tmp_path / "a.json", 32, bsSolveSymmetryPoses=symmetry))
    explicit = StreamingSolverConfig(l1=0.5, l2=2.0, temporal=0.25, symmetry=50.0, template_bb_size=30.0,
                                     symmetry_pairs=[("mouthSmileLeft", "mouthSmileRight")], cancel_pairs=())
    np.testing.assert_allclose(StreamingSolver(neutral, deltas, by_index).solve_sequence(frames),
                               StreamingSolver(neutral, deltas, explicit).solve_sequence(frames), atol=1e-12)
    # By name: an SDK file of 3 poses, one of which the rig lacks.
    sdk_names = ["EyeBlinkLeft", "MouthSmileRight", "mouthSmileLeft"]  # any case
    by_name = StreamingSolverConfig.from_a2f(
        _sdk_file(tmp_path / "b.json", 3, bsSolveSymmetryPoses=[-1, 0, 0], bsSolveActivePoses=[0, 1, 1],
                  bsWeightOffsets=[0.5, 0.0, 0.0]), names=sdk_names)
    assert by_name.symmetry_pairs == (("mouthSmileRight", "mouthSmileLeft"),)
    np.testing.assert_allclose(StreamingSolver(neutral, deltas, by_name).solve_sequence(frames),
                               StreamingSolver(neutral, deltas, explicit).solve_sequence(frames), atol=1e-12)
    # Without names, a file of another size than the rig cannot be applied.
    with pytest.raises(UserError, match="numPoses=3 poses by index, the rig has 32"):
        StreamingSolver(neutral, deltas, StreamingSolverConfig.from_a2f(tmp_path / "b.json"))


@pytest.mark.parametrize("changes, message", [
    ({"numPoses": 0}, "numPoses: expected a positive integer"),
    ({"bsSolveActivePoses": [1, 1]}, "bsSolveActivePoses: expected a list of numPoses=3 integers, got 2 entries"),
    ({"bsWeightOffsets": [0, "a", 0]}, "bsWeightOffsets: expected a list of numPoses=3 numbers"),
    ({"bsSolveCancelPoses": [4, 4, 4]}, "id 4 marks 3 poses"),
    ({"strengthSymmetry": "high"}, "strengthSymmetry: expected a number, got 'high'"),
    ({"strengthL2regularization": -1}, "strengths must be >= 0"),
])
def test_from_a2f_errors_name_the_file_and_field(tmp_path, changes, message):
    path = _sdk_file(tmp_path / "bad.json", 3, **changes)
    with pytest.raises(DataError, match=message) as info:
        StreamingSolverConfig.from_a2f(path)
    assert str(path) in str(info.value)


def test_from_a2f_missing_fields_and_wrong_files(tmp_path):
    path = _sdk_file(tmp_path / "c.json", 2)
    data = json.loads(path.read_text())
    del data["blendshape_params"]["bsSolveCancelPoses"]
    path.write_text(json.dumps(data))
    with pytest.raises(DataError, match="blendshape_params.bsSolveCancelPoses is missing"):
        StreamingSolverConfig.from_a2f(path)
    (tmp_path / "other.json").write_text(json.dumps({"face_params": {}}))
    with pytest.raises(DataError, match="expected an object 'blendshape_params'"):
        StreamingSolverConfig.from_a2f(tmp_path / "other.json")
    (tmp_path / "broken.json").write_text("{")
    with pytest.raises(DataError, match="not an Audio2Face-3D blendshape solver configuration"):
        StreamingSolverConfig.from_a2f(tmp_path / "broken.json")
    with pytest.raises(UserError, match="expected numPoses=2 pose names"):
        StreamingSolverConfig.from_a2f(_sdk_file(tmp_path / "d.json", 2), names=["jawOpen"])


# ---------------------------------------------------------- against the offline fit


def test_close_to_the_offline_qp_on_a_built_sentence(built_dataset, synthetic_corpus):
    """On the small synthetic build (FLAME rigs, 4580-vertex head crop): within the distance
    docs/streaming.md documents, every frame in [0, 1], and about as close to the meshes."""
    from benchmark.data import open_blendvoca
    from blendvoca.assets import load_index_list
    from blendvoca.vocaset import open_vocaset

    data = open_blendvoca(built_dataset)
    corpus = open_vocaset(synthetic_corpus)
    head = load_index_list("flame-head-idx")
    for subject in corpus.subjects[:2]:
        rig = data.rig(subject)
        frames = corpus.frames(subject, "sentence01")
        offline = fit_sequence(rig.neutral, rig.deltas, frames, vertex_subset=head, unposed=True)
        solver = StreamingSolver.from_rig(rig)
        assert solver.num_fitted == 4580
        streamed = solver.solve_sequence(frames)
        assert streamed.min() >= 0.0 and streamed.max() <= 1.0
        assert np.abs(streamed - offline.coeffs).mean() < OFFLINE_DISTANCE_MEAN
        error = np.sqrt(((rig.evaluate(streamed)[:, head] - frames[:, head]) ** 2).sum(-1).mean(-1))
        assert error.mean() < 1.1 * offline.rmse.mean()
        plain = StreamingSolver.from_rig(rig, StreamingSolverConfig.bounded_least_squares()).solve_sequence(frames)
        assert np.abs(plain - offline.coeffs).mean() < OFFLINE_DISTANCE_MEAN_PLAIN
