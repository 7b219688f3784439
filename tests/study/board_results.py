"""Result files fabricated for the metrics-against-people tests (benchmark.results.build_result)."""

from __future__ import annotations

from benchmark.results import build_result, write

PROVENANCE = {"date": "2026-01-01", "git_revision": "0" * 40, "git_dirty": False, "python": "3.11",
              "platform": "test", "versions": {}, "hardware": {}}


def fabricated_result(row: str, per_sentence: list[dict], means: dict, *, recipe_id: str = "a" * 64,
                      directions: dict | None = None):
    """A result of row ``row``: ``per_sentence`` rows ``{"subject", "sentence", metric: value}``,
    ``means`` ``{metric: mean}``, each metric higher-is-better unless ``directions`` says otherwise."""
    directions = directions or {}
    metrics = {m: {"mean": float(v), "std": 0.0, "higher_is_better": directions.get(m, True), "unit": ""}
               for m, v in means.items()}
    return build_result(method={"name": row, "config": {}}, dataset={"recipe_id": recipe_id, "split": "test"},
                        protocol={"samples": 1, "seed": 0}, metrics=metrics, timings={}, provenance=PROVENANCE,
                        per_sentence=per_sentence)


def write_result(folder, row, per_sentence, means, **kwargs):
    result = fabricated_result(row, per_sentence, means, **kwargs)
    return write(folder / f"{row}.json", result), result
