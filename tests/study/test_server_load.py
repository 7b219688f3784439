"""The study server under load on loopback (a short version of perf/study_load.py): concurrent
simulated participants; the database holds exactly the acknowledged answers; then the server is
killed with SIGKILL mid-run and started again: every acknowledged answer is there, none twice,
and the interrupted participants carry on where they stopped."""

from __future__ import annotations

import pytest

from benchmark.study.server.load import load_run

from .server_fixtures import SOUND_WORD, free_port, jspsych_installed, study_clips, tiny_study  # noqa: F401

pytestmark = pytest.mark.slow


def test_concurrent_answers_neither_lost_nor_duplicated(tmp_path, study_clips, jspsych_installed):
    folder = tmp_path / "study"
    tiny_study(folder, study_clips, pairs=6)
    figures = load_run(folder, clients=10, seconds=6, sound_word=SOUND_WORD, port=free_port())
    assert figures["acknowledged"] > 50
    assert figures["lost"] == 0 and figures["duplicated"] == 0 and figures["acknowledged_twice"] == 0
    assert figures["stored"] == figures["acknowledged"]  # nothing killed: the counts are equal
    assert figures["participants"] == figures["participants_started"]
    assert set(figures["statuses"]) <= {200, 303}


def test_sigkill_mid_run_loses_no_acknowledged_answer(tmp_path, study_clips, jspsych_installed):
    folder = tmp_path / "study"
    tiny_study(folder, study_clips, pairs=6)
    figures = load_run(folder, clients=10, seconds=16, kill_at=5, sound_word=SOUND_WORD, port=free_port())
    assert figures["acknowledged_before_kill"] > 0 and figures["transport_errors"] > 0
    assert figures["lost"] == 0 and figures["duplicated"] == 0 and figures["acknowledged_twice"] == 0
    # an answer committed just before the kill whose reply was lost is retried and reported as
    # already answered: it is acknowledged then; only one cut short by the end of the run is not
    assert figures["stored_not_acknowledged"] <= figures["clients"]
    assert figures["interrupted"] > 0 and figures["resumed"] == figures["interrupted"]
