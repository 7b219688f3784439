"""Issue 56: the remaining command-line cases: empty paths, a clone named ``blendvoca`` in
the working folder, a read-only home, a full disk under the site, a motionless plug-in,
two reproduce processes on one work folder and Ctrl-C of reproduce during the vertex
metrics."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from tests.faults.conftest import assert_one_error_line
from tests.faults.test_runner_faults import fast_scoring  # noqa: F401 - a fixture

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("module, argv, flag", [
    ("blendvoca.export.__main__", ["--coeffs", "x.csv", "--format", "livelink", "--out", ""], "--out"),
    ("blendvoca.fit.__main__", ["--rig", "r.npz", "--frames", "f.npy", "--out", ""], "--out"),
    ("benchmark.run", ["--method", "mean", "--results", ""], "--results"),
    ("leaderboard.build", ["--results", ""], "--results"),
    ("leaderboard.reproduce", ["--work", "", "--results", "r", "--tables", "t"], "--work"),
    ("blendvoca.builder.__main__", ["--out", ""], "--out"),
])
def test_an_empty_path_is_one_clear_error(capsys, module, argv, flag):
    import importlib

    main = importlib.import_module(module).main
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert_one_error_line(capsys.readouterr().err, flag, "expected a path, got an empty string")


SHADOWED = r"""
import sys, types
# what Python makes of `python -m blendvoca.build` run from the folder holding a clone named
# blendvoca (installed editable through a finder): `blendvoca` is a namespace package of the clone
# folder, whose __init__.py never runs; its submodules still load
package = types.ModuleType("blendvoca")
package.__path__ = [sys.argv[1], sys.argv[2]]
sys.modules["blendvoca"] = package
from blendvoca.builder.__main__ import main
sys.exit(main(["--vocaset", sys.argv[3], "--out", sys.argv[4], "--workers", "1", "--quiet"]))
"""


def test_a_clone_named_blendvoca_in_the_working_folder_does_not_break_the_build(tmp_path, small_corpus):
    clone = tmp_path / "blendvoca"
    (clone / "build").mkdir(parents=True)  # a clone's root: no __init__.py (pip install -e leaves build/)
    done = subprocess.run([sys.executable, "-c", SHADOWED, str(clone), str(ROOT / "blendvoca"), str(small_corpus),
                           str(tmp_path / "B")], cwd=ROOT, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Traceback" not in done.stderr
    from blendvoca.runtime.version import blendvoca_version

    assert json.loads((tmp_path / "B" / "manifest.json").read_text())["version"] == blendvoca_version() != "unknown"


def test_an_unwritable_cache_costs_time_not_the_run(tmp_path):
    from benchmark.metrics.wind import cached_gmm_components_many

    features = np.random.default_rng(0).normal(size=(40, 3))
    with pytest.warns(UserWarning, match="cannot be written"):
        fits = cached_gmm_components_many([(features, 2, 0)], Path("/proc/no-home/.cache/wind-gmm"))
    assert len(fits) == 1 and np.isclose(fits[0][0].sum(), 1.0)


def test_the_site_on_a_full_disk_says_so(tmp_path, capsys, monkeypatch):
    import leaderboard.site as site
    from leaderboard.site.__main__ import main

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(site, "copy_vendor_files", lambda *a, **k: None)
    monkeypatch.setattr(site, "write_site_data", full)
    out = tmp_path / "site"
    code = main(["--results", str(ROOT / "leaderboard" / "results"), "--out", str(out)])
    assert code == 2
    assert_one_error_line(capsys.readouterr().err, f"--out {out}", "ran out of disk space", "another folder")
    assert not out.exists() and not list(tmp_path.iterdir())  # nothing half-written


def test_a_motionless_plugin_is_scored_and_named(small_build, tmp_path, capsys, fast_scoring):  # noqa: F811
    from benchmark.run import main

    code = main(["--method", "tests.faults.plugins:Motionless", "--data", str(small_build), "--results",
                 str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "sentences do not move at all" in err and "lip-sync offsets carry no information" in err
    (path,) = (tmp_path / "r").glob("*.json")
    record = json.loads(path.read_text())
    assert record["protocol"]["motionless_sentences"] == record["dataset"]["num_sentences"]


def test_two_reproduce_processes_on_one_work_folder(tmp_path, capsys):
    from blendvoca.runtime.locks import held_lock
    from leaderboard.reproduce import WORK_LOCK, main

    work = tmp_path / "w"
    work.mkdir()
    with held_lock(work / WORK_LOCK):  # another reproduce holds the folder
        code = main(["--work", str(work), "--results", str(tmp_path / "r"), "--tables", str(tmp_path / "t"),
                     "--only", "mean", "--quiet"])
    assert code == 2
    assert_one_error_line(capsys.readouterr().err, f"--work {work}", "another leaderboard.reproduce",
                          str(os.getpid()))
    assert not (tmp_path / "r").exists()


INTERRUPT = r"""
import os, signal, subprocess, sys
# SIGINT as in a terminal: a shell's background job (nohup, &) inherits it ignored
p = subprocess.Popen(sys.argv[1:], stderr=subprocess.PIPE, text=True, start_new_session=True,
                     preexec_fn=lambda: signal.signal(signal.SIGINT, signal.default_int_handler))
seen = ""
while "vertex metrics" not in seen:
    ch = p.stderr.read(1)
    if not ch:
        break
    seen += ch
os.killpg(p.pid, signal.SIGINT)
rest = p.stderr.read()
p.wait()
print(p.returncode)
sys.stderr.write(seen + rest)
"""


@pytest.mark.slow  # two reproduce runs of one row with the real metrics (about a minute)
def test_ctrl_c_of_reproduce_during_the_vertex_metrics_then_a_rerun(tmp_path, small_build):
    argv = [sys.executable, "-m", "leaderboard.reproduce", "--work", str(tmp_path / "w"), "--data", str(small_build),
            "--results", str(tmp_path / "r"), "--tables", str(tmp_path / "t"), "--only", "mean",
            "--expert-steps", "2"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", INTERRUPT, *argv], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.stdout.strip() == "130", done.stderr[-2000:]
    assert "Traceback" not in done.stderr and "interrupted: rerun the same command" in done.stderr
    again = subprocess.run(argv + ["--quiet"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr[-2000:]
    assert len(list((tmp_path / "r").glob("mean__*.json"))) == 1
    warnings  # noqa: B018
    signal  # noqa: B018
