"""Issue 56, deliverable 4: what a run reads is verified against the build's manifest,
all of it (every split), before anything runs and again after the method generated; the
ground truth is held in memory before the plug-in runs. A change is exit 4 naming the
file, nothing stored."""

from __future__ import annotations

import shutil

import pytest

from blendvoca import format as fmt
from tests.faults.conftest import assert_one_error_line
from tests.faults.test_runner_faults import _edit_one_value, fast_scoring  # noqa: F401 - a fixture


@pytest.fixture
def build(tmp_path, small_build):
    out = tmp_path / "B"
    shutil.copytree(small_build, out)
    return out


def _run(capsys, build, results, method="mean", *argv):
    from benchmark.run import main

    code = main(["--method", method, "--data", str(build), "--results", str(results), "--quiet", *map(str, argv)])
    return code, capsys.readouterr()


def test_a_tampered_training_track_is_refused_before_training(build, tmp_path, capsys, fast_scoring):  # noqa: F811
    edited = fmt.coeffs_path(build, fmt.read_splits(build)["train"][0], "sentence01")
    _edit_one_value(edited)
    code, out = _run(capsys, build, tmp_path / "r", "regression", "--max-steps", "2")
    assert code == 4
    assert_one_error_line(out.err, str(edited), "manifest.json")
    assert not (tmp_path / "r").exists() or not any((tmp_path / "r").glob("*.json"))


def test_a_plugin_rewriting_a_test_csv_during_generate_stops_the_run(build, tmp_path, capsys, monkeypatch,
                                                                     fast_scoring):  # noqa: F811
    from tests.faults.plugins import TARGET

    target = fmt.coeffs_path(build, fmt.read_splits(build)["test"][0], "sentence01")
    monkeypatch.setenv(TARGET, str(target))
    code, out = _run(capsys, build, tmp_path / "r", "tests.faults.plugins:RewritesTestCsv")
    assert code == 4
    assert_one_error_line(out.err, str(target), "changed while the method generated", "nothing was stored")
    assert not any((tmp_path / "r").glob("*.json"))
    assert not [p for p in (tmp_path / "r").iterdir() if not p.name.startswith(".write-test")]


def test_the_ground_truth_is_scored_as_verified_not_as_rewritten(build, tmp_path, monkeypatch):
    """With verification off after the fact, the scores still compare with what was read
    before the plug-in ran (held in memory)."""
    import numpy as np

    from benchmark.protocol import RunSpec, check_inputs, generate, train
    from tests.faults.plugins import TARGET

    subject = fmt.read_splits(build)["test"][0]
    target = fmt.coeffs_path(build, subject, "sentence01")
    monkeypatch.setenv(TARGET, str(target))
    spec = RunSpec("tests.faults.plugins:RewritesTestCsv", data_root=build, results_dir=tmp_path / "r")
    inputs = check_inputs(spec, evaluation_assets=False)
    before = inputs.dataset.coeffs(subject, "sentence01")
    trained = train(spec, inputs.dataset)
    with pytest.raises(Exception, match="changed while the method generated"):
        generate(spec, inputs.dataset, trained)
    assert np.array_equal(inputs.dataset.coeffs(subject, "sentence01"), before)
    held = inputs.dataset.coeffs(subject, "sentence01")
    held[:] = 9.0  # a copy: the held ground truth does not change
    assert np.array_equal(inputs.dataset.coeffs(subject, "sentence01"), before)
