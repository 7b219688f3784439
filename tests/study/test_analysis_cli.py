"""``python -m benchmark.study analyze`` on a hand-made study and export: the exclusions counted
right, the shares, tables and figure written, ``--board`` held against fabricated result files,
and the refusals (one ``error:`` line, exit 2, nothing written)."""

from __future__ import annotations

import json

import pytest

import benchmark.study.export
from benchmark.study.__main__ import main
from benchmark.study.analysis.exclusions import apply_exclusions
from benchmark.study.answers import read_answers, write_answers
from tests.study.analysis_study import EXCLUDED, KEPT, PEOPLE, SENTENCES, make_export, make_study, ours_preferred
from tests.study.board_results import write_result


@pytest.fixture
def study_folder(tmp_path):
    folder = tmp_path / "study"
    study = make_study(folder)
    make_export(folder, study)
    return folder


def _analyze(folder, *extra):
    return main(["analyze", str(folder), "--replicates", "200", "--quiet", *extra])


def _refused(capsys, folder, *extra):
    code = _analyze(folder, *extra)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and err[0].startswith("error: "), err
    assert not (folder / "analysis").exists()
    return err[0]


def test_exclusions_are_counted_as_declared(study_folder):
    from benchmark.study.design import read_study

    study = read_study(study_folder)
    answers, participants = read_answers(study_folder / "export")
    kept, counts = apply_exclusions(study, answers, participants)
    assert counts["by_reason"] == EXCLUDED
    assert counts["excluded"] == len(PEOPLE) - len(KEPT) and counts["kept"] == len(KEPT)
    assert {a["participant"] for a in kept} == set(KEPT)
    assert {a["kind"] for a in kept} == {"ab"}  # practice and attention trials never counted
    assert counts["practice_answers_ignored"] == len(PEOPLE) * 2
    assert counts["answers_kept"] == len(KEPT) * 2 * len(SENTENCES) * 2  # 2 comparisons x 6 sentences x 2 questions


