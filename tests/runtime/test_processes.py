"""blendvoca.runtime.processes: the one process map (results as a serial map's, errors, Ctrl-C, dying workers)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from blendvoca.runtime.processes import (
    WorkerDied,
    WorkerStartError,
    is_worker_process,
    process_map,
)
from tests.faults.test_build_reliability import _alive, _children, _interrupted_with_ctrl_c, _sigint_as_in_a_terminal

ROOT = Path(__file__).resolve().parents[2]


def _square(x):
    return x * x


def _pid_and_flag(_):
    return os.getpid(), is_worker_process()


def _fails_on_three(x):
    if x == 3:
        raise ValueError(f"item {x} is bad")
    return x


def _sleep_then(x):
    time.sleep(0.05 * (5 - x))
    return x


def _die(x):
    if x == 2:
        os.kill(os.getpid(), signal.SIGKILL)  # as the OOM killer does
    return x


def _broken_init():
    raise ImportError("a module the worker needs is missing")


_SEEN = {}


def _remember(value):
    _SEEN["value"] = value


def _seen(_):
    return _SEEN.get("value")


@pytest.mark.parametrize("workers", [1, 2, 3])
@pytest.mark.parametrize("chunksize", [1, 4])
def test_results_equal_a_serial_map(workers, chunksize):
    items = list(range(23))
    assert list(process_map(_square, items, workers=workers, chunksize=chunksize)) == list(map(_square, items))
    # a lazy iterable (read a few chunks ahead) gives the same
    lazy = (i for i in items)
    assert list(process_map(_square, lazy, workers=workers, chunksize=chunksize)) == list(map(_square, items))


def test_unordered_results_are_the_same_set_in_completion_order():
    got = list(process_map(_sleep_then, range(5), workers=5, ordered=False))
    assert sorted(got) == [0, 1, 2, 3, 4]
    assert got[0] == 4  # the shortest task first


def test_one_worker_runs_here_and_more_run_in_workers():
    here = os.getpid()
    assert list(process_map(_pid_and_flag, range(3), workers=1)) == [(here, False)] * 3
    pooled = list(process_map(_pid_and_flag, range(6), workers=2))
    assert all(pid != here and flag for pid, flag in pooled)
    assert not is_worker_process()


@pytest.mark.parametrize("workers", [1, 2])
def test_the_initializer_runs_in_every_worker(workers):
    assert list(process_map(_seen, range(4), workers=workers, initializer=_remember, initargs=("set",))) == ["set"] * 4


@pytest.mark.parametrize("workers", [1, 2])
def test_an_initializer_that_fails_is_one_worker_start_error(workers):
    with pytest.raises(WorkerStartError, match="worker process could not start: ImportError: a module the worker"):
        list(process_map(_square, range(4), workers=workers, initializer=_broken_init))


@pytest.mark.parametrize("workers", [1, 2])
def test_a_task_error_reaches_the_caller_as_it_was(workers):
    with pytest.raises(ValueError, match="item 3 is bad"):
        list(process_map(_fails_on_three, range(8), workers=workers))


def test_a_worker_killed_by_a_signal_is_a_clear_error():
    # the signal is named when the pool still knows the worker (one that dies at once may be forgotten)
    with pytest.raises(WorkerDied, match=r"^squares: a worker process died \((killed by SIGKILL: )?killed, or out "
                                         r"of memory\); rerun the same command to continue$"):
        list(process_map(_die, range(6), workers=2, desc="squares"))


def test_closing_the_map_early_ends_its_workers():
    before = _children(os.getpid())  # (a forkserver another test started lives on)
    results = process_map(_pid_and_flag, iter(range(100)), workers=2)
    next(results)
    workers = _children(os.getpid()) - before
    assert workers
    results.close()
    assert not any(map(_alive, workers))


def test_bad_chunksize_is_refused():
    with pytest.raises(ValueError, match="chunksize must be >= 1, got 0"):
        list(process_map(_square, range(3), workers=2, chunksize=0))


#: A map with one worker busy (item 0) and one idle, waiting for work (where Ctrl-C used
#: to print the waiting worker's KeyboardInterrupt traceback).
_BUSY_AND_IDLE_POOL = """
import sys, time
from blendvoca import cli
from blendvoca.runtime.processes import process_map
from blendvoca.runtime.progress import set_progress

set_progress(False)  # as --quiet does


def task(i):
    if i == 0:
        print("busy", flush=True)
        time.sleep(60)
    return i


@cli.command
def main(argv=None):
    list(process_map(task, [0, 1, 2], workers=2, desc="tasks"))
    return 0


sys.exit(main())
"""


def test_ctrl_c_ends_busy_and_idle_workers_without_a_traceback():
    process = subprocess.Popen([sys.executable, "-c", _BUSY_AND_IDLE_POOL], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                               preexec_fn=_sigint_as_in_a_terminal)
    assert process.stdout.readline().strip() == "busy"
    time.sleep(0.5)  # the other worker has done items 1 and 2 and waits for more
    workers = _children(process.pid)
    assert workers
    _interrupted_with_ctrl_c(process)
    assert not any(map(_alive, workers))


_INTERRUPTED_IN_THE_PARENT_ONLY = """
import sys, time
from blendvoca.runtime.processes import process_map


def task(i):
    if i == 0:  # one line from one worker (two workers printing at once may share a line)
        print("busy", flush=True)
    time.sleep(60)
    return i


try:
    list(process_map(task, range(4), workers=2))
except KeyboardInterrupt:
    print("interrupted", flush=True)
"""


def test_keyboard_interrupt_in_the_parent_alone_leaves_no_worker_behind():
    process = subprocess.Popen([sys.executable, "-c", _INTERRUPTED_IN_THE_PARENT_ONLY],
                               env=dict(os.environ, PYTHONPATH=str(ROOT)), stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, preexec_fn=_sigint_as_in_a_terminal)
    try:
        assert process.stdout.readline().strip() == "busy"  # a worker runs a task
        workers = _children(process.pid)
        clock = time.monotonic()
        os.kill(process.pid, signal.SIGINT)  # the parent alone: the map must end its workers itself
        out, err = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    assert "interrupted" in out, err
    assert time.monotonic() - clock < 10  # not the tasks' 60 s
    assert workers and not any(map(_alive, workers))
