import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from benchmark.results import (
    SCHEMA_VERSION,
    Latency,
    build_result,
    check,
    read,
    result_filename,
    seed_replicates,
    write,
)
from benchmark.results.__main__ import main as results_main
from blendvoca.errors import DataError

METRICS = {"fd": {"mean": 1.5, "std": 0.1, "higher_is_better": False, "unit": ""}}
COMMITTED = Path(__file__).resolve().parents[2] / "leaderboard"


def _result(**overrides):
    kw = {"method": {"name": "m", "config": {"a": 1}}, "dataset": {"manifest_hash": "abc123"},
              "protocol": {"samples": 1, "seed": 0}, "metrics": METRICS, "timings": {"train_s": 1.23456}}
    kw.update(overrides)
    return build_result(**kw)


def test_build_fills_provenance():
    r = _result()
    assert r.method.label == "m" and r.schema_version == SCHEMA_VERSION == 3
    prov = r.provenance
    assert "numpy" in prov.versions and prov.hardware["cores"] >= 1 and prov.date
    assert prov.hardware["blas"] and all(isinstance(k, str) for k in prov.hardware["blas"])
    assert r.timings["train_s"] == 1.235


def test_write_read_round_trip(tmp_path):
    r = _result()
    path = write(tmp_path / r.filename(), r)
    assert path.name == r.filename() == "m__abc123__s1__seed0.json"
    assert read(path) == r
    assert read(path).to_json() == json.loads(json.dumps(r.to_json()))
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temp file left


def test_bad_metrics_refused_and_nothing_written(tmp_path):
    with pytest.raises(DataError, match="finite"):
        _result(metrics={"x": {"mean": float("nan"), "std": 0, "higher_is_better": True}})
    with pytest.raises(DataError, match="higher_is_better"):
        _result(metrics={"x": {"mean": 1.0}})
    r = _result()
    bad = dataclasses.replace(r, metrics={"fd": dataclasses.replace(r.metrics["fd"], mean=float("inf"))})
    with pytest.raises(DataError, match="metrics.fd.mean: expected a finite number"):
        write(tmp_path / "r.json", bad)
    assert list(tmp_path.iterdir()) == []


def test_check_names_problem():
    with pytest.raises(DataError, match="schema_version"):
        check({"schema_version": 0})
    record = _result().to_json()
    del record["dataset"]["manifest_hash"]
    with pytest.raises(DataError, match="manifest_hash"):
        check(record)
    record = _result().to_json()
    record["per_seed"] = [{"seed": "0"}]
    with pytest.raises(DataError, match=r"^here: per_seed\[0\]\.seed: expected an integer, got '0'$"):
        check(record, "here")


def test_fields_this_version_does_not_type_are_kept_and_latency_is_closed():
    record = _result().to_json()
    record["study"] = {"preference": [0.5, 0.25]}  # a later part, unknown here
    record["method"]["note"] = "kept"
    record["protocol"]["checkpoint"] = None
    r = check(record)
    assert r.to_json() == record and r.extra == {"study": {"preference": [0.5, 0.25]}}
    assert r.protocol.get("checkpoint", "none") == "none" and r.method.extra["note"] == "kept"
    with pytest.raises(DataError, match="latency.speed: unknown field"):
        check({**record, "latency": {"speed": 1.0}})
    r = _result(latency={"rtf": 0.5})
    assert r.latency == Latency(rtf=0.5) and r.to_json()["latency"]["lookahead_s"] is None


def test_committed_results_read_and_write_back_unchanged(tmp_path):
    """The committed files are schema 3 and canonical: read and written again, byte for byte."""
    paths = sorted((COMMITTED / "results").glob("*.json")) + sorted((COMMITTED / "results-archive").rglob("*.json"))
    assert len(paths) >= 27
    for path in paths:
        result = read(path)
        assert result.schema_version == 3
        assert write(tmp_path / path.name, result).read_text() == path.read_text()


def test_every_result_the_tables_read_records_its_measured_lookahead():
    """Protocol v4: each committed board file (not the archive) has a latency record whose
    causality probe measured the look-ahead, reference rows included."""
    paths = sorted((COMMITTED / "results").glob("*.json"))
    assert len(paths) >= 19
    for path in paths:
        latency = read(path).latency
        assert latency is not None and latency.rtf is not None, path.name
        assert latency.lookahead_probe is not None and latency.lookahead_probe.note is None, path.name
        assert latency.measured_lookahead_s is not None, path.name


def test_seed_replicates_per_seed_else_the_metrics_own():
    assert [a.tolist() for a in seed_replicates("fd", [{"fd": [1.0, 2.0]}, {"fd": [3.0]}])] == [[1.0, 2.0], [3.0]]
    own = seed_replicates("fd", [{"fd": [1.0]}, {}], own=[5.0, 6.0])
    assert len(own) == 1 and own[0].dtype == np.float64 and own[0].tolist() == [5.0, 6.0]
    assert seed_replicates("fd", [{"fd": [float("nan")]}]) is None and seed_replicates("fd", []) is None
    r = _result(metrics={"fd": {**METRICS["fd"], "replicates": [1.0, 2.0]}},
                per_seed=[{"seed": 0, "replicates": {"fd": [1.5]}}, {"seed": 1, "replicates": {"fd": [2.5]}}])
    assert [a.tolist() for a in r.seed_replicates("fd")] == [[1.5], [2.5]]


