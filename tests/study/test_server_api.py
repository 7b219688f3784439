"""The study server's API and its refusals (FastAPI's TestClient): slots, resume, answers written
once, unassigned trials, choices, path traversal, oversized and malformed bodies, tokens, escaping."""

from __future__ import annotations

import json
import sqlite3

import pytest
from fastapi.testclient import TestClient

from benchmark.study.answers import read_answers
from benchmark.study.design import read_study, write_study
from benchmark.study.export import export_study
from benchmark.study.server import create_app
from benchmark.study.server.steps import question_screens
from blendvoca.errors import DataError, UserError

from .server_fixtures import (  # noqa: F401 - fixtures
    SOUND_WORD,
    ab_study,
    api_participant,
    jspsych_installed,
    start_api_session,
    study_clips,
    tiny_study,
)


def client_for(folder, **options) -> TestClient:
    return TestClient(create_app(folder, **options), raise_server_exceptions=False)


def through_sound_check(client, path):
    client.post(f"{path}api/instructions")
    client.post(f"{path}api/sound-check", json={"word": SOUND_WORD})
    return client.get(f"{path}api/state").json()


def test_slots_round_robin_then_least_taken(ab_study):
    folder, study = ab_study
    client = client_for(folder)
    paths = [start_api_session(client) for _ in range(4)]
    slots = [client.app.state.store.participant_by_token(p.split("/")[2]).slot for p in paths]
    assert slots == [0, 1, 2, 0]  # every slot once, then again from the least taken
    # a finished participant makes their slot "more judged": the next newcomer avoids it
    api_participant(client, paths[1], lambda s: s["choices"][0])
    newcomer = start_api_session(client)
    assert client.app.state.store.participant_by_token(newcomer.split("/")[2]).slot == 2
    # each slot's screens are the practice trial, then its trials in the design's order
    state = through_sound_check(client, paths[2])
    assert state["screen"]["trial"] == "practice" and state["screen"]["practice"]


def test_full_session_and_export_match_the_design(ab_study):
    folder, study = ab_study
    client = client_for(folder)
    path = start_api_session(client, PROLIFIC_PID="pid1", STUDY_ID="st1", SESSION_ID="se1")
    assert client.get(path).status_code == 200
    choices = {}

    def choose(screen):
        choice = "left" if (screen["trial"], screen["question"]) != ("t2", "realism") else "right"
        choices[(screen["trial"], screen["question"])] = choice
        return choice

    acknowledged = api_participant(client, path, choose)
    screens = question_screens(study, 0)
    assert acknowledged == len(screens) == 7  # 1 practice + 3 trials x 2 questions
    done = client.get(path)
    assert "completion code" in done.text
    code = client.get(f"{path}api/state").json()["completion_code"]
    assert code in done.text
    written = export_study(folder)
    assert {p.name for p in written} == {"answers.csv", "participants.csv", "answers.json", "completion_codes.csv"}
    answers, participants = read_answers(folder / "export")
    assert len(answers) == 6  # practice not exported
    assert {(a["trial"], a["question"]): a["choice"] for a in answers} == {
        k: v for k, v in choices.items() if k[0] != "practice"}
    t1 = next(a for a in answers if a["trial"] == "t1")
    assert (t1["rows"], t1["stimuli"], t1["kind"], t1["rt_ms"]) == ("good|bad", "good-s1|bad-s1", "ab", 1234)
    attention = next(a for a in answers if a["trial"] == "att1")
    assert attention["expected"] == "left" and attention["kind"] == "attention"
    (person,) = participants
    assert person["status"] == "complete" and person["sound_check_passed"] is True
    assert (person["platform"], person["platform_id"]) == ("prolific", "pid1")
    assert person["seconds"] is not None and person["seconds"] >= 0
    assert code in (folder / "export" / "completion_codes.csv").read_text()
    # nothing personal beyond the platform id: the export's fields are the contract's
    assert set(json.loads((folder / "export" / "answers.json").read_text())["participants"][0]) == set(person)


