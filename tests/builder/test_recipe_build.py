"""A build records its recipe id (its identity on every machine) and its per-file tolerances."""

import json
import shutil

from blendvoca import format as fmt
from blendvoca.builder.pipeline import build_dataset, build_recipe
from blendvoca.builder.worker import static_inputs
from blendvoca.format.compare import compare_builds
from blendvoca.format.hashing import array_digest
from blendvoca.vocaset import open_vocaset


def _expected_recipe(corpus_root, params):
    assets = {**static_inputs(params["shapes"])["assets"],
              "topology": array_digest(open_vocaset(corpus_root).faces)}
    return build_recipe(corpus_root, params, assets)


def test_manifest_records_the_recipe_and_tolerances(built_dataset, synthetic_corpus, tmp_path):
    manifest = json.loads((built_dataset / fmt.MANIFEST_FILE).read_text())
    params = {"shapes": "speech", "delta": 0.1}
    assert manifest["recipe"] == _expected_recipe(synthetic_corpus, params)
    assert fmt.dataset_id(built_dataset) == manifest["recipe"]["id"] != fmt.manifest_hash(built_dataset)
    coeffs = [rel for rel in manifest["files"] if rel.startswith(fmt.COEFFS_DIR + "/")]
    assert coeffs and all(manifest["tolerances"][rel] > 0 for rel in coeffs)
    assert fmt.SPLITS_FILE not in manifest["tolerances"]
    # The same corpus elsewhere has the same recipe; one changed file, another.
    moved = tmp_path / "moved"
    shutil.copytree(synthetic_corpus, moved)
    assert _expected_recipe(moved, params)["id"] == manifest["recipe"]["id"]
    wav = next((moved / "audio").rglob("*.wav"))
    wav.write_bytes(wav.read_bytes()[:-2] + b"\x01\x00")
    assert _expected_recipe(moved, params)["id"] != manifest["recipe"]["id"]


def test_changed_parameter_gives_another_recipe(built_dataset, synthetic_corpus, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(built_dataset, out)
    before = fmt.dataset_id(out)
    build_dataset(out, synthetic_corpus, workers=1, delta=0.2, report=False)
    after = fmt.dataset_id(out)
    assert after != before and after == _expected_recipe(synthetic_corpus, {"shapes": "speech", "delta": 0.2})["id"]
    # Its own build verifies and compares as itself.
    assert compare_builds(out, out).same
