from pathlib import Path

import pytest

from benchmark.results import build_result, check, write
from leaderboard import build
from leaderboard.build import (
    DEFAULT_OUT_DIR,
    DEFAULT_RESULTS_DIR,
    build_leaderboard,
    main,
)
from leaderboard.collect import column_decimals, ranks

PROV = {"date": "2026-01-01T00:00:00+00:00", "git_revision": None, "versions": {}, "hardware": {}}


# the tests edit results as JSON records; these read them as the files are read (benchmark.results.check)
def _typed(results):
    return [check(r) if isinstance(r, dict) else r for r in results]


def tables_by_manifest(results):
    """The tables as leaderboard.build makes them (each row's settled statements filled)."""
    from leaderboard.settled import tables_with_statements

    return tables_with_statements(_typed(results))


def rendered_tables(results):
    return build.rendered_tables(_typed(results))


def write_result(result, folder, filename=None):
    typed = check(result)
    return write(Path(folder) / (filename or typed.filename()), typed)


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
        metrics=entries, timings={}, provenance=PROV).to_json()


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
    assert "| beta | **1.00** [0.80, 1.20] | 1 | - |" in distribution
    assert "| alpha | 2.00 [1.90, 2.10] | 1 | - |" in distribution
    # AV confidence: gamma is best but its interval overlaps beta's: nothing bold
    assert "**" not in lipsync
    # the reference row is apart and never highlighted even though it is best
    assert "| *reference rows (not ranked)* |" in distribution
    assert "| *ground-truth* | 0.00 [0.00, 0.00] | 1 | - |" in distribution
    assert "| Method | FD (latent^2) ↓ | S | RTF |" in distribution
    # these results store nothing to resample: the older rule, and the table says so
    assert "Best in FD by the older rule" in distribution
    # a lone method on other data is not highlighted, and other data never mixes in
    table2 = md.split("## Dataset")[2]
    assert "**" not in table2 and "beta" not in table2


def test_latex_escapes_highlights_and_fits_the_page():
    results = [_result("a_b & c", "h", {"lve_rig": (1.0, 0.1, False, "mm", (0.9, 1.1))}),
               _result("d", "h", {"lve_rig": (2.0, 0.1, False, "mm", (1.9, 2.1))})]
    tex = rendered_tables(results)["leaderboard.tex"]
    assert r"a\_b \& c & $\mathbf{1.00}$ {\scriptsize $[0.90, 1.10]$} & 1 & - \\" in tex
    assert r"d & $2.00$ {\scriptsize $[1.90, 2.10]$} & 1 & - \\" in tex
    assert r"LVE rig (mm) $\downarrow$" in tex and r"\resizebox{\linewidth}{!}" in tex
    tex = rendered_tables([_result("a", "h", {"fdd_mesh": (1.0, 0.1, False, "mm^2")})])["leaderboard.tex"]
    assert r"FDD (abs.) mesh (mm$^{2}$) $\downarrow$" in tex
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
     "metrics.fd: lacks 'mean'"),
    (lambda r: __import__("json").dumps({k: v for k, v in r.items() if k != "protocol"}), "lacks 'protocol'"),
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


# ---------------------------------------------------------------- protocol v3: resampling, seeds, settling

import json  # noqa: E402
import zlib  # noqa: E402

import numpy as np  # noqa: E402

from benchmark.metrics.bootstrap import mean_replicates, probability_of_improvement  # noqa: E402
from leaderboard.collect import (  # noqa: E402
    BEST_PROBABILITY,
    best_mark,
    load_results,
    pairwise_probabilities,
)
from leaderboard.render import AV_OFFSET_NOTE, NOT_SETTLED_MARK  # noqa: E402

SENTENCES = [("S1", f"sentence{i:02d}") for i in range(1, 21)] + [("S2", f"sentence{i:02d}") for i in range(1, 21)]


def _rows(values, name):
    return [{"subject": s, "sentence": q, name: float(v)} for (s, q), v in zip(SENTENCES, values)]


def _entry(values, name, hib=False, unit="mm"):
    values = np.asarray(values, dtype=float)
    mean = float(values.mean())
    lo, hi = np.quantile(mean_replicates(values, resamples=500, seed=0), [0.025, 0.975])
    return {"mean": mean, "std": float(values.std()), "higher_is_better": hib, "unit": unit,
            "ci95": [min(float(lo), mean), max(float(hi), mean)], "n": values.size}