def test_resume_after_reload_and_restart(ab_study, tmp_path):
    folder, study = ab_study
    client = client_for(folder)
    path = start_api_session(client, PROLIFIC_PID="pid2", STUDY_ID="st", SESSION_ID="se")
    assert api_participant(client, path, lambda s: s["choices"][1], stop_after=3) == 3
    before = client.get(f"{path}api/state").json()
    client.app.state.store.close()
    # a new application on the same database (a restarted server): same token, same next question
    again = client_for(folder)
    after = again.get(f"{path}api/state").json()
    assert after == before and after["screen"]["trial"] == question_screens(study, 0)[3].trial
    # back through the platform link (same platform session): a new token, the same place
    back = start_api_session(again, PROLIFIC_PID="pid2", STUDY_ID="st", SESSION_ID="se")
    assert back != path and again.get(f"{back}api/state").json() == before
    assert again.get(f"{path}api/state").status_code == 403  # the old token stopped working
    # the same platform id in another session: refused (one participation per person)
    other = again.post("/start", data={"consent": "yes", "PROLIFIC_PID": "pid2", "STUDY_ID": "st",
                                        "SESSION_ID": "other"}, follow_redirects=False)
    assert other.status_code == 409 and "already taken part" in other.text
    assert api_participant(again, back, lambda s: s["choices"][0]) == 4


def test_answers_refused(ab_study):
    folder, study = ab_study
    client = client_for(folder)
    path = start_api_session(client)
    answer = lambda **kw: client.post(f"{path}api/answer", json={"rt_ms": 10, **kw})  # noqa: E731
    # before the sound check: not the current step
    assert answer(trial="practice", question="lipsync", choice="left").status_code == 409
    state = through_sound_check(client, path)
    screen = state["screen"]
    assert answer(trial="nope", question="lipsync", choice="left").status_code == 403
    assert answer(trial="t1", question="diversity", choice="left").status_code == 403
    assert answer(trial="t2", question="lipsync", choice="left").status_code == 409  # not the current one
    bad = answer(trial=screen["trial"], question=screen["question"], choice="middle")
    assert bad.status_code == 422 and "left, right" in bad.json()["error"]
    assert answer(trial=screen["trial"], question=screen["question"], choice="3").status_code == 422
    first = answer(trial=screen["trial"], question=screen["question"], choice="left")
    assert first.status_code == 200 and first.json()["ok"]
    twice = answer(trial=screen["trial"], question=screen["question"], choice="right")
    assert twice.status_code == 409 and "already answered" in twice.json()["error"]
    assert client.app.state.store.count_answers() == 1
    # another participant's slot can hold trials in another order: only one's own current question
    other = start_api_session(client)
    through_sound_check(client, other)
    assert client.post(f"{other}api/answer", json={"trial": "t1", "question": "realism", "choice": "left"}
                       ).status_code == 409
    # malformed: wrong types, unknown fields, not JSON, negative time; short messages, no traceback
    for body in ({"trial": 1}, {"trial": "t1", "question": "lipsync", "choice": "left", "extra": 1},
                 {"trial": "t1", "question": "lipsync", "choice": "left", "rt_ms": -5}):
        response = client.post(f"{path}api/answer", json=body)
        assert response.status_code == 422 and "Traceback" not in response.text
    response = client.post(f"{path}api/answer", content=b"{not json", headers={"content-type": "application/json"})
    assert response.status_code == 422 and set(response.json()) == {"error"}
    assert client.app.state.store.count_answers() == 1


def test_oversized_and_chunked_bodies_refused(ab_study):
    folder, _ = ab_study
    client = client_for(folder)
    path = start_api_session(client)
    big = client.post(f"{path}api/answer", content=b"x" * 20000, headers={"content-type": "application/json"})
    assert big.status_code == 413
    chunked = client.post(f"{path}api/answer", content=iter([b'{"trial": "t1"}']),
                          headers={"content-type": "application/json"})
    assert chunked.status_code == 411
    assert client.post("/start", content=b"consent=yes&" + b"a" * 20000,
                       headers={"content-type": "application/x-www-form-urlencoded"}).status_code == 413
    assert client.post("/start", data={"consent": "no"}).status_code == 400


def test_tokens_checked_everywhere(ab_study):
    folder, _ = ab_study
    client = client_for(folder)
    path = start_api_session(client)
    token = path.split("/")[2]
    assert len(token) >= 40  # secrets.token_urlsafe(32)
    forged = token[:-1] + ("A" if token[-1] != "A" else "B")
    for url in (f"/s/{forged}/", f"/s/{forged}/api/state", f"/s/{forged}/media/good-s1", "/s/short/api/state",
                "/s/%3Cscript%3E/api/state"):
        assert client.get(url).status_code == 403, url
    assert client.post(f"/s/{forged}/api/answer", json={"trial": "t1", "question": "lipsync",
                                                         "choice": "left"}).status_code == 403
    assert client.post(f"/s/{forged}/api/instructions").status_code == 403
    # the database keeps only the token's digest
    rows = sqlite3.connect(folder / "answers.sqlite").execute("select token_sha256 from participants").fetchall()
    assert rows and all(token not in row[0] for row in rows)


