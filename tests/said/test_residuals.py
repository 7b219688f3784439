"""``blendshape_residuals.pickle`` as SAiD's training script reads it."""

import pickle

import numpy as np

from blendvoca.builder.said_residuals import RESIDUALS_FILE, blendshape_residuals, write_blendshape_residuals
from blendvoca.rig import Rig


def _rig(seed, names=("jawOpen", "mouthClose", "cheekPuff")):
    rng = np.random.default_rng(seed)
    faces = np.array([[0, 1, 2], [2, 3, 4], [4, 5, 0]])
    return Rig(rng.standard_normal((6, 3)), rng.standard_normal((len(names), 6, 3)) * 0.01, names, faces)


def test_residuals_are_head_crop_offsets_in_column_order(tmp_path):
    rigs = {"A": _rig(0), "B": _rig(1)}
    for subject, rig in rigs.items():
        rig.save(tmp_path / "rigs" / f"{subject}.npz")
    head = np.array([5, 0, 2, 3])
    path = write_blendshape_residuals(tmp_path, ["A", "B", "missing"], head_index=head)
    assert path == tmp_path / RESIDUALS_FILE
    with open(path, "rb") as f:
        loaded = pickle.load(f)
    assert list(loaded) == ["A", "B"]
    for subject, rig in rigs.items():
        assert list(loaded[subject]) == list(rig.names)
        # what their dataset does: neutral head vertices + residual = the blendshape's head mesh
        stacked = np.stack(list(loaded[subject].values()))
        assert stacked.shape == (3, 4, 3)
        for k, name in enumerate(rig.names):
            np.testing.assert_array_equal(rig.neutral[head] + loaded[subject][name], (rig.neutral + rig.deltas[k])[head])
    assert blendshape_residuals({}, head) == {}
    assert write_blendshape_residuals(tmp_path / "empty", ["A"], head_index=head) is None


def test_build_writes_the_residuals_of_its_rigs(built_dataset):
    from blendvoca.assets import load_index_list
    from blendvoca.io.mesh import read_obj

    with open(built_dataset / RESIDUALS_FILE, "rb") as f:
        residuals = pickle.load(f)
    subject = sorted(residuals)[0]
    header = (built_dataset / "blendshape_coeffs" / subject).glob("*.csv")
    names = next(header).read_text().splitlines()[0].split(",")
    assert list(residuals[subject]) == names
    neutral = read_obj(built_dataset / "templates_head" / f"{subject}.obj")[0]
    shape = read_obj(built_dataset / "blendshapes_head" / subject / f"{names[3]}.obj")[0]
    assert residuals[subject][names[3]].shape == (len(load_index_list("flame-head-idx")), 3)
    np.testing.assert_allclose(neutral + residuals[subject][names[3]], shape, atol=1e-6)