def _sentence_result(label, values, name="lve_rig", reference=False, manifest="h", **extra):
    result = build_result(
        method={"name": label, "label": label, "reference": reference, "config": {}},
        dataset={"manifest_hash": manifest, "split": "test", "num_sentences": len(values)},
        protocol={"samples": 1, "seed": 0}, metrics={name: _entry(values, name)}, timings={}, provenance=PROV,
        per_sentence=_rows(values, name)).to_json()
    result.update(extra)
    return result


def _seeds_result(label, per_seed_values, name="lve_rig", **extra):
    """A row trained with several seeds: per_seed rows, seed_range, the mean over seeds."""
    per_seed_values = [np.asarray(v, dtype=float) for v in per_seed_values]
    pooled = np.mean(per_seed_values, axis=0)
    entry = _entry(pooled, name)
    means = [float(v.mean()) for v in per_seed_values]
    entry["ci95"] = [min(entry["ci95"][0], min(means)), max(entry["ci95"][1], max(means))]
    entry["seed_range"] = [min(means), max(means)]
    result = _sentence_result(label, pooled, name, **extra)
    result["metrics"][name] = entry
    result["seeds"] = list(range(len(per_seed_values)))
    result["per_seed"] = [{"seed": k, "metrics": {name: m}, "per_sentence": _rows(v, name)}
                          for k, (v, m) in enumerate(zip(per_seed_values, means))]
    return result


def _section(md, title):
    return md.split(f"### {title}")[1].split("\n### ")[0]


def test_best_needs_95_percent_of_paired_resamples_over_sentences():
    rng = np.random.default_rng(0)
    base = rng.normal(3.0, 1.0, size=len(SENTENCES))  # sentences differ a lot
    results = [_sentence_result("a", base), _sentence_result("b", base + 0.05),  # b worse on every sentence
               _sentence_result("gt", base - 1.0, reference=True)]
    ci_a, ci_b = results[0]["metrics"]["lve_rig"]["ci95"], results[1]["metrics"]["lve_rig"]["ci95"]
    assert ci_a[1] > ci_b[0]  # the intervals overlap: the older rule would mark nothing
    (table,) = tables_by_manifest(results)
    mark = best_mark(table.rows, table.columns[0])
    assert mark.rule == "resampling" and mark.probability == 1.0 and set(mark.rows) == {0}
    vertex = _section(rendered_tables(results)["leaderboard.md"], "Vertex")
    assert f"| a | **{base.mean():.2f}** " in vertex
    assert "older rule" not in vertex
    # the reference row is better still but never marked
    assert "| *gt* | " in vertex and "**" not in vertex.split("reference rows")[1]

    # a difference the resamples do not support: nothing marked
    noise = rng.normal(0.0, 0.5, size=base.size)
    noisy = base + noise - noise.mean() + 0.02  # worse by 0.02 on average, by +-0.5 per sentence
    results = [_sentence_result("a", base), _sentence_result("b", noisy)]
    (table,) = tables_by_manifest(results)
    mark = best_mark(table.rows, table.columns[0])
    a, b = base, noisy
    expected = probability_of_improvement(*(mean_replicates(v, resamples=2000, seed=zlib.crc32(b"lve_rig"))
                                            for v in ((a, b) if a.mean() < b.mean() else (b, a))),
                                          higher_is_better=False)
    assert mark.probability == pytest.approx(expected) and mark.probability < BEST_PROBABILITY
    assert not mark.rows and "**" not in _section(rendered_tables(results)["leaderboard.md"], "Vertex")


def test_common_sentences_only_are_paired():
    base = np.linspace(1.0, 5.0, len(SENTENCES))
    a = _sentence_result("a", base)
    b = _sentence_result("b", base + 0.1)
    b["per_sentence"] = b["per_sentence"][5:] + [{"subject": "S9", "sentence": "extra", "lve_rig": 100.0}]
    (table,) = tables_by_manifest([a, b])
    mark = best_mark(table.rows, table.columns[0])
    assert mark.rule == "resampling" and mark.probability == 1.0  # the extra sentence is not compared


