"""benchmark.runs: the stored-run layout written by the runner and read back by read_run."""

import json

import numpy as np
import pytest

from benchmark.results import build_result, write
from benchmark.runs import StoredVertices, TrackWriter, read_run, track_path, vertices_path
from blendvoca.names import BLENDVOCA_NAMES

PROV = {"date": "2026-01-01T00:00:00+00:00", "git_revision": None, "versions": {}, "hardware": {}}


def test_tracks_and_vertices_round_trip_through_a_stored_run(tmp_path):
    rng = np.random.default_rng(0)
    writer = TrackWriter(tmp_path / "run", BLENDVOCA_NAMES)
    tracks = rng.uniform(size=(2, 30, 32))
    template = rng.normal(scale=0.1, size=(50, 3))
    verts = template[None, None] + rng.normal(scale=0.005, size=(2, 30, 50, 3))
    writer.write_tracks("S1", "sentence03", tracks)
    writer.write_vertices("S1", "sentence03", verts, template)
    assert ("S1", "sentence03") in writer.stored_vertices() and len(writer.stored_vertices()) == 1
    # float16 offsets: about 2^-11 relative to centimetre motion, i.e. micrometres
    assert np.abs(writer.stored_vertices()[("S1", "sentence03")] - verts).max() < 2e-5
    assert not (tmp_path / "run").exists()  # staged until commit
    writer.commit()
    result = build_result(method={"name": "m", "config": {}}, dataset={"manifest_hash": "h", "path": "/data/bv"},
                          protocol={"samples": 2, "seed": 0}, metrics={"x": {"mean": 1.0, "higher_is_better": False}},
                          timings={}, provenance=PROV, tracks="run", per_sentence=[{"subject": "S1",
                                                                                    "sentence": "sentence03"}])
    path = write(tmp_path / "run.json", result)
    run = read_run(path)
    assert run.keys == [("S1", "sentence03")] and run.tracks_dir == (tmp_path / "run").resolve()
    assert [p.name for p in run.track_paths("S1", "sentence03")] == ["sentence03-0.csv", "sentence03-1.csv"]
    np.testing.assert_allclose(run.tracks("S1", "sentence03"), tracks, atol=5e-7)  # %.6f CSVs
    assert run.has_vertices() and run.vertices("S1", "sentence03").shape == verts.shape
    assert str(run.dataset_root) == "/data/bv"
    assert track_path("R", "S", "sentence01", 2).as_posix() == "R/S/sentence01-2.csv"
    assert vertices_path("R", "S", "sentence01").as_posix() == "R/S/sentence01.vertices.npz"


def test_rerun_replaces_its_own_tracks_and_a_failed_run_leaves_nothing(tmp_path):
    first = TrackWriter(tmp_path / "run", BLENDVOCA_NAMES)
    first.write_tracks("S1", "sentence01", np.zeros((1, 5, 32)))
    first.commit()
    second = TrackWriter(tmp_path / "run", BLENDVOCA_NAMES)
    second.write_tracks("S2", "sentence02", np.ones((1, 5, 32)))
    second.commit()
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*.csv")) == [
        "run/S2/sentence02-0.csv"]
    failed = TrackWriter(tmp_path / "other", BLENDVOCA_NAMES)
    failed.write_tracks("S1", "sentence01", np.zeros((1, 5, 32)))
    failed.discard()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    assert len(StoredVertices(tmp_path / "missing")) == 0


def test_a_killed_runs_staging_is_removed_by_the_next_writer_not_a_live_ones(tmp_path):
    import subprocess
    import sys

    from blendvoca.runtime.staging import process_tag

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True, check=True)
    dead_pid = int(dead.stdout)
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        killed = tmp_path / f".run.{process_tag(dead_pid)}.partial"
        running = tmp_path / f".run.{process_tag(live.pid)}.partial"
        elsewhere = tmp_path / f".run.other-host.example-{dead_pid}.partial"
        other_run = tmp_path / f".other.{process_tag(dead_pid)}.partial"
        for folder in (killed, running, elsewhere, other_run):
            (folder / "S1").mkdir(parents=True)
        writer = TrackWriter(tmp_path / "run", BLENDVOCA_NAMES)
        assert not killed.exists()
        assert running.is_dir() and elsewhere.is_dir() and other_run.is_dir() and writer.staging.is_dir()
    finally:
        live.kill()
        live.wait()


def test_read_run_explains_missing_tracks(tmp_path):
    result = build_result(method={"name": "m", "config": {}}, dataset={"manifest_hash": "h"},
                          protocol={"samples": 1, "seed": 0}, metrics={"x": {"mean": 1.0, "higher_is_better": False}},
                          timings={}, provenance=PROV)
    path = write(tmp_path / "old.json", result)
    with pytest.raises(ValueError, match="stored no tracks"):
        read_run(path)
    data = json.loads(path.read_text())
    data["tracks"] = "gone"
    path.write_text(json.dumps(data))
    with pytest.raises(FileNotFoundError, match="gone"):
        read_run(path)
