"""The recipe id (the dataset's identity across machines) and ``compare`` within stored tolerances."""

import json

import numpy as np
import pytest

from blendvoca import format as fmt
from blendvoca.format.__main__ import main as compare_main
from blendvoca.format.compare import compare_builds, file_difference
from blendvoca.format.recipe import make_recipe, recipe_id


def _corpus(root, text="frames"):
    (root / "a").mkdir(parents=True)
    (root / "a" / "one.txt").write_text(text)
    (root / "two.bin").write_bytes(b"\x00\x01")
    (root / ".hidden").write_text("not the corpus")
    return root


def test_recipe_id_is_stable_and_moves_with_every_input(tmp_path):
    root = _corpus(tmp_path / "c")
    params = {"shapes": "speech", "delta": 0.1}
    first = recipe_id(fmt.corpus_files(root), params, root=root, assets={"rig": "ab"})
    # Same inputs elsewhere (another folder, another order of the parameters): same id.
    other = _corpus(tmp_path / "elsewhere")
    assert recipe_id(fmt.corpus_files(other), {"delta": 0.1, "shapes": "speech"}, root=other,
                     assets={"rig": "ab"}) == first
    (other / ".hidden").write_text("edited")  # hidden files are not the corpus
    assert recipe_id(fmt.corpus_files(other), params, root=other, assets={"rig": "ab"}) == first
    # A changed input file, parameter, asset or format version: another id.
    (other / "a" / "one.txt").write_text("frames!")
    assert recipe_id(fmt.corpus_files(other), params, root=other, assets={"rig": "ab"}) != first
    assert recipe_id(fmt.corpus_files(root), {**params, "delta": 0.2}, root=root, assets={"rig": "ab"}) != first
    assert recipe_id(fmt.corpus_files(root), params, root=root, assets={"rig": "cd"}) != first
    assert recipe_id(fmt.corpus_files(root), params, root=root, assets={"rig": "ab"}, format_version="0") != first
    # A renamed file: another id (names count, not only contents).
    (root / "two.bin").rename(root / "three.bin")
    assert recipe_id(fmt.corpus_files(root), params, root=root, assets={"rig": "ab"}) != first


def test_recipe_takes_named_files_for_adapters(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("1,2\n")
    record = make_recipe([("clips/x.csv", path)], {"fps": 60})
    assert record["inputs"]["files"]["count"] == 1 and len(record["id"]) == 64
    assert record["id"] == recipe_id({"clips/x.csv": path}, {"fps": 60})
    with pytest.raises(ValueError, match="given twice"):
        make_recipe([("x", path), ("x", path)], {})


def _build(root, recipe="r" * 64, coeffs=None, tolerances=None):
    """A minimal build folder: one track, one exact file, a manifest with a recipe and tolerances."""
    root.mkdir(parents=True)
    coeffs = np.array([[0.25, 0.5], [0.125, 0.0]]) if coeffs is None else coeffs
    rel = fmt.write_coeffs(root, "S1", "sentence01", coeffs, ("jawOpen", "mouthClose"))
    fmt.write_splits(root, {"train": ["S1"], "val": [], "test": []})
    files = [rel, fmt.SPLITS_FILE]
    manifest = {"tool": "blendvoca.build", "files": {r: fmt.file_digest(root / r) for r in files},
                "recipe": {"id": recipe},
                "tolerances": fmt.default_tolerances(files) if tolerances is None else tolerances}
    (root / fmt.MANIFEST_FILE).write_text(json.dumps(manifest))
    return root


def test_compare_within_and_beyond_tolerance(tmp_path, capsys):
    base = np.array([[0.25, 0.5], [0.125, 0.0]])
    a = _build(tmp_path / "a", coeffs=base)
    assert fmt.file_tolerance("blendshape_coeffs/S1/sentence01.csv") == pytest.approx(2e-2)
    near = _build(tmp_path / "near", coeffs=base + 0.004)  # a kernel's rounding
    found = compare_builds(a, near)
    assert found.same and found.within == 1 and found.identical == 1
    assert found.max_difference["blendshape_coeffs/S1/sentence01.csv"] == pytest.approx(0.004)
    assert compare_main(["compare", str(a), str(near)]) == 0
    assert "same dataset" in capsys.readouterr().out

    far = _build(tmp_path / "far", coeffs=base + np.array([[0.0, 0.05], [0.0, 0.0]]))
    found = compare_builds(a, far)
    assert not found.same and "blendshape_coeffs/S1/sentence01.csv" in found.problem
    assert "0.05" in found.problem
    assert compare_main(["compare", str(a), str(far)]) == 4
    err = capsys.readouterr().err
    assert "blendshape_coeffs/S1/sentence01.csv" in err and "max difference 0.05" in err


def test_compare_refuses_another_recipe_and_exact_files(tmp_path):
    a = _build(tmp_path / "a")
    other = _build(tmp_path / "other", recipe="s" * 64)
    assert "different recipes" in compare_builds(a, other).problem
    # splits.json has no tolerance: any difference rules the pair out.
    same = _build(tmp_path / "same")
    fmt.write_splits(same, {"train": [], "val": ["S1"], "test": []})
    manifest = json.loads((same / fmt.MANIFEST_FILE).read_text())
    manifest["files"][fmt.SPLITS_FILE] = fmt.file_digest(same / fmt.SPLITS_FILE)
    (same / fmt.MANIFEST_FILE).write_text(json.dumps(manifest))
    assert "byte for byte" in compare_builds(a, same).problem


def test_file_difference_of_structure_is_infinite(tmp_path):
    a = tmp_path / "a.csv"
    b = tmp_path / "b.csv"
    a.write_text("x,y\n1,2\n")
    b.write_text("x,z\n1,2\n")
    assert file_difference(a, b) == float("inf")
    b.write_text("x,y\n1,2.5\n")
    assert file_difference(a, b) == pytest.approx(0.5)


def test_dataset_id_reads_the_recipe_and_falls_back_on_the_content_hash(tmp_path):
    a = _build(tmp_path / "a", recipe="0123456789abcdef" * 4)
    assert fmt.dataset_id(a) == "0123456789abcdef" * 4
    manifest = json.loads((a / fmt.MANIFEST_FILE).read_text())
    del manifest["recipe"]
    (a / fmt.MANIFEST_FILE).write_text(json.dumps(manifest))
    assert fmt.dataset_id(a) == fmt.manifest_hash(a)


def test_folder_manifest_records_a_recipe(tmp_path):
    root = tmp_path / "said"
    fmt.write_coeffs(root, "S1", "sentence01", np.zeros((2, 2)), ("jawOpen", "mouthClose"))
    fmt.write_folder_manifest(root)
    identity = fmt.dataset_id(root)
    assert identity != fmt.manifest_hash(root) and len(identity) == 64
    fmt.write_coeffs(root, "S1", "sentence01", np.ones((2, 2)), ("jawOpen", "mouthClose"))
    fmt.write_folder_manifest(root)
    assert fmt.dataset_id(root) != identity