def test_too_few_sentences_are_not_resampled():
    # 4 sentences, b worse on each: every resample agrees, but a sign test gives p = 1/16
    base = np.array([1.0, 2.0, 3.0, 4.0])
    results = [_sentence_result("a", base), _sentence_result("b", base + 0.01)]
    for r in results:
        r["per_sentence"] = r["per_sentence"][:4]
    (table,) = tables_by_manifest(results)
    mark = best_mark(table.rows, table.columns[0])
    assert mark.rule == "intervals" and not mark.rows
    assert "fewer than 5 sentences" in _section(rendered_tables(results)["leaderboard.md"], "Vertex")
    five = [_sentence_result("a", np.r_[base, 5.0]), _sentence_result("c", np.r_[base, 5.0] + 0.02)]
    (table,) = tables_by_manifest(five)
    assert best_mark(table.rows, table.columns[0]).rule == "resampling"  # five in common


def test_two_level_marks_and_seed_ranges():
    rng = np.random.default_rng(1)
    sentences = rng.normal(0.0, 0.05, size=len(SENTENCES))
    # a: two seeds far apart (means 1 and 3, pooled 2); b: one seed at 2.5. Over sentences
    # only, a would beat b every time; with its seeds resampled, only when seed 0 is drawn
    a = _seeds_result("a", [1.0 + sentences, 3.0 + sentences])
    b = _sentence_result("b", 2.5 + sentences)
    (table,) = tables_by_manifest([a, b])
    assert table.rows[0].seeds == (0, 1) and table.rows[0].seed_ranges["lve_rig"] == pytest.approx((1.0, 3.0), abs=0.01)
    mark = best_mark(table.rows, table.columns[0])
    assert mark.rule == "resampling" and 0.6 < mark.probability < 0.9 and not mark.rows  # P = 3/4 in expectation
    md = _section(rendered_tables([a, b])["leaderboard.md"], "Vertex")
    assert "| a | 2.00 [1.00, 3.00] seeds [1.00, 3.00] | 1 | - |" in md and "**" not in md
    tex = rendered_tables([a, b])["leaderboard.tex"]
    assert r"seeds $[1.00, 3.00]$" in tex
    # seeds that agree: marked
    a = _seeds_result("a", [1.0 + sentences, 1.1 + sentences])
    (table,) = tables_by_manifest([a, b])
    assert best_mark(table.rows, table.columns[0]).rows == {0}


def _set_result(label, replicates, mean, **extra):
    metrics = {"fd": {"mean": mean, "std": None, "higher_is_better": False, "unit": "latent^2",
                      "ci95": [min(mean, min(replicates)), max(mean, max(replicates))], "replicates": replicates}}
    result = build_result(method={"name": label, "label": label, "reference": False, "config": {}},
                          dataset={"manifest_hash": "h", "split": "test", "num_sentences": 40},
                          protocol={"samples": 5, "seed": 0}, metrics=metrics, timings={},
                          provenance=PROV).to_json()
    result.update(extra)
    return result


def test_set_level_metrics_use_their_replicates_and_the_matrix_agrees():
    rng = np.random.default_rng(2)
    shared = rng.normal(0.0, 2.0, size=1000)  # the resampled sentences' effect, common to both rows
    results = [_set_result("a", (10.0 + shared).tolist(), 10.0), _set_result("b", (10.5 + shared).tolist(), 10.5),
               _set_result("c", (10.2 + rng.normal(0, 2.0, 1000)).tolist(), 10.2)]
    (table,) = tables_by_manifest(results)
    column = table.columns[0]
    mark = best_mark(table.rows, column)
    # a and c are the two best; c's replicates are not paired with a's: no sure order
    assert mark.rule == "resampling" and (mark.best, mark.runner_up) == (0, 2) and not mark.rows
    matrix = pairwise_probabilities(table.rows, column)
    assert matrix[0][1] == 1.0 and matrix[1][0] == 0.0  # paired: a beats b in every resample
    assert matrix[0][2] == pytest.approx(mark.probability)
    for i in range(3):
        assert matrix[i][i] is None
        for j in range(3):
            if i != j:
                assert matrix[i][j] + matrix[j][i] == pytest.approx(1.0)
    # per-seed replicates are resampled at two levels
    seeds = [(9.0 + shared).tolist(), (11.0 + shared).tolist()]
    two = _set_result("a", seeds[0], 10.0, seeds=[0, 1],
                      per_seed=[{"seed": 0, "metrics": {"fd": 9.0}, "replicates": {"fd": seeds[0]}},
                                {"seed": 1, "metrics": {"fd": 11.0}, "replicates": {"fd": seeds[1]}}])
    (table,) = tables_by_manifest([two, results[1]])
    assert table.rows[0].seed_ranges["fd"] == (9.0, 11.0)  # from per_seed metrics (no seed_range stored)
    p = best_mark(table.rows, table.columns[0]).probability
    assert 0.6 < p < 0.9  # beats b (10.5) when seed 0 is drawn at least once: 3/4


