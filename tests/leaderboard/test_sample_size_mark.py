"""The tables mark a distribution metric whose test split has fewer sentences than the
oracle exam found it needs (the bundled default's 4), and do not at the board's 80."""

from __future__ import annotations

from benchmark.evaluation.sample_size import MIN_TEST_SENTENCES
from benchmark.results import build_result, check
from leaderboard import build
from leaderboard.render import SMALL_SPLIT_MARK

PROV = {"date": "2026-01-01T00:00:00+00:00", "git_revision": None, "versions": {}, "hardware": {}}


def _result(label, sentences, fd, lve, reference=False):
    metrics = {"fd": {"mean": fd, "std": None, "higher_is_better": False, "unit": "latent^2", "ci95": [fd, fd]},
               "lve_rig": {"mean": lve, "std": 0.1, "higher_is_better": False, "unit": "mm", "ci95": [lve, lve]}}
    return check(build_result(method={"name": label, "label": label, "reference": reference, "config": {}},
                              dataset={"manifest_hash": f"h{sentences}", "split": "test", "num_sentences": sentences},
                              protocol={"samples": 1, "seed": 0}, metrics=metrics, timings={},
                              provenance=PROV).to_json())


def _tables(sentences):
    tables = build.rendered_tables([_result("alpha", sentences, 2.0, 3.0), _result("beta", sentences, 1.0, 4.0),
                                    _result("ground-truth", sentences, 0.0, 0.0, reference=True)])
    return tables["leaderboard.md"], tables["leaderboard.tex"]


def _distribution_section(markdown):
    return markdown.split("### Distribution")[1].split("###")[0]


def test_a_split_of_4_sentences_marks_fd_with_a_note_naming_its_size():
    assert MIN_TEST_SENTENCES["fd"] > 4
    markdown, latex = _tables(4)
    section = _distribution_section(markdown)
    header = next(line for line in section.splitlines() if line.startswith("| Method"))
    assert f"FD (latent^2) ↓ {SMALL_SPLIT_MARK}" in header
    note = next(line for line in section.splitlines() if line.startswith(SMALL_SPLIT_MARK))
    assert f"FD needs {MIN_TEST_SENTENCES['fd']} (this split has 4)" in note
    assert "sample-size-exam" in note
    # LVE is not a distribution metric the exam sizes: its table carries no mark
    vertex = markdown.split("### Vertex")[1].split("###")[0]
    assert SMALL_SPLIT_MARK not in vertex
    assert r"$^\S$" in latex and SMALL_SPLIT_MARK not in latex


def test_the_boards_80_sentences_carry_no_mark():
    markdown, latex = _tables(80)
    assert SMALL_SPLIT_MARK not in markdown and r"$^\S$" not in latex
