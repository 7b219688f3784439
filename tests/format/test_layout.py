"""The BlendVOCA folder layout: names, paths, the structure read off a listing, and the
items written and read back through blendvoca.format."""

import json

import numpy as np
import pytest

from blendvoca import format as fmt
from blendvoca.errors import DataError
from blendvoca.names import BLENDVOCA_NAMES


def test_relative_paths_and_paths_name_the_same_files(tmp_path):
    assert fmt.coeffs_relpath("S", "sentence01") == "blendshape_coeffs/S/sentence01.csv"
    assert fmt.coeffs_relpath("S", "sentence01", sample=2) == "blendshape_coeffs/S/sentence01-2.csv"
    assert fmt.audio_relpath("S", "sentence01") == "audio/S/sentence01.wav"
    assert fmt.rig_relpath("S") == "rigs/S.npz"
    assert fmt.template_relpath("S") == "templates_head/S.obj"
    assert fmt.blendshape_relpath("S", "jawOpen") == "blendshapes_head/S/jawOpen.obj"
    root = str(tmp_path)  # str or PathLike
    assert fmt.coeffs_path(root, "S", "sentence01", 2) == tmp_path / fmt.coeffs_relpath("S", "sentence01", 2)
    assert fmt.audio_path(tmp_path, "S", "sentence01") == tmp_path / fmt.audio_relpath("S", "sentence01")
    assert fmt.rig_path(root, "S") == tmp_path / "rigs" / "S.npz"
    assert fmt.template_path(root, "S") == tmp_path / "templates_head" / "S.obj"
    assert fmt.blendshapes_dir(root, "S") == fmt.blendshape_path(root, "S", "jawOpen").parent
    assert fmt.manifest_path(root) == tmp_path / "manifest.json"
    assert fmt.splits_path(root) == tmp_path / "splits.json"
    assert fmt.coeffs_std_path(root) == tmp_path / "coeffs_std.csv"
    assert fmt.is_report_file("report/README.md") and not fmt.is_report_file("reports.csv")


def test_the_structure_read_off_a_listing():
    listed = ["blendshape_coeffs/B/sentence02.csv", "blendshape_coeffs/B/sentence01.csv",
              "blendshape_coeffs/B/sentence01-10.csv", "blendshape_coeffs/B/sentence01-2.csv",
              "blendshape_coeffs/B/sentence011-0.csv", "blendshape_coeffs/B/notes.txt",
              "blendshape_coeffs/A/sentence03.csv", "blendshape_coeffs/A/deep/sentence04.csv",
              "audio/C/sentence01.wav", "splits.json"]
    assert fmt.listed_subjects(listed) == ["A", "B"]  # a folder with a file directly in it
    assert fmt.listed_sentences(listed, "B") == ["sentence01", "sentence02"]
    assert fmt.listed_sentences(listed, "A") == ["sentence03"]  # not the file in a subfolder
    # in sample-number order (2 before 10), only that sentence's
    assert fmt.listed_samples(listed, "B", "sentence01") == ["blendshape_coeffs/B/sentence01-2.csv",
                                                             "blendshape_coeffs/B/sentence01-10.csv"]
    assert fmt.listed_samples(listed, "B", "sentence02") == []


