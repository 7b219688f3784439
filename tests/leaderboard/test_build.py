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
    """metrics: name -> (mean, std, higher_is_better, unit[, (lo, hi)])."""
    entries = {}
    for k, (m, s, hib, u, *ci) in metrics.items():
        entries[k] = {"mean": m, "std": s, "higher_is_better": hib, "unit": u}
        if ci:
            entries[k]["ci95"] = list(ci[0])
    return build_result(
        method={"name": label, "label": label, "reference": reference, "config": {}},
        dataset={"manifest_hash": manifest, "split": "test", "num_sentences": 80},
        protocol={"samples": samples, "seed": seed},
        metrics=entries, timings={}, provenance=PROV)


def _three():
    return [
        _result("alpha", "h1", {"fd": (2.0, 0.1, False, "latent^2", (1.9, 2.1)),
                                "av_confidence_geometric": (5.0, 1.0, True, "correlation", (4.0, 6.0))}),
        _result("beta", "h1", {"fd": (1.0, 0.2, False, "latent^2", (0.8, 1.2)),
                               "av_confidence_geometric": (6.0, 1.0, True, "correlation", (5.0, 7.0))}),
        _result("gamma", "h1", {"fd": (3.0, 0.3, False, "latent^2", (2.5, 3.5)),
                                "av_confidence_geometric": (7.0, 1.0, True, "correlation", (6.5, 7.5))}),
        _result("ground-truth", "h1", {"fd": (0.0, 0.0, False, "latent^2", (0.0, 0.0)),
                                       "av_confidence_geometric": (9.0, 1.0, True, "correlation", (8.0, 9.5))},
                reference=True),
        _result("alpha", "h2_other_data", {"fd": (0.5, 0.1, False, "latent^2", (0.4, 0.6))}),
    ]


def test_ranking_respects_direction_and_ties():
    assert ranks([2.0, 1.0, 3.0], False, 2) == [2, 1, 3]
    assert ranks([2.0, 1.0, 3.0], True, 2) == [2, 3, 1]
    assert ranks([1.0001, 1.0, None], False, 2) == [1, 1, None]
    assert ranks([1.0, 2.0], None, 2) == [None, None]
    assert column_decimals([1234.0]) == 1 and column_decimals([1.23]) == 2 and column_decimals([0.0123]) == 4
    assert column_decimals([14.9, 0.034]) == 3 and column_decimals([5.0, 0.0]) == 2 and column_decimals([]) == 2
    assert column_decimals([6270.3, 7.55, -5e-7]) == 1  # a numerical zero does not ask for 4 decimals


def test_grouped_by_manifest_references_apart_columns_in_table_1_order():
    tables = tables_by_manifest(_three())
    assert [t.manifest_hash for t in tables] == ["h1", "h2_other_data"]
    assert [r.label for r in tables[0].rows] == ["alpha", "beta", "gamma"]
    assert [r.label for r in tables[0].references] == ["ground-truth"]
    assert [r.label for r in tables[1].rows] == ["alpha"]
    # lip sync before the distribution metrics, as in the paper
    assert [(g, [c.name for c in cols]) for g, cols in tables[0].groups] == [
        ("lip sync", ["av_confidence_geometric"]), ("distribution", ["fd"])]


def test_best_only_where_intervals_do_not_overlap():
    md = rendered_tables(_three())["leaderboard.md"]
    table1 = md.split("## Dataset")[1]
    distribution = table1.split("### Distribution")[1]
    lipsync = table1.split("### Lip sync")[1].split("###")[0]
    # FD: beta [0.8, 1.2] is clear of alpha [1.9, 2.1]: bold
    assert "| beta | **1.00** [0.80, 1.20] | 1 |" in distribution
    assert "| alpha | 2.00 [1.90, 2.10] | 1 |" in distribution
    # AV confidence: gamma is best but its interval overlaps beta's: nothing bold
    assert "**" not in lipsync
    # the reference row is apart and never highlighted even though it is best
    assert "| *reference rows (not ranked)* |" in distribution
    assert "| *ground-truth* | 0.00 [0.00, 0.00] | 1 |" in distribution
    assert "| Method | FD (latent^2) ↓ | S |" in distribution
    # a lone method on other data is not highlighted, and other data never mixes in
    table2 = md.split("## Dataset")[2]
    assert "**" not in table2 and "beta" not in table2


def test_latex_escapes_highlights_and_fits_the_page():
    results = [_result("a_b & c", "h", {"lve": (1.0, 0.1, False, "mm", (0.9, 1.1))}),
               _result("d", "h", {"lve": (2.0, 0.1, False, "mm", (1.9, 2.1))})]
    tex = rendered_tables(results)["leaderboard.tex"]
    assert r"a\_b \& c & $\mathbf{1.00}$ {\scriptsize $[0.90, 1.10]$} & 1 \\" in tex
    assert r"d & $2.00$ {\scriptsize $[1.90, 2.10]$} & 1 \\" in tex
    assert r"LVE (mm) $\downarrow$" in tex and r"\resizebox{\linewidth}{!}" in tex
    tex = rendered_tables([_result("a", "h", {"fdd": (1.0, 0.1, False, "mm^2")})])["leaderboard.tex"]
    assert r"FDD (abs.) (mm$^{2}$) $\downarrow$" in tex
    # an unregistered metric goes last, under its own name
    tex = rendered_tables([_result("a", "h", {"lve_%": (1.0, 0.1, False, "mm")})])["leaderboard.tex"]
    assert r"lve\_\% (mm) $\downarrow$" in tex


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


def _cli_error(capsys, results, tmp_path):
    code = main(["--results", str(results), "--out", str(tmp_path / "tables")])
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    assert not (tmp_path / "tables").exists()  # nothing written on a refused input
    return code, lines[0]


def _results_with(tmp_path, edit):
    """A results folder with one valid result, then changed by ``edit(result_dict) -> text``."""
    import json

    folder = tmp_path / "results"
    path = write_result(_three()[0], folder)
    path.write_text(edit(json.loads(path.read_text())))
    return folder, path


@pytest.mark.parametrize("edit, fragment", [
    (lambda r: "{\"schema_version\": 1, ", "not valid JSON"),
    (lambda r: "", "not valid JSON"),
    (lambda r: __import__("json").dumps({**r, "metrics": {"fd": {"higher_is_better": False, "std": 0.1}}}),
     "metric 'fd': missing field(s) ['mean']"),
    (lambda r: __import__("json").dumps({k: v for k, v in r.items() if k != "protocol"}), "['protocol']"),
    (lambda r: __import__("json").dumps({**r, "dataset": {**r["dataset"], "manifest_hash": ["h1"]}}),
     "dataset.manifest_hash: expected a string"),
    (lambda r: __import__("json").dumps({**r, "protocol": {**r["protocol"], "samples": "ten"}}),
     "protocol.samples: expected an integer"),
    (lambda r: __import__("json").dumps({**r, "method": {**r["method"], "label": 7}}),
     "method.label: expected a string"),
])
def test_a_bad_result_file_is_one_error_line_naming_it(edit, fragment, tmp_path, capsys):
    folder, path = _results_with(tmp_path, edit)
    code, line = _cli_error(capsys, folder, tmp_path)
    assert code == 2 and str(path) in line and fragment in line, line


def test_a_missing_results_folder_is_one_error_line(tmp_path, capsys):
    code, line = _cli_error(capsys, tmp_path / "no-such-results", tmp_path)
    assert code == 2 and str(tmp_path / "no-such-results") in line
