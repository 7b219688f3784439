"""Scripted participants click through the real pages in Debian's headless Chromium (selenium):
one completes, one fails the attention check, one reloads mid-study and resumes; the export and
the database hold exactly their answers."""

from __future__ import annotations

import sqlite3

import pytest

from benchmark.study.answers import read_answers
from benchmark.study.export import export_study
from benchmark.study.server.steps import question_screens

from ..leaderboard.browser import browser  # noqa: F401 - fixture
from .server_fixtures import (  # noqa: F401 - fixtures
    ab_study,
    browser_participant,
    jspsych_installed,
    serve_in_thread,
    study_clips,
)


def prefer(*good_rows):
    """A chooser that picks the side showing one of ``good_rows`` (the stimulus ids start with the row)."""
    def choose(screen):
        sides = [m.rsplit("/", 1)[1].split("-")[0] for m in screen["media"]]
        return "left" if sides[0] in good_rows else "right"
    return choose


def test_chromium_plays_h264_aac(browser, ab_study):
    folder, _ = ab_study
    with serve_in_thread(folder) as url:
        browser.get(url + "/")
        assert browser.execute_script(
            "return document.createElement('video').canPlayType('video/mp4; codecs=\"avc1.42E01E, mp4a.40.2\"')"
        ) == "probably"


def test_participants_click_through_the_pages(browser, ab_study):
    folder, study = ab_study
    with serve_in_thread(folder) as url:
        runs = []
        # 1: completes, preferring the better row and the ground truth
        runs.append(browser_participant(browser, url, prefer("good", "gt"),
                                        platform={"PROLIFIC_PID": "P1", "STUDY_ID": "S", "SESSION_ID": "A"}))
        browser.delete_all_cookies()
        # 2: fails the attention check (picks the static face)
        runs.append(browser_participant(browser, url, prefer("bad", "static"),
                                        platform={"PROLIFIC_PID": "P2", "STUDY_ID": "S", "SESSION_ID": "B"}))
        # 3: reloads after two answers and carries on where it stopped
        runs.append(browser_participant(browser, url, prefer("good", "gt"), reload_after=2,
                                        platform={"workerId": "W3", "hitId": "H", "assignmentId": "A3"}))
    assert [r["reloaded"] for r in runs] == [False, False, True]
    total = len([s for s in question_screens(study, 0) if not s.practice])
    assert [r["answers"] for r in runs] == [total] * 3
    assert len({r["code"] for r in runs}) == 3 and all(len(r["code"]) == 8 for r in runs)

    export_study(folder)
    answers, participants = read_answers(folder / "export")
    assert len(answers) == 3 * total
    assert sorted(p["platform_id"] for p in participants) == ["P1", "P2", "W3"]
    assert all(p["status"] == "complete" and p["sound_check_passed"] for p in participants)
    assert sorted(p["slot"] for p in participants) == [0, 1, 2]
    by_person = {p["platform_id"]: p["participant"] for p in participants}
    attention = {a["participant"]: a["choice"] for a in answers if a["kind"] == "attention"
                 and a["question"] == "lipsync"}
    assert attention[by_person["P1"]] == "left" == attention[by_person["W3"]]  # the ground truth is on the left
    assert attention[by_person["P2"]] == "right"
    # the answers' rows match what each side showed: participant 1 always chose the "good" row
    for a in answers:
        if a["participant"] == by_person["P1"] and a["kind"] == "ab":
            assert a["rows"].split("|")[("left", "right").index(a["choice"])] == "good"
        assert a["rt_ms"] is not None and a["rt_ms"] > 0
    # the database: one row per answered question (the practice kept there), none twice
    db = sqlite3.connect(folder / "answers.sqlite")
    assert db.execute("select count(*) from answers").fetchone()[0] == 3 * (total + 1)
    assert db.execute("select count(*) from (select participant_id, trial, question from answers "
                      "group by 1, 2, 3 having count(*) > 1)").fetchone()[0] == 0
    assert db.execute("pragma journal_mode").fetchone()[0] == "wal"