def test_git_dirty_ignores_the_committed_output_folders(tmp_path):
    """Rows of one reproduce run are written in turn: a result or table written before
    does not make the next run's code dirty; any other change does."""
    import subprocess

    from benchmark.results import git_revision

    def git(*args):
        subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@example.org", *args], cwd=tmp_path,
                       check=True, capture_output=True)

    git("init", "-q")
    for rel in ("leaderboard/results/a.json", "leaderboard/tables/leaderboard.md", "benchmark/code.py"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("0\n")
    git("add", "-A")
    git("commit", "-q", "-m", "first")
    assert git_revision(tmp_path / "benchmark")["dirty"] is False
    (tmp_path / "leaderboard/results/a.json").write_text("1\n")
    (tmp_path / "leaderboard/results/b.json").write_text("new\n")
    (tmp_path / "leaderboard/tables/leaderboard.md").write_text("1\n")
    (tmp_path / "leaderboard/results-archive/old").mkdir(parents=True)
    (tmp_path / "leaderboard/results-archive/old/a.json").write_text("0\n")  # reproduce --archive
    state = git_revision(tmp_path / "benchmark")
    assert state["dirty"] is False and len(state["revision"]) == 40
    (tmp_path / "benchmark/code.py").write_text("1\n")
    assert git_revision(tmp_path / "benchmark")["dirty"] is True


def test_a_run_over_several_seeds_is_named_by_them():
    r = _result(protocol={"samples": 5, "seed": 0, "seeds": [0, 1, 2]})
    assert r.filename() == result_filename("m", "abc123", 5, 0, (0, 1, 2)) == "m__abc123__s5__seeds0-1-2.json"


def test_older_result_files_are_refused_with_one_line_saying_what_to_run(tmp_path, capsys):
    record = _result().to_json()
    old = tmp_path / "old.json"
    for version, remedy in ((2, f"run `python -m benchmark.results upgrade {old}`"),
                            (1, "rescore the run with `python -m benchmark.run`")):
        old.write_text(json.dumps({**record, "schema_version": version}))
        with pytest.raises(DataError) as error:
            read(old)
        message = str(error.value)
        assert "\n" not in message and message.startswith(f"{old}: a schema-{version} result file")
        assert remedy in message


def test_upgrade_rewrites_a_schema_2_file_with_its_numbers_unchanged(tmp_path, capsys):
    record = _result(per_sentence=[{"subject": "s", "sentence": "q", "fd": 1.25}]).to_json()
    old = tmp_path / "old.json"
    old.write_text(json.dumps({**record, "schema_version": 2}, indent=2, sort_keys=True) + "\n")
    assert results_main(["upgrade", str(old)]) == 0
    assert read(old).to_json() == record
    assert results_main(["upgrade", str(old)]) == 0  # already schema 3: left alone
    assert capsys.readouterr().out.splitlines() == [f"{old}: upgraded to schema 3", f"{old}: already schema 3"]
    old.write_text(json.dumps({**record, "schema_version": 1}))
    assert results_main(["upgrade", str(old)]) != 0
    assert "schema-1 result file" in capsys.readouterr().err and json.loads(old.read_text())["schema_version"] == 1


def test_the_learning_curve_round_trips_and_its_statements_stay_outside_the_digest():
    convergence = {"checked_at_step": 2, "total_steps": 4, "settled": False,
                   "metrics": {"fd": {"half_budget": 2.0, "full_budget": 1.5, "half_width": 0.1, "settled": False}},
                   "sentences": [["S1", "sentence01"], ["S1", "sentence02"]],
                   "curve": [{"step": 1, "metrics": {"fd": 3.0, "lve_rig": 2.0},
                              "per_sentence": {"lve_rig": [1.5, 2.5]}, "replicates": {"fd": [2.9, 3.1]}},
                             {"step": 2, "metrics": {"fd": 2.0}}]}
    r = _result(convergence=convergence)
    assert r.to_json()["convergence"] == convergence
    assert r.convergence.curve[0].per_sentence == {"lve_rig": [1.5, 2.5]} and r.convergence.sentences[1] == \
        ("S1", "sentence02")
    stated = _result(convergence={**convergence, "statements": ["m: would lose to n"]})
    assert stated.record_digest() == r.record_digest()  # the table's verdict is not a measurement
    edited = _result(convergence={**convergence, "curve": [{"step": 1, "metrics": {"fd": 3.5}}]})
    assert edited.record_digest() != r.record_digest()  # the curve is
    with pytest.raises(DataError, match=r"convergence\.curve\[0\]\.per_sentence\.lve_rig"):
        _result(convergence={**convergence, "curve": [{"step": 1, "metrics": {}, "per_sentence": {"lve_rig": []}}]})
    with pytest.raises(DataError, match=r"convergence\.sentences: expected a list of \[subject, sentence\]"):
        _result(convergence={**convergence, "sentences": [["S1"]]})