def test_items_round_trip(tmp_path):
    from blendvoca.rig import Rig

    rng = np.random.default_rng(0)
    coeffs = rng.uniform(size=(7, 32))
    written = [fmt.write_coeffs(tmp_path, "S", "sentence01", coeffs, BLENDVOCA_NAMES),
               fmt.write_coeffs(tmp_path, "S", "sentence01", coeffs[::-1], BLENDVOCA_NAMES, sample=1)]
    assert written == [fmt.coeffs_relpath("S", "sentence01"), fmt.coeffs_relpath("S", "sentence01", 1)]
    back, names = fmt.read_coeffs(tmp_path, "S", "sentence01")
    assert names == BLENDVOCA_NAMES and back.dtype == np.float64
    np.testing.assert_allclose(back, coeffs, atol=5e-7)  # 6 decimals
    np.testing.assert_allclose(fmt.read_coeffs(tmp_path, "S", "sentence01", sample=1, names=["jawOpen"])[0][:, 0],
                               coeffs[::-1, BLENDVOCA_NAMES.index("jawOpen")], atol=5e-7)

    stereo = np.stack([np.sin(np.linspace(0, 50, 32000)), np.zeros(32000)], axis=1) * 0.5
    assert fmt.write_audio(tmp_path, "S", "sentence01", stereo, 32000) == fmt.audio_relpath("S", "sentence01")
    audio, rate = fmt.read_audio(tmp_path, "S", "sentence01")
    assert rate == fmt.AUDIO_RATE == 16000 and audio.dtype == np.float32 and audio.shape == (16000,)
    assert 0.2 < np.abs(audio).max() < 0.3  # the channels averaged

    rig = Rig(rng.normal(size=(4, 3)), 0.01 * rng.normal(size=(2, 4, 3)), ("jawOpen", "mouthClose"),
              np.array([[0, 1, 2], [1, 2, 3]]))
    assert fmt.write_rig(tmp_path, "S", rig) == fmt.rig_relpath("S")
    np.testing.assert_array_equal(fmt.read_rig(tmp_path, "S").deltas, rig.deltas)
    files = fmt.write_said_rig(tmp_path, "S", rig.neutral, rig.deltas, rig.names, rig.faces)
    assert files == [fmt.template_relpath("S"), fmt.blendshape_relpath("S", "jawOpen"),
                     fmt.blendshape_relpath("S", "mouthClose")]
    said = fmt.read_said_rig(str(tmp_path), "S", rig.names)
    np.testing.assert_allclose(said.deltas, rig.deltas, atol=1e-8)
    with pytest.raises(DataError, match="neither rigs/T.npz nor templates_head/T.obj"):
        fmt.read_said_rig(tmp_path, "T", rig.names)

    splits = {"train": ["S"], "val": [], "test": ["T"]}
    assert fmt.write_splits(tmp_path, splits) == fmt.SPLITS_FILE
    assert fmt.read_splits(tmp_path) == splits
    fmt.splits_path(tmp_path).write_text("[1]")
    with pytest.raises(DataError, match="expected an object of split -> subjects"):
        fmt.read_splits(tmp_path)
    fmt.splits_path(tmp_path).write_text("{")
    with pytest.raises(DataError, match="splits.json: not readable JSON"):
        fmt.read_splits(tmp_path)

    assert fmt.write_coeffs_std(tmp_path, [0.5, 0.25], ["jawOpen", "mouthClose"]) == fmt.COEFFS_STD_FILE
    assert fmt.coeffs_std_path(tmp_path).read_text() == "jawOpen,mouthClose\n0.5000,0.2500\n"


def test_the_folder_manifest_lists_the_data_and_names_the_dataset(tmp_path):
    fmt.write_coeffs(tmp_path, "S", "sentence01", np.zeros((3, 32)), BLENDVOCA_NAMES)
    (tmp_path / "notes.txt").write_text("not data")
    fmt.write_folder_manifest(tmp_path)
    assert set(fmt.listed_files(tmp_path)) == {fmt.coeffs_relpath("S", "sentence01")}
    assert not fmt.written_by_build(tmp_path) and fmt.recorded_vocaset(tmp_path) is None
    identity = fmt.manifest_hash(tmp_path)
    manifest = fmt.read_manifest(tmp_path)
    manifest["files"]["report/README.md"] = "00"
    fmt.manifest_path(tmp_path).write_text(json.dumps(manifest))
    assert fmt.manifest_hash(tmp_path) == identity  # the report is not the data's identity
    fmt.remove_manifest(tmp_path)
    fmt.remove_manifest(tmp_path)  # no manifest: nothing to do
    with pytest.raises(fmt.ManifestError, match="has no manifest.json"):
        fmt.listed_files(tmp_path)
