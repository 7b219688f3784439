"""The perceptual study kit end to end, as its user runs it: ``benchmark.study create`` makes an
A/B study of two stored rows of the bundled default (lip sync and realism) and a MOS study of
one sampler's 3 samples; the server serves each; scripted participants click through the real
pages in Debian's headless Chromium (one fails an attention check, one reloads mid-study and
resumes); ``export`` and ``analyze`` report the exclusions and the tables. Both run once more
against PostgreSQL (a throwaway cluster; skipped with the install command where it is absent,
failed in CI)."""

from __future__ import annotations

import contextlib
import json

import pytest

from benchmark.study.__main__ import main
from benchmark.study.answers import read_answers
from benchmark.study.design import read_study
from benchmark.study.export import export_study

from ..leaderboard.browser import browser  # noqa: F401 - fixture
from .create_fixtures import make_study, write_stored_rows
from .server_fixtures import browser_participant, jspsych_installed, postgres_cluster, serve_in_thread  # noqa: F401

pytestmark = pytest.mark.slow

#: The scripted participants finish in seconds: the study's minimum time is set below that.
QUICK = ("--min-seconds", "1")


def participant(study, *, prefer_row: str | None = None, attentive: bool = True, score=None):
    """A chooser reading the study's design the way a person reads the faces: the ground truth is
    recognisable (attention checks answered as expected, or the opposite when not ``attentive``),
    ``prefer_row`` wins every A/B comparison, ``score(stimulus)`` rates a MOS clip."""
    def choose(screen):
        trial = study.trial(screen["trial"])
        if trial.kind == "practice":
            return screen["choices"][0]
        if trial.kind == "attention":
            if attentive:
                return trial.expected
            other = [c for c in study.question(screen["question"]).choices if c != trial.expected]
            return other[0]
        if trial.kind == "ab":
            rows = [study.stimuli[s].row for s in trial.stimuli]
            return "left" if rows[0] == prefer_row else "right"
        return score(study.stimuli[trial.stimuli[0]])
    return choose


@pytest.fixture(scope="module")
def stored_rows(tmp_path_factory):
    return write_stored_rows(tmp_path_factory.mktemp("rows"), rows=("truth", "still", "sampler"))


def _analyze(folder, capsys):
    capsys.readouterr()
    assert main(["analyze", str(folder), "--replicates", "200", "--quiet"]) == 0
    return capsys.readouterr().out, json.loads((folder / "analysis" / "analysis.json").read_text())


@pytest.mark.parametrize("database", ["sqlite", "postgresql"])
def test_an_ab_study_from_stored_rows_to_its_table(tmp_path, browser, stored_rows, jspsych_installed, capsys,
                                                   database):
    folder = make_study(tmp_path / "ab", design="ab", results=stored_rows, extra=QUICK)
    study = read_study(folder)
    assert {s.row for s in study.stimuli.values() if s.role != "attention"} >= {"truth", "still"}
    with contextlib.ExitStack() as stack:
        db_url = stack.enter_context(postgres_cluster()) if database == "postgresql" else None
        url = stack.enter_context(serve_in_thread(folder, db_url))
        runs = [browser_participant(browser, url, participant(study, prefer_row="truth"),
                                    sound_word=study.sound_check.answer, platform={"PROLIFIC_PID": "P1"})]
        browser.delete_all_cookies()
        runs.append(browser_participant(browser, url, participant(study, prefer_row="truth", attentive=False),
                                        sound_word=study.sound_check.answer.upper() + ".", platform={"PROLIFIC_PID": "P2"}))
        browser.delete_all_cookies()
        runs.append(browser_participant(browser, url, participant(study, prefer_row="truth"), reload_after=2,
                                        sound_word=study.sound_check.answer, platform={"PROLIFIC_PID": "P3"}))
        browser.delete_all_cookies()
        assert [r["reloaded"] for r in runs] == [False, False, True]
        export_study(folder, db_url)
    answers, participants = read_answers(folder / "export")
    assert sorted(p["platform_id"] for p in participants) == ["P1", "P2", "P3"]
    assert all(p["status"] == "complete" and p["sound_check_passed"] for p in participants)
    counted = {(a["participant"], a["trial"], a["question"]) for a in answers}
    assert len(counted) == len(answers) == sum(r["answers"] for r in runs)

    out, record = _analyze(folder, capsys)
    exclusions = record["exclusions"]
    assert exclusions["by_reason"] == {"attention": 1, "too_fast": 0, "incomplete": 0, "sound_check": 0}
    assert exclusions["kept"] == 2
    assert "1 excluded" in out and "failed an attention check" in out
    (pair,) = {(p["a"], p["b"]) for p in record["preference"]}
    assert set(pair) == {"truth", "still"}
    for share in record["preference"]:
        assert share["question"] in ("lipsync", "realism")
        preferred_a = share["a"] == "truth"
        assert share["share_a"] == (1.0 if preferred_a else 0.0)  # both kept participants chose the truth
    table = (folder / "analysis" / "tables.md").read_text()
    assert "Lip Sync" in table and "Realism" in table
    assert (folder / "analysis" / "figure.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("database", ["sqlite", "postgresql"])
def test_a_mos_study_of_a_samplers_three_samples(tmp_path, browser, stored_rows, jspsych_installed, capsys, database):
    folder = make_study(tmp_path / "mos", design="mos", results=stored_rows, extra=QUICK)
    study = read_study(folder)
    shown = [s for s in study.stimuli.values() if s.role == "item"]
    assert {s.row for s in shown} == {"sampler"} and all(list(s.samples) == [0, 1, 2] for s in shown)
    assert all(s.width == 3 * s.height for s in shown)  # the three samples side by side, one audio
    sentences = sorted({s.sentence for s in shown})

    def by_sentence(stimulus):  # the first sentence rated 5, the second 3: a known truth the analysis gives back
        return "5" if stimulus.sentence == sentences[0] else "3"

    with contextlib.ExitStack() as stack:
        db_url = stack.enter_context(postgres_cluster()) if database == "postgresql" else None
        url = stack.enter_context(serve_in_thread(folder, db_url))
        for k in range(3):
            browser_participant(browser, url, participant(study, score=by_sentence),
                                sound_word=study.sound_check.answer, platform={"PROLIFIC_PID": f"M{k}"})
            browser.delete_all_cookies()
        export_study(folder, db_url)
    out, record = _analyze(folder, capsys)
    assert record["exclusions"]["excluded"] == 0 and record["exclusions"]["kept"] == 3, out
    mos = record["mos"]
    assert {m["question"] for m in mos} == {"lipsync", "realism", "diversity"}
    for entry in mos:
        assert entry["row"] == "sampler"
        # both items were rated by the same three people: the mean is 4
        assert entry["mean"] == pytest.approx(4.0)
