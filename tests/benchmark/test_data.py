import json
import shutil

import numpy as np
import pytest

from benchmark.data import open_blendvoca
from blendvoca.format.__main__ import main as format_main
from blendvoca.names import BLENDVOCA_NAMES


def test_reads_build(fake_dataset_dir):
    ds = open_blendvoca(fake_dataset_dir)
    assert ds.subjects == ["FakeA", "FakeB", "FakeC"]
    assert ds.split("test") == ["FakeC"] and ds.split("train") == ["FakeA"]
    assert ds.sentences("FakeC") == ["sentence01", "sentence02", "sentence03"]
    coeffs = ds.coeffs("FakeC", "sentence01")
    assert coeffs.ndim == 2 and coeffs.shape[1] == 32 and 150 <= len(coeffs) < 200
    samples, rate = ds.audio("FakeC", "sentence01")
    assert rate == 16000 and samples.dtype == np.float32
    assert abs(len(samples) / 16000 - len(coeffs) / 60) < 0.05
    rig = ds.rig("FakeC")
    assert rig.names == BLENDVOCA_NAMES and rig.neutral.shape == (5023, 3)
    assert ds.rig("FakeC") is rig
    assert ds.samples("FakeC", "sentence01").shape == (1, *coeffs.shape)
    assert ds.names == BLENDVOCA_NAMES
    assert len(ds.manifest_hash) == 64 and ds.manifest_hash == open_blendvoca(fake_dataset_dir).manifest_hash


def test_a_path_may_be_a_str_or_path_like(fake_dataset_dir):
    from benchmark.data import BlendVOCADataset

    for root in (str(fake_dataset_dir), fake_dataset_dir):
        assert BlendVOCADataset(root).subjects == ["FakeA", "FakeB", "FakeC"]
        assert open_blendvoca(root, vocaset=str(fake_dataset_dir)).manifest_hash == \
            open_blendvoca(fake_dataset_dir).manifest_hash


def test_the_dataset_and_the_test_fake_are_what_plug_ins_are_given(fake_dataset_dir):
    from benchmark.methods import Dataset
    from benchmark.testing import FakeBlendVOCA

    assert isinstance(open_blendvoca(fake_dataset_dir), Dataset)
    for fake in (FakeBlendVOCA(), FakeBlendVOCA(1, train=["A"], val=0, test=["B"], tracks="smooth", rig="random")):
        assert isinstance(fake, Dataset)
    assert not isinstance(object(), Dataset)


def test_said_layout_fallback(fake_dataset_dir, tmp_path):
    import trimesh

    from blendvoca.rig import Rig

    root = tmp_path / "said"
    shutil.copytree(fake_dataset_dir / "blendshape_coeffs", root / "blendshape_coeffs")
    sphere = trimesh.creation.icosphere(subdivisions=1)
    rng = np.random.default_rng(0)
    rig = Rig(sphere.vertices, rng.normal(scale=0.01, size=(32, len(sphere.vertices), 3)), BLENDVOCA_NAMES, sphere.faces)
    rig.save_said_folder(root / "blendshapes_head" / "FakeC")
    (root / "templates_head").mkdir()
    (root / "blendshapes_head" / "FakeC" / "Neutral.obj").rename(root / "templates_head" / "FakeC.obj")
    with pytest.raises(ValueError, match=r"no manifest.json.*python -m blendvoca.format manifest"):
        open_blendvoca(root)  # a hand-made folder is listed once, then opened
    assert format_main(["manifest", str(root)]) == 0
    ds = open_blendvoca(root)
    np.testing.assert_allclose(ds.rig("FakeC").deltas, rig.deltas, atol=1e-6)
    assert set(ds.splits) == {"train", "val", "test"}  # the VOCASET split (no such subjects here)
    assert ds.split("test") == []
    with pytest.raises(ValueError, match="neither rigs"):
        ds.rig("FakeA")


def test_samples_and_manifest_hash(fake_dataset_dir, tmp_path):
    root = tmp_path / "copy"
    shutil.copytree(fake_dataset_dir, root)
    from blendvoca.io.coeffs import write_coeffs_csv

    from blendvoca.format.manifest import write_folder_manifest

    base = open_blendvoca(root).coeffs("FakeC", "sentence02")
    for k in range(3):
        write_coeffs_csv(root / "blendshape_coeffs" / "FakeC" / f"sentence02-{k}.csv", base * (k + 1) / 4, BLENDVOCA_NAMES)
    assert open_blendvoca(root).samples("FakeC", "sentence02").shape == (1, *base.shape)  # not listed: not seen
    write_folder_manifest(root)
    ds = open_blendvoca(root)
    s = ds.samples("FakeC", "sentence02")
    assert s.shape == (3, *base.shape)
    np.testing.assert_allclose(s[2], base * 0.75, atol=1e-6)
    assert ds.sentences("FakeC") == ["sentence01", "sentence02", "sentence03"]
    manifest = json.loads((root / "manifest.json").read_text())
    del manifest["files"]["blendshape_coeffs/FakeC/sentence02-2.csv"]
    (root / "manifest.json").write_text(json.dumps(manifest))
    assert open_blendvoca(root).manifest_hash != ds.manifest_hash
    (root / "manifest.json").write_text(json.dumps({"changed": True}))
    with pytest.raises(ValueError, match="files"):
        open_blendvoca(root)


def test_manifest_hash_covers_data_files_not_the_report(fake_dataset_dir, tmp_path):
    root = tmp_path / "copy"
    shutil.copytree(fake_dataset_dir, root)

    def hash_with(files):
        (root / "manifest.json").write_text(json.dumps({"files": files, "version": "x"}))
        return open_blendvoca(root).manifest_hash

    data = {"blendshape_coeffs/FakeA/sentence01.csv": "aa", "audio/FakeA/sentence01.wav": "bb"}
    base = hash_with(data)
    assert hash_with({**data, "report/README.md": "cc"}) == base
    (root / "manifest.json").write_text(json.dumps({"files": data, "version": "x", "blas": ["openblas 0.3.31 SkylakeX"]}))
    assert open_blendvoca(root).manifest_hash == base  # the kernels are recorded, not the data's identity
    assert hash_with({**data, "audio/FakeA/sentence01.wav": "bc"}) != base


def test_errors(tmp_path, fake_dataset_dir):
    with pytest.raises(ValueError, match="not a directory"):
        open_blendvoca(tmp_path / "missing")
    with pytest.raises(ValueError, match="manifest.json"):
        open_blendvoca(tmp_path)
    ds = open_blendvoca(fake_dataset_dir)
    with pytest.raises(ValueError, match="unknown split"):
        ds.split("dev")
    with pytest.raises(ValueError, match="unknown subject"):
        ds.coeffs("Nobody", "sentence01")
