from pathlib import Path

import pytest

from benchmark.results import build_result, write_result
from leaderboard.build import (
    DEFAULT_OUT_DIR,
    DEFAULT_RESULTS_DIR,
    build_leaderboard,
    main,
    rendered_tables,
)
from leaderboard.collect import column_decimals, ranks, tables_by_manifest

PROV = {"date": "2026-01-01T00:00:00+00:00", "git_revision": None, "versions": {}, "hardware": {}}


def _result(label, manifest, metrics, reference=False, seed=0, samples=1):
    return build_result(
        method={"name": label, "label": label, "reference": reference, "config": {}},
        dataset={"manifest_hash": manifest, "split": "test", "num_sentences": 80},
        protocol={"samples": samples, "seed": seed},
        metrics={k: {"mean": m, "std": s, "higher_is_better": hib, "unit": u} for k, (m, s, hib, u) in metrics.items()},
        timings={}, provenance=PROV)


def _three():
    return [
        _result("alpha", "h1", {"fd": (2.0, 0.1, False, ""), "sync": (5.0, 1.0, True, "")}),
        _result("beta", "h1", {"fd": (1.0, 0.2, False, ""), "sync": (6.0, 1.0, True, "")}),
        _result("gamma", "h1", {"fd": (3.0, 0.3, False, ""), "sync": (7.0, 1.0, True, "")}),
        _result("ground-truth", "h1", {"fd": (0.0, 0.0, False, ""), "sync": (9.0, 1.0, True, "")}, reference=True),
        _result("alpha", "h2_other_data", {"fd": (0.5, 0.1, False, "")}),
    ]


def test_ranking_respects_direction_and_ties():
    assert ranks([2.0, 1.0, 3.0], False, 2) == [2, 1, 3]
    assert ranks([2.0, 1.0, 3.0], True, 2) == [2, 3, 1]
    assert ranks([1.0001, 1.0, None], False, 2) == [1, 1, None]
    assert ranks([1.0, 2.0], None, 2) == [None, None]
    assert column_decimals([1234.0]) == 1 and column_decimals([1.23]) == 2 and column_decimals([0.0123]) == 4
    assert column_decimals([14.9, 0.034]) == 3 and column_decimals([5.0, 0.0]) == 2 and column_decimals([]) == 2


def test_grouped_by_manifest_and_references_first():
    tables = tables_by_manifest(_three())
    assert [t.manifest_hash for t in tables] == ["h1", "h2_other_data"]
    assert [r.label for r in tables[0].rows] == ["ground-truth", "alpha", "beta", "gamma"]
    assert [r.label for r in tables[1].rows] == ["alpha"]


def test_markdown_bold_and_underline():
    md = rendered_tables(_three())["leaderboard.md"]
    table1 = md.split("## Dataset")[1]
    assert "| beta | **1.00 ± 0.20** | <u>6.00 ± 1.00</u> | 1 |" in table1
    assert "| alpha | <u>2.00 ± 0.10</u> | 5.00 ± 1.00 | 1 |" in table1
    assert "| gamma | 3.00 ± 0.30 | **7.00 ± 1.00** | 1 |" in table1
    # the reference row is never highlighted even though it is best
    assert "| ground-truth *(reference)* | 0.00 ± 0.00 | 9.00 ± 1.00 | 1 |" in table1
    assert "| fd ↓ | sync ↑ |" in table1
    # a lone method on other data is not highlighted, and other data never mixes in
    table2 = md.split("## Dataset")[2]
    assert "**" not in table2 and "beta" not in table2


def test_latex_escapes_and_highlights():
    results = [_result("a_b & c", "h", {"lve_%": (1.0, 0.1, False, "mm")}),
               _result("d", "h", {"lve_%": (2.0, 0.1, False, "mm")})]
    tex = rendered_tables(results)["leaderboard.tex"]
    assert r"a\_b \& c & $\mathbf{1.00 \pm 0.10}$ & 1 \\" in tex
    assert r"d & $\underline{2.00 \pm 0.10}$ & 1 \\" in tex
    assert r"lve\_\% (mm) $\downarrow$" in tex
    tex = rendered_tables([_result("a", "h", {"fdd": (1.0, 0.1, False, "mm^2")})])["leaderboard.tex"]
    assert r"fdd (mm$^{2}$) $\downarrow$" in tex


def test_conflicting_metric_direction_refused():
    results = [_result("a", "h", {"x": (1.0, 0.1, False, "")}), _result("b", "h", {"x": (1.0, 0.1, True, "")})]
    with pytest.raises(ValueError, match="metric 'x'"):
        tables_by_manifest(results)


def test_build_is_deterministic(tmp_path):
    for r in _three():
        write_result(r, tmp_path / "results")
    a = [p.read_text() for p in build_leaderboard(tmp_path / "results", tmp_path / "a")]
    assert main(["--results", str(tmp_path / "results"), "--out", str(tmp_path / "b")]) == 0
    b = [(tmp_path / "b" / p).read_text() for p in ("leaderboard.md", "leaderboard.tex")]
    assert a == b


def test_committed_tables_match_committed_results(tmp_path):
    written = build_leaderboard(DEFAULT_RESULTS_DIR, tmp_path)
    for path in written:
        committed = Path(DEFAULT_OUT_DIR) / path.name
        assert committed.is_file(), f"{committed} is not committed; run python -m leaderboard.build"
        assert path.read_text() == committed.read_text(), f"{committed} is stale; run python -m leaderboard.build"
