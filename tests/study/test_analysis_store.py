"""``analyze --board DIR --store``: the study's verdict stored in the studied rows' result files
(``human_preference``, benchmark.results), read back, and shown by the leaderboard as a
"human preference" column; tables without a study are unchanged."""

from __future__ import annotations

import json

import pytest

from benchmark import results as result_files
from benchmark.study.__main__ import main
from leaderboard.build import rendered_tables
from tests.study.analysis_study import make_export, make_study
from tests.study.test_analysis_cli import _board


def test_store_writes_the_verdict_that_the_leaderboard_shows(tmp_path, capsys):
    folder = tmp_path / "study"
    make_export(folder, make_study(folder))
    board = _board(tmp_path)
    before = rendered_tables([result_files.read(p) for p in sorted(board.glob("*.json"))])
    assert "Human pref." not in before["leaderboard.md"]
    assert main(["analyze", str(folder), "--board", str(board), "--store", "--replicates", "200", "--quiet"]) == 0
    record = json.loads((folder / "analysis" / "analysis.json").read_text())
    voca = result_files.read(board / "voca.json").human_preference
    assert voca.study == "study" and voca.reference == "ours" and voca.participants == 6
    assert voca.questions["lipsync"].share == 0.0  # everybody preferred ours on lip sync
    assert voca.questions["realism"].share == pytest.approx(2 / 6)
    shares = {(p["b"], p["question"]): p for p in record["preference"]}
    assert voca.questions["realism"].ci95 == pytest.approx([1 - shares["voca", "realism"]["ci95"][1],
                                                            1 - shares["voca", "realism"]["ci95"][0]])
    strength = {s["row"]: s for s in record["bradley_terry"]["realism"]["strengths"]}["voca"]
    assert voca.questions["realism"].log_strength == pytest.approx(strength["log_strength"])
    ours = result_files.read(board / "ours.json")
    assert ours.human_preference.reference == "ours" and not ours.edited()
    tables = rendered_tables([result_files.read(p) for p in sorted(board.glob("*.json"))])
    markdown = tables["leaderboard.md"]
    assert "| Method |" in markdown and "Human pref. |" in markdown
    assert "lip sync 0 % \\[0, 0\\]; realism 33 % \\[" in markdown and "vs. ours |" in markdown
    assert "Human pref." in tables["leaderboard.tex"]
    # removing the study gives the tables as they were
    for path in board.glob("*.json"):
        data = json.loads(path.read_text())
        del data["human_preference"]
        path.write_text(json.dumps(data))
    assert rendered_tables([result_files.read(p) for p in sorted(board.glob("*.json"))]) == before


def test_store_needs_board(tmp_path, capsys):
    folder = tmp_path / "study"
    make_export(folder, make_study(folder))
    assert main(["analyze", str(folder), "--store", "--quiet"]) == 2
    assert capsys.readouterr().err.startswith("error: --store")
