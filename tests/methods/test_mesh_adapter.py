import numpy as np
import pytest

from baselines.mesh_adapter.adapt import adapted_coefficients
from baselines.mesh_adapter.config import adapter_config, read_adapter_config
from baselines.mesh_adapter.sequences import find_sequences, read_vertex_sequence
from benchmark.methods import Budget, TrainingRequest, get_method
from benchmark.protocol import generated_tracks
from benchmark.testing import RANDOM_RIG_VERTICES, FakeBlendVOCA

V = RANDOM_RIG_VERTICES


def rig_dataset(test=("S1", "S2")):
    """Test speakers only, with random 33-shape rigs (one shape beyond the 32 names) and
    smooth tracks within the fit's rate bound (|du| < 0.1): the vertices give the tracks back."""
    return FakeBlendVOCA(0, train=0, val=0, test=list(test), sentences=2, frames=(100, 140), tracks="smooth",
                         rig="random", manifest_hash="righash")


@pytest.fixture(scope="module")
def dataset():
    return rig_dataset()


def _write_npy(dataset, root, step=1, offsets=False):
    for subject in dataset.split("test"):
        for sentence in dataset.sentences(subject):
            frames = dataset.vertices(subject, sentence)[::step]
            if offsets:
                frames = frames - dataset.rig(subject).neutral[None]
            (root / subject).mkdir(parents=True, exist_ok=True)
            np.save(root / subject / f"{sentence}.npy", frames)


def test_adapter_recovers_known_coefficients_at_60fps(dataset, tmp_path):
    _write_npy(dataset, tmp_path / "out")
    (tmp_path / "m.yaml").write_text("name: Fake VOCA\nvertices: out\nfps: 60\n")
    method = get_method("mesh-adapter")(config=str(tmp_path / "m.yaml"))
    assert method.label == "Fake VOCA"
    method.train(dataset, TrainingRequest(seed=0, budget=Budget()))
    generated, _ = generated_tracks(method, dataset)
    for (subject, sentence), tracks in generated.items():
        np.testing.assert_allclose(tracks[0], dataset.coeffs(subject, sentence), atol=1e-5)


def test_adapter_30fps_offsets_close_and_same_length(dataset, tmp_path):
    _write_npy(dataset, tmp_path / "out", step=2, offsets=True)
    method = get_method("mesh-adapter")(vertices=str(tmp_path / "out"), fps=30, template="offsets")
    method.train(dataset, TrainingRequest(seed=0, budget=Budget()))
    generated, _ = generated_tracks(method, dataset)
    for key, tracks in generated.items():
        truth = dataset.coeffs(*key)
        assert tracks.shape == (1, truth.shape[0], 32)
        # linear interpolation of a smooth signal; the last 60 fps frame of an even-length
        # track lies past the last 30 fps frame and holds it
        assert np.abs(tracks[0, :-1] - truth[:-1]).max() < 0.01
        assert np.abs(tracks[0] - truth).max() < 0.1


def test_adapter_reads_per_frame_mesh_folders(dataset, tmp_path):
    from blendvoca.io.mesh import write_ply

    frames = dataset.vertices("S1", "sentence01")[:12]
    folder = tmp_path / "S1" / "sentence01"
    folder.mkdir(parents=True)
    for i, f in enumerate(frames):  # unpadded numbers: natural sort must keep frame 10 after 9
        write_ply(folder / f"frame{i + 1}.ply", f, dataset.rig("S1").faces)
    assert list(find_sequences(tmp_path)) == [("S1", "sentence01")]
    np.testing.assert_allclose(read_vertex_sequence(folder), frames, atol=1e-6)


def test_adapter_save_load_round_trip(dataset, tmp_path):
    _write_npy(dataset, tmp_path / "out")
    method = get_method("mesh-adapter")(vertices=str(tmp_path / "out"))
    method.train(dataset, TrainingRequest(seed=0, budget=Budget()))
    method.save(tmp_path / "ckpt")
    loaded = get_method("mesh-adapter").load(tmp_path / "ckpt")
    assert loaded.config() == method.config()
    a, _ = generated_tracks(method, dataset)
    b, _ = generated_tracks(loaded, dataset)
    assert all(np.array_equal(a[k], b[k]) for k in a)


def test_missing_outputs_named(dataset, tmp_path):
    _write_npy(dataset, tmp_path / "out")
    (tmp_path / "out" / "S2" / "sentence02.npy").unlink()
    method = get_method("mesh-adapter")(vertices=str(tmp_path / "out"))
    with pytest.raises(FileNotFoundError, match=r"1 of 4 sentences.*S2/sentence02"):
        method.train(dataset, TrainingRequest(seed=0, budget=Budget()))


def test_wrong_topology_named(dataset, tmp_path):
    (tmp_path / "out" / "S1").mkdir(parents=True)
    for q in dataset.sentences("S1"):
        np.save(tmp_path / "out" / "S1" / f"{q}.npy", np.zeros((10, V + 1, 3)))
    with pytest.raises(ValueError, match=r"S1/sentence01.*\(T, 60, 3\)"):
        method = get_method("mesh-adapter")(vertices=str(tmp_path / "out"), split="test")
        method.train(rig_dataset(test=["S1"]), TrainingRequest(seed=0, budget=Budget()))


def test_config_validation(tmp_path):
    with pytest.raises(ValueError, match="unknown key"):
        adapter_config({"vertices": "x", "fsp": 30})
    with pytest.raises(ValueError, match="'template' must be one of"):
        adapter_config({"vertices": "x", "template": "relative"})
    with pytest.raises(ValueError, match="'vertices'"):
        adapter_config({"fps": 30})
    with pytest.raises(ValueError, match="expected config=PATH.yaml"):
        get_method("mesh-adapter")()
    (tmp_path / "a.yaml").write_text("vertices: sub\nfps: 30\n")
    cfg = read_adapter_config(tmp_path / "a.yaml")
    assert cfg.vertices == str((tmp_path / "sub").resolve()) and cfg.fps == 30.0 and cfg.name == "sub"


def test_adapted_coefficients_closed_form():
    rng = np.random.default_rng(3)
    neutral, deltas = rng.normal(size=(20, 3)), rng.normal(size=(4, 20, 3))
    truth = np.clip(rng.uniform(size=(1, 4)).repeat(10, 0), 0, 1)
    frames = neutral + np.einsum("tk,kvc->tvc", truth, deltas)
    np.testing.assert_allclose(adapted_coefficients(frames, neutral, deltas), truth, atol=1e-6)
    np.testing.assert_allclose(adapted_coefficients(frames - neutral, neutral, deltas, template="offsets"), truth,
                               atol=1e-6)
