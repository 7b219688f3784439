"""Each leaderboard section names its dataset, and says when its latent metrics are out of domain."""

from benchmark.results import build_result
from benchmark.results import DatasetInfo
from leaderboard.collect import tables_by_manifest
from leaderboard.render import OUT_OF_DOMAIN_NOTE, markdown_tables

PROV = {"date": "2026-01-01T00:00:00+00:00", "git_revision": None, "versions": {}, "hardware": {}}


def _result(label, manifest, dataset=None, protocol=None):
    return build_result(
        method={"name": label, "label": label, "reference": False, "config": {}},
        dataset={"manifest_hash": manifest, "split": "test", "num_sentences": 8, **(dataset or {})},
        protocol={"samples": 1, "seed": 0, **(protocol or {})},
        metrics={"fd": {"mean": 1.0, "std": 0.1, "higher_is_better": False, "unit": "latent^2"}},
        timings={}, provenance=PROV)


def test_sections_carry_the_dataset_name_and_the_out_of_domain_note():
    results = [
        _result("alpha", "h_beat", {"name": "beat", "title": "BEAT", "latent_out_of_domain": True}),
        _result("beta", "h_beat", {"name": "beat", "title": "BEAT"}),
        _result("alpha", "h_voca", {"name": "vocaset"}),
        _result("alpha", "h_old"),
    ]
    tables = {t.manifest_hash: t for t in tables_by_manifest(results)}
    assert tables["h_beat"].name == "BEAT" and tables["h_beat"].latent_out_of_domain
    assert tables["h_voca"].name == "vocaset" and not tables["h_voca"].latent_out_of_domain
    assert tables["h_old"].name == ""
    text = markdown_tables(list(tables.values()))
    assert "## BEAT: dataset `h_beat`" in text and "## vocaset: dataset `h_voca`" in text
    assert "## Dataset `h_old`" in text
    assert text.count(OUT_OF_DOMAIN_NOTE) == 1
    assert DatasetInfo(name="beat", recipe_id="r").display_name == "beat"
    assert DatasetInfo(recipe_id="r").display_name == ""
