"""Issue 56, deliverable 6: resource failures named as such, and a plug-in that cannot
change what the evaluation runs with (threads, signal handlers), defeat the generate time
limit, delete results unnoticed or leave processes behind."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.faults.conftest import assert_one_error_line
from tests.faults.test_runner_faults import fast_scoring  # noqa: F401 - a fixture

ROOT = Path(__file__).resolve().parents[2]
PLUGINS = "tests.faults.plugins"
FAST = r"""
import sys
from benchmark.protocol import scoring
from tests.methods.fakes import fake_evaluate_split
scoring.evaluate_split = fake_evaluate_split
from benchmark.run import main
sys.exit(main(sys.argv[1:]))
"""


def _run(capsys, build, results, method, *argv):
    from benchmark.run import main

    code = main(["--method", method, "--data", str(build), "--results", str(results), "--quiet", *map(str, argv)])
    return code, capsys.readouterr()


def _subprocess(build, results, method, *argv, env=None, timeout=120):
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-c", FAST, "--method", method, "--data", str(build), "--results",
                           str(results), "--quiet", *map(str, argv)], cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})}, timeout=timeout)
    return done, time.monotonic() - started


def test_a_plugin_cannot_change_the_evaluations_threads_or_signal_handlers(small_build, tmp_path, capsys,
                                                                           fast_scoring):  # noqa: F811
    import torch

    before_threads = torch.get_num_threads()
    torch.set_num_threads(2)
    inherited = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a terminal (a background job inherits SIG_IGN)
    sigint, sigterm = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    try:
        code, out = _run(capsys, small_build, tmp_path / "r", f"{PLUGINS}:SetsThreads")
        assert code == 0, out.err
        assert torch.get_num_threads() == 2
        assert signal.getsignal(signal.SIGINT) is sigint and signal.getsignal(signal.SIGTERM) is sigterm
        assert "torch threads 1 -> 2" in out.err and "SIGINT handler" in out.err
        (path,) = (tmp_path / "r").glob("*.json")
        assert json.loads(path.read_text())["protocol"]["threads"] == {"torch": 2}
    finally:
        torch.set_num_threads(before_threads)
        signal.signal(signal.SIGINT, inherited)


def test_the_time_limit_holds_against_a_plugin_that_ignores_the_alarm(small_build, tmp_path):
    done, seconds = _subprocess(small_build, tmp_path / "r", f"{PLUGINS}:IgnoresAlarm", "--generate-time-limit", "2",
                                env={"BLENDVOCA_TEST_TARGET": "60"})
    assert done.returncode == 3, done.stderr
    assert "exceeded the limit of 2 s" in done.stderr and "SIGALRM" in done.stderr
    assert seconds < 40
    assert not list((tmp_path / "r").glob("*.json"))


def test_a_plugin_waiting_on_a_child_is_stopped_and_its_child_ended(small_build, tmp_path):
    done, seconds = _subprocess(small_build, tmp_path / "r", f"{PLUGINS}:WaitsOnChild", "--generate-time-limit", "2")
    assert done.returncode == 3, done.stderr
    assert "exceeded the limit of 2 s" in done.stderr and "Traceback" not in done.stderr
    assert seconds < 40
    left = subprocess.run(["pgrep", "-f", "import time; time.sleep(60)"], capture_output=True, text=True)
    assert not left.stdout.strip()


def test_a_plugin_deleting_results_during_generate_is_named(small_build, tmp_path, capsys, monkeypatch,
                                                            fast_scoring):  # noqa: F811
    results = tmp_path / "r"
    assert _run(capsys, small_build, results, "mean")[0] == 0
    (earlier,) = results.glob("*.json")
    monkeypatch.setenv("BLENDVOCA_TEST_TARGET", str(results))
    code, out = _run(capsys, small_build, results, f"{PLUGINS}:DeletesResults")
    assert code == 3
    assert_one_error_line(out.err, "deleted while it generated", earlier.name, "nothing was stored")


def test_children_a_plugin_leaves_running_are_named_and_ended(small_build, tmp_path, capsys,
                                                              fast_scoring):  # noqa: F811
    from tests.faults.plugins import SpawnsChildren

    SpawnsChildren.started.clear()
    code, out = _run(capsys, small_build, tmp_path / "r", f"{PLUGINS}:SpawnsChildren")
    assert code == 0, out.err
    assert "2 child process(es) it left running, ended" in out.err
    assert len(SpawnsChildren.started) == 2
    for child in SpawnsChildren.started:
        assert child.poll() is not None  # ended (and reaped)


def test_memory_running_out_in_a_plugin_is_named_not_a_bug(small_build, tmp_path, capsys,
                                                           fast_scoring):  # noqa: F811
    code, out = _run(capsys, small_build, tmp_path / "r", f"{PLUGINS}:RaisesMemoryError")
    assert code == 2
    assert_one_error_line(out.err, "ran out of memory", "generate", "try")
    assert "internal error" not in out.err


@pytest.mark.parametrize("error", [MemoryError("cannot allocate"), OSError(errno.ENOMEM, "Cannot allocate memory")])
def test_the_mesh_metrics_fallback_does_not_swallow_memory_errors(error):
    from benchmark.evaluation import _source_meshes
    from blendvoca.errors import OutOfResources

    class Dataset:
        def vertices(self, subject, sentence):
            try:
                raise error
            except Exception as exc:  # a reader that wraps what it hit, as the mesh readers do
                raise ValueError(f"{subject}/{sentence}: could not read") from exc

    with pytest.raises(OutOfResources, match="ran out of memory"):
        _source_meshes(Dataset(), [("A", "s01")], None)

    class NoMeshes:  # a corpus without meshes: still the quiet fallback
        def vertices(self, subject, sentence):
            raise FileNotFoundError("no meshes")

    with pytest.warns(UserWarning, match="mesh-space metrics"):
        assert _source_meshes(NoMeshes(), [("A", "s01")], None) is None


def test_a_memory_error_escaping_a_tool_is_exit_2_with_what_to_try(capsys):
    from blendvoca import cli

    @cli.command
    def main(argv=None):
        raise MemoryError()

    assert main([]) == 2
    err = capsys.readouterr().err
    assert_one_error_line(err, "ran out of memory", "try")
    assert "internal error" not in err

    @cli.command
    def full(argv=None):
        raise OSError(errno.ENOSPC, "No space left on device", "/tmp/site/index.html")

    assert full([]) == 2
    assert_one_error_line(capsys.readouterr().err, "/tmp/site/index.html", "ran out of disk space", "another folder")


def test_torch_allocator_failures_are_memory():
    from blendvoca.errors import ran_out_of

    message = ("[enforce fail at alloc_cpu.cpp:127] err == 0. DefaultCPUAllocator: can't allocate memory: you tried "
               "to allocate 15204352 bytes. Error code 12 (Cannot allocate memory)")
    assert ran_out_of(RuntimeError(message)) == "memory"
    assert ran_out_of(RuntimeError("CUDA out of memory. Tried to allocate 2.00 GiB")) == "memory"
    assert ran_out_of(RuntimeError("shape mismatch")) is None
    # soundfile's cffi dlopen under `ulimit -v` (issue 56's 500 MB build, per item)
    dlopen = OSError("cannot load library 'libsndfile.so': libsndfile.so: failed to map segment from shared object")
    assert ran_out_of(dlopen) == "memory"
    assert ran_out_of(OSError("cannot load library 'libsndfile.so': no such file")) is None


LIMITED = r"""
import resource, sys
limit = int(sys.argv[1])
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
from benchmark.run import main
sys.exit(main(sys.argv[2:]))
"""


@pytest.mark.slow  # a real scoring under an address-space limit (about 30 s)
def test_a_run_under_a_memory_limit_fails_naming_memory_or_has_every_metric(small_build, tmp_path):
    results = tmp_path / "r"
    done = subprocess.run([sys.executable, "-c", LIMITED, str(1200 * 2**20), "--method", "mean", "--data",
                           str(small_build), "--results", str(results), "--quiet"], cwd=ROOT, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr, done.stderr[-2000:]
    if done.returncode:
        assert done.returncode == 2 and "ran out of memory" in done.stderr, done.stderr[-2000:]
        assert not list(results.glob("*.json"))
    else:
        (path,) = results.glob("*.json")
        metrics = json.loads(path.read_text())["metrics"]
        assert {"lve_mesh", "lve_rig", "mve_mesh"} <= set(metrics)  # the mesh metrics were not dropped


@pytest.mark.parametrize("megabytes", [700, 850])
def test_a_run_below_pytorchs_address_space_is_refused_before_it_aborts(small_build, tmp_path, megabytes):
    """Issue 56's `ulimit -v` 700 MB benchmark: PyTorch's import aborted the process (C++ std::bad_alloc,
    exit 134, no message); below the measured floor the run is refused up front, naming the limit."""
    results = tmp_path / "r"
    done = subprocess.run([sys.executable, "-c", LIMITED, str(megabytes * 2**20), "--method", "mean", "--data",
                           str(small_build), "--results", str(results), "--quiet"], cwd=ROOT, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 2, done.stderr[-2000:]
    assert done.stderr.count("error:") == 1 and "Traceback" not in done.stderr, done.stderr
    assert f"allows {megabytes} MiB" in done.stderr and "ulimit -v" in done.stderr
    assert not results.exists() or not list(results.iterdir())
