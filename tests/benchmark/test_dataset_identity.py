"""Results are named and matched by the dataset's recipe id, not by its content hash."""

import json
import shutil

import pytest

from benchmark.data import open_blendvoca
from benchmark.results import build_result, check
from blendvoca import format as fmt
from blendvoca.errors import UserError

RECIPE = "0123456789ab" + "c" * 52


def _result(dataset):
    return build_result(method={"name": "m", "label": "m", "config": {}}, dataset=dataset,
                        protocol={"samples": 1, "seed": 0}, timings={}, provenance={},
                        metrics={"lve_rig": {"mean": 1.0, "std": 0.1, "higher_is_better": False, "unit": "mm"}})


def test_results_are_named_by_the_recipe_and_read_without_one():
    new = _result({"recipe_id": RECIPE, "manifest_hash": "f" * 64})
    assert new.key == RECIPE and new.filename() == "m__0123456789ab__s1__seed0.json"
    legacy = _result({"manifest_hash": "e" * 64})
    assert legacy.key == "e" * 64 and "__eeeeeeeeeeee__" in legacy.filename()
    with pytest.raises(ValueError, match="recipe_id"):
        check({**legacy.to_json(), "dataset": {"split": "test"}})


def _with_recipe(root, recipe):
    manifest = json.loads((root / fmt.MANIFEST_FILE).read_text())
    manifest["recipe"] = {"id": recipe}
    (root / fmt.MANIFEST_FILE).write_text(json.dumps(manifest))
    return root


def test_site_data_matches_by_recipe_across_contents(fake_dataset_dir, tmp_path):
    from leaderboard.site.data import SiteRun, with_dataset

    # Another machine's build of one recipe: other numbers (another content hash), same recipe id.
    ours = _with_recipe(shutil.copytree(fake_dataset_dir, tmp_path / "ours"), RECIPE)
    theirs = _with_recipe(shutil.copytree(fake_dataset_dir, tmp_path / "theirs"), RECIPE)
    csv = sorted((theirs / fmt.COEFFS_DIR).rglob("*.csv"))[0]
    csv.write_text(csv.read_text().replace("0.", "0.0", 1))
    manifest = json.loads((theirs / fmt.MANIFEST_FILE).read_text())
    manifest["files"][csv.relative_to(theirs).as_posix()] = fmt.file_digest(csv)
    (theirs / fmt.MANIFEST_FILE).write_text(json.dumps(manifest))
    assert open_blendvoca(ours).manifest_hash != open_blendvoca(theirs).manifest_hash
    assert open_blendvoca(ours).recipe_id == open_blendvoca(theirs).recipe_id == RECIPE

    run = SiteRun(tmp_path / "m.json", _result({"recipe_id": RECIPE, "manifest_hash": open_blendvoca(ours).manifest_hash,
                                                "path": str(ours)}))
    (matched,) = with_dataset([run], theirs)
    assert matched.result.dataset.path == str(theirs.resolve())
    other = _with_recipe(shutil.copytree(fake_dataset_dir, tmp_path / "other"), "d" * 64)
    with pytest.raises(UserError, match="recipe"):
        with_dataset([run], other)