def test_old_files_fall_back_to_the_interval_rule_and_say_so():
    md = rendered_tables(_three())["leaderboard.md"]
    assert "Best in FD by the older rule (95 % interval disjoint from the runner-up's)" in md
    tex = rendered_tables(_three())["leaderboard.tex"]
    assert "by the older rule" in tex


def test_not_settled_rows_are_marked_with_a_line_under_the_table():
    # settled by ranking (leaderboard.settled; more cases in test_settled.py): moving's half-budget LVE rig
    # (2.31) is worse than steady's (2.0) on every sentence, its full-budget one (1.5) better on every one
    base = np.linspace(1.0, 2.0, len(SENTENCES))
    convergence = {"checked_at_step": 750, "total_steps": 1500, "settled": False,
                   "metrics": {"lve_rig": {"half_budget": 2.31, "full_budget": 1.5, "half_width": 0.05,
                                           "settled": False},
                               "fd": {"half_budget": 3.0, "full_budget": 3.01, "half_width": 0.5, "settled": True}}}
    results = [_sentence_result("moving", base, convergence=convergence),
               _sentence_result("steady", base + 0.5, convergence={**convergence, "settled": True, "metrics": {}})]
    md = rendered_tables(results)["leaderboard.md"]
    vertex = _section(md, "Vertex")
    assert f"| moving {NOT_SETTLED_MARK} | **" in vertex and "| steady | " in vertex
    assert (f"{NOT_SETTLED_MARK} Not settled (its half-budget values in place of its full-budget ones would change "
            "these statements of the table): moving: at step 750 of 1500 (resamples shifted by the move), LVE rig "
            "2.31 (now 1.5) would make steady bold (now moving is), would lose to steady (now beats it, P = 1.00).") \
        in vertex
    tex = rendered_tables(results)["leaderboard.tex"]
    assert r"moving $^\dagger$ & " in tex and r"LVE rig 2.31 (now 1.5) would make steady bold" in tex
    # rows without a convergence record (they do not train) carry no mark
    assert NOT_SETTLED_MARK not in _section(rendered_tables(results[1:])["leaderboard.md"], "Vertex")
    # the same move that stays on the same side of every row changes no statement: no mark
    results[1] = _sentence_result("steady", base + 1.0, convergence={**convergence, "settled": True, "metrics": {}})
    assert NOT_SETTLED_MARK not in _section(rendered_tables(results)["leaderboard.md"], "Vertex")


def test_a_row_alone_with_moving_seeds_changes_no_statement():
    base = np.linspace(1.0, 2.0, len(SENTENCES))

    def check(half, full, width, settled):
        return {"half_budget": half, "full_budget": full, "half_width": width, "settled": settled}

    # the seed mean moves 3.10 -> 3.09 within 0.26, but seeds 1 and 2 moved by more than their own half-widths:
    # the record says so (information); with no other row in the table, no statement can change
    convergence = {"checked_at_step": 10000, "total_steps": 12000, "settled": False,
                   "metrics": {"lve_rig": check(3.10, 3.09, 0.26, False), "fd": check(3.2, 14.2, 8.3, False)}}
    per_seed = [{"seed": 0, "convergence": {"metrics": {"lve_rig": check(2.88, 2.84, 0.10, True)}}},
                {"seed": 1, "convergence": {"metrics": {"lve_rig": check(3.25, 2.95, 0.086, False)}}},
                {"seed": 2, "convergence": {"metrics": {"lve_rig": check(3.18, 3.46, 0.079, False)}}}]
    result = _sentence_result("seeded", base, convergence=convergence)
    result["per_seed"] = per_seed
    (table,) = tables_by_manifest([result])
    assert table.rows[0].statements == [] and table.rows[0].settled is True
    assert [s for s, *_ in table.rows[0].unsettled_seeds("lve_rig")] == [1, 2]
    assert NOT_SETTLED_MARK not in _section(rendered_tables([result])["leaderboard.md"], "Vertex")