def test_analyze_writes_the_shares_tables_and_figure(study_folder, capsys):
    assert _analyze(study_folder) == 0
    out = capsys.readouterr().out
    assert "5 excluded" in out and "ours vs. voca" in out
    record = json.loads((study_folder / "analysis" / "analysis.json").read_text())
    shares = {(p["a"], p["b"], p["question"]): p for p in record["preference"]}
    # every kept participant prefers ours on lip sync; on realism on 4 sentences of 6
    for other in ("voca", "faceformer"):
        assert shares["ours", other, "lipsync"]["share_a"] == 1.0
        assert shares["ours", other, "lipsync"]["p_value"] < 0.05
        assert shares["ours", other, "realism"]["share_a"] == pytest.approx(4 / 6)
        assert shares["ours", other, "realism"]["answers"] == len(KEPT) * len(SENTENCES)
        low, high = shares["ours", other, "realism"]["ci95"]
        assert low <= 4 / 6 <= high
    assert record["exclusions"]["by_reason"] == EXCLUDED
    bt = record["bradley_terry"]["lipsync"]
    assert bt["reference"] == "ours" and [s["row"] for s in bt["strengths"]] == ["ours", "voca", "faceformer"]
    assert all(s["log_strength"] < -2 for s in bt["strengths"][1:])
    assert record["agreement"]["realism"]["alpha"] == pytest.approx(1.0)  # every participant answers alike
    assert record["agreement"]["lipsync"]["alpha"] is None  # one value only: alpha is undefined
    tables = (study_folder / "analysis" / "tables.md").read_text()
    assert "| Comparison | Lip Sync | Realism |" in tables and "| ours vs. voca | 100.0 %" in tables
    latex = (study_folder / "analysis" / "tables.tex").read_text()
    assert "\\toprule" in latex and "ours vs. voca & 100.0 \\%" in latex
    assert (study_folder / "analysis" / "figure.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_reference_orients_the_comparisons(study_folder):
    assert _analyze(study_folder, "--reference", "voca") == 0
    record = json.loads((study_folder / "analysis" / "analysis.json").read_text())
    shares = {(p["a"], p["b"], p["question"]): p["share_a"] for p in record["preference"]}
    assert shares["voca", "ours", "lipsync"] == 0.0
    assert ("ours", "faceformer", "lipsync") in shares  # a pair without the reference keeps the study's order
    assert record["bradley_terry"]["lipsync"]["reference"] == "voca"


def test_a_missing_export_is_exported_first(tmp_path, monkeypatch, capsys):
    folder = tmp_path / "study"
    study = make_study(folder)
    calls = []

    def export_study(study_folder, db_url):
        calls.append((str(study_folder), db_url))
        make_export(folder, study)

    monkeypatch.setattr(benchmark.study.export, "export_study", export_study, raising=False)
    assert _analyze(folder, "--db", "sqlite:///x.sqlite") == 0
    assert calls == [(str(folder), "sqlite:///x.sqlite")]


def _per_sentence(row):
    """A metric that sides with the participants on realism (ours loses on sentences 3 and 6)."""
    out = []
    for k, (subject, sentence) in enumerate(SENTENCES):
        ours_wins = ours_preferred("p1", type("T", (), {"id": f"x-{k}"})(), "realism")
        value = 1.0 if row == "ours" else (0.0 if ours_wins else 2.0)
        out.append({"subject": subject, "sentence": sentence, "realism_score": value, "error": value})
    return out


def _board(tmp_path, rows=("ours", "voca", "faceformer"), recipe=lambda row: "a" * 64):
    board = tmp_path / "board"
    board.mkdir()
    means = {"ours": 1.0, "voca": 0.5, "faceformer": 0.7}
    for row in rows:
        write_result(board, row, _per_sentence(row), {"realism_score": means[row], "error": means[row]},
                     recipe_id=recipe(row), directions={"error": False})
    return board


def test_board_holds_the_metrics_against_the_participants(study_folder, tmp_path, capsys):
    assert _analyze(study_folder, "--board", str(_board(tmp_path))) == 0
    record = json.loads((study_folder / "analysis" / "analysis.json").read_text())
    realism = {e["metric"]: e for e in record["board"]["questions"]["realism"]}
    assert realism["realism_score"]["sentence_agreement"] == 1.0
    assert realism["realism_score"]["sentence_units"] == 2 * len(SENTENCES)
    assert realism["realism_score"]["pair_agreement"] == 1.0
    # the same numbers read as lower-is-better side against the participants everywhere
    assert realism["error"]["sentence_agreement"] == 0.0 and realism["error"]["pair_agreement"] == 0.0
    assert realism["error"]["spearman"] < 0 and realism["realism_score"]["spearman"] > 0
    assert "The metrics against people: Realism" in (study_folder / "analysis" / "tables.md").read_text()


def test_refusals_are_one_error_line(study_folder, tmp_path, capsys):
    assert "--reference 'nobody'" in _refused(capsys, study_folder, "--reference", "nobody")
    assert "faceformer" in _refused(capsys, study_folder, "--board", str(_board(tmp_path, rows=("ours", "voca"))))
    other = tmp_path / "other"
    other.mkdir()
    different = _board(other, recipe=lambda row: ("b" if row == "voca" else "a") * 64)
    assert "different builds" in _refused(capsys, study_folder, "--board", str(different))
    write_answers(study_folder / "export", [], [])
    assert "no answers" in _refused(capsys, study_folder)


def test_everybody_excluded_is_refused(tmp_path, capsys):
    folder = tmp_path / "study"
    study = make_study(folder)
    make_export(folder, study, people={k: v for k, v in PEOPLE.items() if k not in KEPT})
    assert "no answers left after the exclusions" in _refused(capsys, folder)


def test_the_minimum_time_falls_back_on_the_session_times(study_folder):
    from benchmark.study.design import read_study

    answers, participants = read_answers(study_folder / "export")
    for record in participants:
        if record["participant"] == "p1":  # 90 s between start and finish, no seconds recorded
            record.update(seconds=None, started_at="2026-01-01T00:00:00Z", finished_at="2026-01-01T00:01:30Z")
    kept, counts = apply_exclusions(read_study(study_folder), answers, participants)
    assert counts["by_reason"]["too_fast"] == EXCLUDED["too_fast"] + 1
    assert "p1" not in {a["participant"] for a in kept}