@pytest.mark.parametrize("url", [
    "/s/{t}/media/../study.json", "/s/{t}/media/..%2fstudy.json", "/s/{t}/media/%2e%2e%2fstudy.json",
    "/s/{t}/media/%2e%2e/study.json", "/s/{t}/media/..%252fstudy.json", "/s/{t}/media/stimuli%2fgood-s1.mp4",
    "/s/{t}/media/good-s1.mp4", "/s/{t}/media/%2Fetc%2Fpasswd", "/s/{t}/media/..\\study.json",
    "/stimuli/good-s1.mp4", "/study.json", "/answers.sqlite", "/static/..%2fserver%2fapp.py",
    "/static/%2e%2e/%2e%2e/design.py", "/vendor/../package.json", "/vendor/..%2fpackage.json",
    "/vendor/%2e%2e%2f%2e%2e%2fpackage-lock.json", "/s/{t}/media/%00good-s1",
])
def test_files_outside_the_stimuli_refused(ab_study, url):
    folder, _ = ab_study
    client = client_for(folder)
    token = start_api_session(client).split("/")[2]
    response = client.get(url.replace("{t}", token))
    assert response.status_code in (403, 404), (url, response.status_code)
    assert b"blendvoca-study-1" not in response.content and b"root:" not in response.content
    assert b"import" not in response.content


def test_media_only_for_the_participants_trials(ab_study, study_clips):
    folder, study = ab_study
    client = client_for(folder)
    token = start_api_session(client).split("/")[2]
    clip = client.get(f"/s/{token}/media/good-s1")
    assert clip.status_code == 200 and clip.headers["content-type"] == "video/mp4"
    assert clip.content == (folder / "stimuli" / "good-s1.mp4").read_bytes()
    ranged = client.get(f"/s/{token}/media/good-s1", headers={"Range": "bytes=0-99"})
    assert ranged.status_code == 206 and len(ranged.content) == 100
    assert client.get(f"/s/{token}/media/sound-check").status_code == 200
    # a study whose slot leaves a stimulus out: that stimulus is not served to it
    narrow = folder.parent / "narrow"
    full = tiny_study(narrow, study_clips, slots=1)
    from dataclasses import replace

    write_study(replace(full, participants=(replace(full.participants[0], trials=("t1",)),)), narrow)
    other = client_for(narrow)
    token = start_api_session(other).split("/")[2]
    assert other.get(f"/s/{token}/media/good-s1").status_code == 200
    assert other.get(f"/s/{token}/media/static-s3").status_code == 200  # the practice trial's
    assert other.get(f"/s/{token}/media/good-s2").status_code == 404
    assert other.get(f"/s/{token}/media/gt-s3").status_code == 404


def test_text_is_escaped(tmp_path, study_clips, jspsych_installed):
    folder = tmp_path / "study"
    tiny_study(folder, study_clips, prompt_suffix=' <script>alert("x")</script></script><img src=x onerror=1>')
    client = client_for(folder)
    path = start_api_session(client)
    through_sound_check(client, path)
    page = client.get(path).text
    assert "<script>alert" not in page and "<img src=x" not in page and "\\u003cscript\\u003e" in page
    assert client.get(f"{path}api/state").json()["screen"]["prompt"].endswith("<img src=x onerror=1>")
    # URL parameters: only ids are accepted, refused ones are never echoed raw
    refused = client.get("/?PROLIFIC_PID=%3Cb%3Ehi%3C/b%3E")
    assert refused.status_code == 400 and "<b>hi" not in refused.text
    ok = client.get("/?PROLIFIC_PID=abc&STUDY_ID=s&SESSION_ID=x")
    assert 'value="abc"' in ok.text
    assert client.get(path).headers["content-security-policy"].startswith("default-src 'self'")
    # a completion URL with markup is escaped on the last page
    from benchmark.study.server.pages import done_page

    assert '"><script>' not in done_page("AB12", 'https://x.test/?cc={code}"><script>')