def test_a_row_scoring_another_rows_training_carries_its_verdict_under_the_table():
    from benchmark.protocol.convergence import shared_convergence

    base = np.linspace(1.0, 2.0, len(SENTENCES))
    owner = {"checked_at_step": 3750, "total_steps": 4500, "settled": False,
             "metrics": {"lve_rig": {"half_budget": 3.0, "full_budget": 1.5, "half_width": 0.5, "settled": False}}}
    shared = shared_convergence(owner, "owner")
    assert shared == {"shared_with": "owner", "checked_at_step": 3750, "total_steps": 4500, "metrics": {},
                      "settled": False}
    assert shared_convergence(None, "owner") is None  # an unchecked training passes nothing on
    md = rendered_tables([_sentence_result("owner", base, convergence=owner),
                          _sentence_result("variant", base + 1.0, convergence=shared)])["leaderboard.md"]
    vertex = _section(md, "Vertex")
    assert f"| variant {NOT_SETTLED_MARK} | " in vertex and f"| owner {NOT_SETTLED_MARK} | " in vertex
    assert "owner: at step 3750 of 4500 (resamples shifted by the move), LVE rig 3 (now 1.5) would make variant " \
           "bold (now owner is), would lose to variant (now beats it, P = 1.00); variant: row owner's training, " \
           "not settled there." in vertex


def test_av_offset_columns_carry_the_ground_truth_lag_note():
    results = [_result("a", "h", {"av_offset_geometric": (0.1, 0.1, False, "frames@60fps", (0.0, 0.2)),
                                  "av_lag_bias_geometric": (0.2, 0.1, None, "frames@60fps", (0.1, 0.3))}),
               _result("b", "h", {"fd": (1.0, 0.1, False, "latent^2", (0.9, 1.1))})]
    md = rendered_tables(results)["leaderboard.md"]
    assert AV_OFFSET_NOTE in _section(md, "Lip sync") and AV_OFFSET_NOTE not in _section(md, "Distribution")
    assert "uniform over -2..2 frames" in AV_OFFSET_NOTE and "0 for the ground truth" in AV_OFFSET_NOTE
    tex = rendered_tables(results)["leaderboard.tex"]
    assert r"\texttt{av\_offset\_*}" in tex and r"\texttt{av\_lag\_bias\_*}" in tex


def test_an_older_result_file_is_one_error_line_saying_what_to_run(tmp_path, capsys):
    folder = tmp_path / "results"
    new = write_result(_three()[0], folder)
    old = folder / "old.json"
    for version, remedy in ((2, "python -m benchmark.results upgrade"), (1, "python -m benchmark.run")):
        old.write_text(json.dumps({**json.loads(new.read_text()), "schema_version": version}))
        code, line = _cli_error(capsys, folder, tmp_path)
        assert code == 2 and f"{old}: a schema-{version} result file" in line and remedy in line
        from leaderboard.site.data import load_site_runs

        with pytest.raises(ValueError, match=f"schema-{version} result file"):
            load_site_runs(folder)


