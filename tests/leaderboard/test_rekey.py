"""Re-keying results written before recipe ids: identity field and file name, nothing else."""

import json
import shutil
from pathlib import Path

from benchmark.results import dataset_key, read_result
from leaderboard.rekey import main, rekey_results

COMMITTED = Path(__file__).resolve().parents[2] / "leaderboard" / "results"


def test_rekey_adds_the_recipe_and_renames(tmp_path):
    source = sorted(COMMITTED.glob("mean__*.json"))[0]
    old = json.loads(source.read_text())
    content = old["dataset"]["manifest_hash"]
    old["dataset"].pop("recipe_id", None)
    legacy = tmp_path / f"mean__{content[:12]}__s1__seed0.json"
    legacy.write_text(json.dumps(old, indent=2, sort_keys=True) + "\n")
    (tmp_path / legacy.stem).mkdir()  # its tracks folder moves with it
    old["tracks"] = legacy.stem
    legacy.write_text(json.dumps(old, indent=2, sort_keys=True) + "\n")
    recipe = "ab" * 32
    assert main([str(tmp_path), f"{content}={recipe}"]) == 0
    renamed = tmp_path / f"mean__{recipe[:12]}__s1__seed0.json"
    assert not legacy.exists() and renamed.is_file() and (tmp_path / renamed.stem).is_dir()
    new = json.loads(renamed.read_text())
    assert new["dataset"] == {**old["dataset"], "recipe_id": recipe}
    assert {k: v for k, v in new.items() if k not in ("dataset", "tracks")} == \
        {k: v for k, v in old.items() if k not in ("dataset", "tracks")}
    assert dataset_key(read_result(renamed)) == recipe
    # A second run finds nothing left to do.
    assert rekey_results(tmp_path, {content: recipe}) == []


def test_committed_results_carry_recipe_ids():
    for path in sorted(COMMITTED.glob("*.json")):
        result = read_result(path)
        assert result["dataset"].get("recipe_id"), path
        assert dataset_key(result)[:12] in path.name
