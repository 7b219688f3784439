"""Issue 56, deliverable 3: no silent replacement. A result's file name carries the digest
of every setting that changes its numbers (for every run but a plain one); a run that
would replace a result of other settings is refused unless ``--overwrite``; runs writing
into one ``--results`` at once never mix one's result with another's tracks."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.faults.conftest import assert_one_error_line
from tests.faults.test_runner_faults import fast_scoring  # noqa: F401 - a fixture

ROOT = Path(__file__).resolve().parents[2]


def _run(capsys, build, results, *argv):
    from benchmark.run import main

    code = main(["--method", "random", "--data", str(build), "--results", str(results), "--quiet", "--samples", "2",
                 *map(str, argv)])
    return code, capsys.readouterr()


def _results(folder):
    return sorted(p for p in Path(folder).glob("*.json"))


def test_another_config_gets_its_own_name_and_the_plain_run_keeps_its_own(small_build, tmp_path, capsys,
                                                                        fast_scoring):  # noqa: F811
    from benchmark.runs import read_run

    results = tmp_path / "r"
    assert _run(capsys, small_build, results)[0] == 0
    (plain,) = _results(results)
    assert "__c" not in plain.name  # a plain run keeps the name it always had
    plain_text = plain.read_text()
    for scale in (0.1, 0.2):
        code, out = _run(capsys, small_build, results, "--config", f"scale={scale}")
        assert code == 0, out.err
    files = _results(results)
    assert len(files) == 3 and plain.read_text() == plain_text  # nothing replaced
    for path in files:
        stored = read_run(path)
        scale = stored.result.method.config.get("scale", 0.3)
        assert stored.result.settings_digest() in path.name or path == plain
        assert max(stored.tracks(*key).max() for key in stored.keys) <= scale + 1e-9
    # the same settings again replace their own result (a rerun), nothing else
    assert _run(capsys, small_build, results, "--config", "scale=0.1")[0] == 0
    assert len(_results(results)) == 3


def test_a_result_of_other_settings_under_the_name_is_refused_unless_overwrite(small_build, tmp_path, capsys,
                                                                              fast_scoring):  # noqa: F811
    results = tmp_path / "r"
    assert _run(capsys, small_build, results, "--config", "scale=0.1")[0] == 0
    (configured,) = _results(results)
    # what the version before the digest wrote: a configured run under the plain name
    plain_name = configured.name.split("__c")[0] + ".json"
    shutil.copy(configured, results / plain_name)
    before = (results / plain_name).read_bytes()
    code, out = _run(capsys, small_build, results)
    assert code == 2
    assert_one_error_line(out.err, plain_name, "other settings", "config", "--overwrite")
    assert (results / plain_name).read_bytes() == before
    assert not [p for p in results.iterdir() if p.name.endswith(".partial")]
    code, out = _run(capsys, small_build, results, "--overwrite")
    assert code == 0, out.err
    assert json.loads((results / plain_name).read_text())["method"]["config"]["scale"] == 0.3
    # a file that is no result is not replaced either
    (results / plain_name).write_text("not json")
    code, out = _run(capsys, small_build, results)
    assert code == 2 and "no readable result" in out.err


def test_the_digest_covers_every_setting_that_changes_numbers(small_build, tmp_path):
    from benchmark.results import read

    from benchmark.protocol import RunSpec, run
    from tests.methods.fakes import fake_evaluate

    base = dict(data_root=small_build, samples=2)
    names = set()
    for extra in ({}, {"config": {"scale": 0.2}}, {"samples": 3}, {"seed": 1}, {"clip": True},
                  {"budget": __import__("benchmark.methods", fromlist=["Budget"]).Budget(max_steps=3)},
                  {"split": "val"}):
        spec = RunSpec("random", results_dir=tmp_path / "r", **{**base, **extra})
        path = run(spec, evaluate=fake_evaluate)
        names.add(path.name)
        assert read(path).settings()  # read back
    assert len(names) == 7


CONCURRENT = r"""
import sys
from benchmark.protocol import scoring
from tests.methods.fakes import fake_evaluate_split
scoring.evaluate_split = fake_evaluate_split
from benchmark.run import main
sys.exit(main(sys.argv[1:]))
"""


def test_four_concurrent_runs_into_one_folder_each_keep_their_own_tracks(small_build, tmp_path):
    from benchmark.runs import read_run

    results = tmp_path / "r"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    procs = [subprocess.Popen([sys.executable, "-c", CONCURRENT, "--method", "random", "--data", str(small_build),
                               "--results", str(results), "--quiet", "--samples", "2", "--config", f"scale={scale}"],
                              cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for scale in (0.1, 0.2, 0.3, 0.4)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0, 0], [o[1] for o in outs]
    files = _results(results)
    assert len(files) == 4
    scales = []
    for path in files:
        stored = read_run(path)
        scale = stored.result.method.config["scale"]
        scales.append(scale)
        peak = max(stored.tracks(*key).max() for key in stored.keys)
        assert scale - 0.1 < peak <= scale + 1e-9, (path.name, scale, peak)  # its own tracks, no other run's
    assert sorted(scales) == [0.1, 0.2, 0.3, 0.4]
    assert not [p for p in results.iterdir() if p.name.endswith(".partial")]


def test_runs_of_one_name_take_turns(tmp_path):
    """The result's lock: a second writer of the same name waits for the first (and is
    refused with a clear message when it never lets go)."""
    from blendvoca.runtime.locks import LockHeld, held_lock

    lock = tmp_path / ".x.json.lock"
    with held_lock(lock):
        child = subprocess.run([sys.executable, "-c",
                                "import sys; from blendvoca.runtime.locks import held_lock, LockHeld\n"
                                f"try:\n    with held_lock({str(lock)!r}, wait=0.3): sys.exit(0)\n"
                                "except LockHeld as e:\n    print(e.holder); sys.exit(7)"],
                               cwd=ROOT, capture_output=True, text=True)
        assert child.returncode == 7 and child.stdout.strip() == str(os.getpid())
    with held_lock(lock, wait=0):
        pass
    assert LockHeld
    np  # noqa: B018