def test_rows_scored_by_different_lip_sync_experts_are_not_mixed_in_one_table(tmp_path, capsys):
    folder = tmp_path / "results"

    def scored_by(label, digest, manifest="h1", file_digest=None):
        result = _result(label, manifest, {"av_confidence_expert": (0.5, 0.1, True, "distance", (0.4, 0.6))})
        record = {"path": "/cache/expert.pt", "sha256": file_digest or digest}
        if file_digest:
            record["weights_sha256"] = digest
        result["protocol"]["lipsync_models"] = {"sync_expert": record}
        return write_result(result, folder)

    first = scored_by("alpha", "a" * 64)
    scored_by("beta", "a" * 64)
    assert [r.label for r in tables_by_manifest(load_results(folder))[0].rows] == ["alpha", "beta"]
    # the same weights trained again elsewhere: another file digest, one table
    (folder / "beta__h1__s1__seed0.json").unlink()
    first.unlink()
    first = scored_by("alpha", "c" * 64, file_digest="1" * 64)
    scored_by("beta", "c" * 64, file_digest="2" * 64)
    assert [r.label for r in tables_by_manifest(load_results(folder))[0].rows] == ["alpha", "beta"]
    other = scored_by("gamma", "b" * 64)  # the same expert name, another checkpoint
    code, line = _cli_error(capsys, folder, tmp_path)
    assert code == 2 and "different lip-sync models" in line and "sync_expert" in line
    assert f"bbbbbbbbbbbb: {other}" in line and str(first) in line
    from leaderboard.site.data import load_site_runs

    with pytest.raises(ValueError, match="different lip-sync models"):
        load_site_runs(folder)
    # on other data it is another table: fine
    other.unlink()
    scored_by("gamma", "b" * 64, manifest="h2")
    assert [t.manifest_hash for t in tables_by_manifest(load_results(folder))] == ["h1", "h2"]


@pytest.mark.parametrize("edit, fragment", [
    (lambda r: {**r, "seeds": [0, "1"]}, "seeds: expected a list of integers"),
    (lambda r: {**r, "per_seed": {"seed": 0}}, "per_seed: expected a list of objects"),
    (lambda r: {**r, "per_seed": [{"seed": 0, "per_sentence": [{"sentence": "s"}]}]},
     "per_seed[0].per_sentence[0].subject: expected a string"),
    (lambda r: {**r, "per_seed": [{"seed": 0, "replicates": {"fd": []}}]},
     "per_seed[0].replicates.fd: expected a non-empty list of finite numbers"),
    (lambda r: {**r, "metrics": {"fd": {**r["metrics"]["fd"], "seed_range": [2.0, 1.0]}}},
     "metrics.fd.seed_range: expected [low, high]"),
    (lambda r: {**r, "metrics": {"fd": {**r["metrics"]["fd"], "replicates": ["x"]}}},
     "metrics.fd.replicates: expected a non-empty list"),
    (lambda r: {**r, "convergence": {"settled": "no"}}, "convergence.settled: expected true or false"),
    (lambda r: {**r, "convergence": {"metrics": {"fd": {"half_width": "wide"}}}},
     "convergence.metrics.fd.half_width: expected a finite number"),
    (lambda r: {**r, "per_sentence": [["S1", "sentence01"]]}, "per_sentence[0]: expected an object"),
])
def test_a_bad_v3_field_is_one_error_line_naming_it(edit, fragment, tmp_path, capsys):
    folder, path = _results_with(tmp_path, lambda r: json.dumps(edit({**r, "metrics": {
        "fd": {"mean": 2.0, "std": 0.1, "higher_is_better": False, "unit": "latent^2"}}})))
    code, line = _cli_error(capsys, folder, tmp_path)
    assert code == 2 and str(path) in line and fragment in line, line


def test_the_interval_rule_note_names_its_cause():
    # four test sentences: per-sentence values stored, but too few to resample (at least 5)
    a = _sentence_result("a", [1.0, 1.1, 1.2, 1.3])
    b = _sentence_result("b", [3.0, 3.1, 3.2, 3.3])
    (table,) = tables_by_manifest([a, b])
    mark = best_mark(table.rows, table.columns[0])
    assert mark.rule == "intervals" and mark.reason.startswith("only 4 sentence(s) scored in common (fewer than 5")
    md = rendered_tables([a, b])["leaderboard.md"]
    assert ("as nothing could be resampled: only 4 sentence(s) scored in common (fewer than 5 sentences cannot be "
            "resampled)") in md
    assert "neither per-sentence values" not in md
    # result files without per-sentence values or replicates: that is the cause named
    md = rendered_tables(_three())["leaderboard.md"]
    assert "store neither per-sentence values nor bootstrap replicates" in md and "fewer than 5" not in md
