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
