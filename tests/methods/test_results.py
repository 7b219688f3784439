import json

import pytest

from benchmark.results import (
    build_result,
    check_result,
    read_result,
    result_filename,
    write_result,
)

METRICS = {"fd": {"mean": 1.5, "std": 0.1, "higher_is_better": False, "unit": ""}}


def _result(**overrides):
    kw = {"method": {"name": "m", "config": {"a": 1}}, "dataset": {"manifest_hash": "abc123"},
              "protocol": {"samples": 1, "seed": 0}, "metrics": METRICS, "timings": {"train_s": 1.23456}}
    kw.update(overrides)
    return build_result(**kw)


def test_build_fills_provenance():
    r = _result()
    assert r["method"]["label"] == "m"
    prov = r["provenance"]
    assert "numpy" in prov["versions"] and prov["hardware"]["cores"] >= 1 and prov["date"]
    assert prov["hardware"]["blas"] and all(isinstance(k, str) for k in prov["hardware"]["blas"])
    assert r["timings"]["train_s"] == 1.235


def test_write_read_round_trip(tmp_path):
    r = _result()
    path = write_result(r, tmp_path)
    assert path.name == result_filename(r) == "m__abc123__s1__seed0.json"
    assert read_result(path) == json.loads(json.dumps(r))
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temp file left


def test_bad_metrics_refused_and_nothing_written(tmp_path):
    with pytest.raises(ValueError, match="finite"):
        _result(metrics={"x": {"mean": float("nan"), "std": 0, "higher_is_better": True}})
    with pytest.raises(ValueError, match="higher_is_better"):
        _result(metrics={"x": {"mean": 1.0}})
    r = _result()
    r["metrics"]["fd"]["mean"] = float("inf")
    with pytest.raises(ValueError):
        write_result(r, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_check_result_names_problem():
    with pytest.raises(ValueError, match="schema_version"):
        check_result({"schema_version": 0})
    r = _result()
    del r["dataset"]["manifest_hash"]
    with pytest.raises(ValueError, match="manifest_hash"):
        check_result(r)


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
    assert result_filename(r) == "m__abc123__s5__seeds0-1-2.json"


def test_schema_1_results_read_with_their_names_in_the_space_they_were_scored_in(tmp_path):
    """Before the two reference spaces, vertex rows were scored against the source meshes
    and coefficient rows against the rig reconstruction of the ground truth."""
    old = {"lve": {"mean": 1.2, "std": 0.1, "higher_is_better": False, "unit": "mm"},
           "apd": {"mean": 3.0, "std": 0.1, "higher_is_better": True, "unit": "mm"}, **METRICS}
    for output, space in (("vertices", "mesh"), ("coefficients", "rig"), (None, "rig")):
        r = _result(method={"name": "m", "config": {}, **({"output": output} if output else {})}, metrics=old,
                    per_sentence=[{"subject": "s", "sentence": "q", "lve": 1.2}])
        r["schema_version"] = 1
        path = tmp_path / f"{space}-{output}.json"
        path.write_text(json.dumps(r))
        read = read_result(path)
        assert read["schema_version"] == 1
        assert set(read["metrics"]) == {f"lve_{space}", f"apd_{space}", "fd"}
        assert read["per_sentence"] == [{"subject": "s", "sentence": "q", f"lve_{space}": 1.2}]
    assert _result()["schema_version"] == 2
    with pytest.raises(ValueError, match="schema_version"):
        check_result({**_result(), "schema_version": 3})
