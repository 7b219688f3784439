"""``python -m leaderboard.rekey RESULTS CONTENT_HASH=RECIPE_ID ...``: file results under their dataset's recipe id.

Results written before recipe ids existed record only the content hash of the
build they were scored on (``dataset.manifest_hash``) and are named by it. Given
which recipe each such build was made from (``python -m blendvoca.build`` of the
same corpus and parameters records it in its manifest: ``recipe.id``), this adds
``dataset.recipe_id`` to each result of that build and renames the file (and its
tracks folder, when there is one) to :func:`benchmark.results.result_filename`'s
name. Nothing else in a file changes; results of other builds, and results that
already have a recipe id, are left as they are.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

from blendvoca import cli
from blendvoca.errors import UserError
from blendvoca.io.atomic import atomic_write

__all__ = ["main", "rekey_results"]


def _check_digest(text: str, what: str) -> str:
    if len(text) != 64 or any(c not in "0123456789abcdef" for c in text):
        raise UserError(f"{what}: expected 64 lowercase hex digits, got {text!r}")
    return text


def rekey_results(results_dir, mapping: dict[str, str]) -> list[tuple[str, str]]:
    """Add ``dataset.recipe_id`` to the results of the builds in ``mapping`` and rename them.

    Parameters
    ----------
    results_dir : path-like
        A folder of result files (``*.json``).
    mapping : dict
        ``{content hash: recipe id}``, 64 hex digits each.

    Returns
    -------
    list of (str, str)
        ``(old name, new name)`` of every file rewritten, sorted.

    Raises
    ------
    UserError
        A new name that another file already has.
    """
    from benchmark.results import read_result, result_filename
    from benchmark.runs import tracks_folder_name

    root = Path(os.fspath(results_dir))
    done = []
    for path in sorted(root.glob("*.json")):
        read_result(path)  # a file that is not a result is refused, not rewritten
        raw = json.loads(path.read_text(encoding="utf-8"))
        dataset = raw["dataset"]
        recipe = mapping.get(dataset.get("manifest_hash"))
        if recipe is None or dataset.get("recipe_id"):
            continue
        raw["dataset"] = {**dataset, "recipe_id": recipe}
        name = result_filename(raw)
        target = root / name
        if target.exists() and target != path:
            raise UserError(f"{path}: would be renamed to {name}, which exists")
        old_tracks, new_tracks = root / tracks_folder_name(path.name), root / tracks_folder_name(name)
        if raw.get("tracks") == tracks_folder_name(path.name):
            raw["tracks"] = tracks_folder_name(name)
        with atomic_write(target, "w", encoding="utf-8") as f:
            f.write(json.dumps(raw, indent=2, sort_keys=True, allow_nan=False) + "\n")
        if target != path:
            path.unlink()
            if old_tracks.is_dir():
                old_tracks.rename(new_tracks)
        done.append((path.name, name))
    return done


@cli.command
def main(argv: list[str] | None = None) -> int:
    """Re-key the results of builds whose recipe is known; prints one ``old -> new`` line per file."""
    p = cli.parser("leaderboard.rekey", __doc__)
    p.add_argument("results", help="the folder of result files")
    p.add_argument("pairs", nargs="+", metavar="CONTENT_HASH=RECIPE_ID",
                   help="a build's content hash (dataset.manifest_hash) and the recipe id of that build")
    args = p.parse_args(argv)
    mapping = {}
    for pair in args.pairs:
        content, sep, recipe = pair.partition("=")
        if not sep:
            raise UserError(f"{pair!r}: expected CONTENT_HASH=RECIPE_ID")
        mapping[_check_digest(content, "content hash")] = _check_digest(recipe, "recipe id")
    for old, new in rekey_results(args.results, mapping):
        print(f"{old} -> {new}")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