def test_sound_check_attempts(ab_study):
    folder, _ = ab_study
    client = client_for(folder)
    path = start_api_session(client)
    client.post(f"{path}api/instructions")
    for left in (2, 1):
        reply = client.post(f"{path}api/sound-check", json={"word": "banana"}).json()
        assert not reply["passed"] and reply["attempts_left"] == left and reply["state"]["step"] == "sound_check"
    reply = client.post(f"{path}api/sound-check", json={"word": "banana"}).json()
    assert reply["state"]["step"] == "question"  # goes on, recorded as failed (the analysis excludes it)
    assert client.post(f"{path}api/sound-check", json={"word": SOUND_WORD}).status_code == 409
    api_participant(client, path, lambda s: s["choices"][0])
    export_study(folder)
    (person,) = read_answers(folder / "export")[1]
    assert person["sound_check_passed"] is False
    # the word is matched without case or surrounding spaces
    second = start_api_session(client)
    client.post(f"{second}api/instructions")
    assert client.post(f"{second}api/sound-check", json={"word": f"  {SOUND_WORD.upper()} "}).json()["passed"]


def test_mturk_parameters_and_preview(ab_study):
    folder, _ = ab_study
    client = client_for(folder)
    preview = client.get("/?workerId=W1&hitId=H1&assignmentId=ASSIGNMENT_ID_NOT_AVAILABLE")
    assert preview.status_code == 200 and 'id="start"' not in preview.text
    assert client.post("/start", data={"consent": "yes", "workerId": "W1", "hitId": "H1",
                                        "assignmentId": "ASSIGNMENT_ID_NOT_AVAILABLE"}).status_code == 400
    path = start_api_session(client, workerId="W1", hitId="H1", assignmentId="A1")
    participant = client.app.state.store.participant_by_token(path.split("/")[2])
    assert (participant.platform, participant.platform_id) == ("mturk", "W1")


def test_missing_or_changed_stimuli_refused(ab_study):
    folder, _ = ab_study
    (folder / "stimuli" / "bad-s2.mp4").write_bytes(b"changed")
    with pytest.raises(DataError, match="changed since the study was created"):
        create_app(folder)
    (folder / "stimuli" / "bad-s2.mp4").unlink()
    with pytest.raises(DataError, match="missing"):
        create_app(folder)


def test_serve_and_export_commands_refuse_bad_input(ab_study, capsys):
    from benchmark.study.__main__ import main

    folder, _ = ab_study
    assert main(["export", str(folder)]) == 2  # no answers yet
    assert "no answers yet" in capsys.readouterr().err
    (folder / "stimuli" / "t.mp4").write_bytes(b"")
    (folder / "stimuli" / "good-s1.mp4").write_bytes(b"changed")
    assert main(["serve", str(folder), "--port", "8765"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and "changed since" in err and len(err.strip().splitlines()) == 1
    assert not (folder / "answers.sqlite").exists()  # nothing served, nothing written
    assert main(["serve", str(folder), "--db", "mysql://x@y/z"]) == 2
    assert main(["serve", str(folder.parent / "nowhere")]) == 2


def test_bad_database_url(ab_study):
    from benchmark.study.server.store import Store

    with pytest.raises(UserError, match="expected a sqlite"):
        Store("mysql://u@h/d")
    with pytest.raises(UserError, match="not a database URL"):
        Store("::::")


def test_mos_study(tmp_path, study_clips, jspsych_installed):
    folder = tmp_path / "mos"
    study = tiny_study(folder, study_clips, design="mos")
    client = client_for(folder)
    path = start_api_session(client)
    state = through_sound_check(client, path)
    assert state["screen"]["choices"] == ["1", "2", "3", "4", "5"] and len(state["screen"]["media"]) == 1
    bad = client.post(f"{path}api/answer", json={"trial": state["screen"]["trial"],
                                                  "question": state["screen"]["question"], "choice": "left"})
    assert bad.status_code == 422
    assert api_participant(client, path, lambda s: "4") == len(question_screens(study, 0))
    export_study(folder)
    answers, _ = read_answers(folder / "export")
    assert {a["choice"] for a in answers} == {"4"} and all(a["kind"] == "mos" for a in answers)
    assert len(read_study(folder).trials) == 5
