"""The same API flow against PostgreSQL (a throwaway cluster started with initdb/pg_ctl): answers
written once, resume after a restart, the export; skipped with the install command where
PostgreSQL is absent (``.ci/run`` installs it)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from benchmark.study.answers import read_answers
from benchmark.study.export import export_study
from benchmark.study.server import create_app
from benchmark.study.server.steps import question_screens

from .server_fixtures import (  # noqa: F401 - fixtures
    ab_study,
    api_participant,
    jspsych_installed,
    postgres_cluster,
    start_api_session,
    study_clips,
)


@pytest.fixture(scope="module")
def postgres_url():
    with postgres_cluster() as url:
        yield url


def test_api_flow_on_postgresql(ab_study, postgres_url):
    folder, study = ab_study
    client = TestClient(create_app(folder, postgres_url), raise_server_exceptions=False)
    store = client.app.state.store
    assert store.url.drivername == "postgresql+psycopg"
    total = len(question_screens(study, 0))
    paths = [start_api_session(client, PROLIFIC_PID=f"P{k}", STUDY_ID="S", SESSION_ID=f"s{k}") for k in range(3)]
    assert [store.participant_by_token(p.split("/")[2]).slot for p in paths] == [0, 1, 2]
    assert api_participant(client, paths[0], lambda s: s["choices"][0]) == total
    assert api_participant(client, paths[1], lambda s: s["choices"][1], stop_after=2) == 2
    state = client.get(f"{paths[1]}api/state").json()
    screen = state["screen"]
    ok = client.post(f"{paths[1]}api/answer", json={"trial": screen["trial"], "question": screen["question"],
                                                      "choice": "left", "rt_ms": 5})
    assert ok.status_code == 200
    again = client.post(f"{paths[1]}api/answer", json={"trial": screen["trial"], "question": screen["question"],
                                                         "choice": "right", "rt_ms": 5})
    assert again.status_code == 409
    bad = client.post(f"{paths[1]}api/answer", json={"trial": "t1", "question": "lipsync", "choice": "5"})
    assert bad.status_code in (409, 422)
    before = client.get(f"{paths[1]}api/state").json()
    store.close()

    # a restarted server on the same database: the session resumes where it stopped
    restarted = TestClient(create_app(folder, postgres_url), raise_server_exceptions=False)
    assert restarted.get(f"{paths[1]}api/state").json() == before
    assert api_participant(restarted, paths[1], lambda s: s["choices"][1]) == total - 3
    assert restarted.app.state.store.count_answers() == 2 * total
    restarted.app.state.store.close()

    export_study(folder, postgres_url)
    answers, participants = read_answers(folder / "export")
    assert len(answers) == 2 * (total - 1)  # practice not exported
    assert sorted(p["status"] for p in participants) == ["complete", "complete", "incomplete"]
    assert not (folder / "answers.sqlite").exists()
