"""The one process map: a function over items in worker processes, with the build's care.

:func:`process_map` is what the build, the evaluation, WInD and the renderer run
their parallel work on. Beyond ``ProcessPoolExecutor.map`` it

* runs in this process when one worker is asked for (or there is one item), with
  the same initializer and the same errors;
* keeps an initializer's failure and raises it from every task as one
  :class:`WorkerStartError` (an initializer that raises would otherwise break the
  pool with a message that names nothing);
* ties each worker's life to this process (:mod:`blendvoca.runtime.lifetime`):
  a worker ends when its parent dies, and leaves Ctrl-C to the parent;
* ends its workers at once when the caller stops early (Ctrl-C, an exception, a
  generator closed): no worker outlives the map;
* turns a worker that dies (killed, out of memory) into one :class:`WorkerDied`
  naming the map and how the worker ended;
* draws one progress bar (:func:`blendvoca.runtime.progress.bar`) when given a
  ``desc``.
"""

from __future__ import annotations

import collections
import itertools
import multiprocessing
import os
import signal
import sys
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from blendvoca.errors import BlendVOCAError, UserError, out_of_resources, ran_out_of

from .lifetime import die_with_parent, leave_interrupts_to_the_parent
from .progress import bar

__all__ = ["WorkerDied", "WorkerError", "WorkerStartError", "default_start_method", "failure_reason",
           "is_worker_process", "process_map"]


class WorkerError(UserError):
    """A worker process could not start or died; ends the job (rerun the same command to continue)."""


class WorkerStartError(WorkerError):
    """A worker process could not set itself up (assets, imports)."""


class WorkerDied(WorkerError):
    """A worker process died while it worked (killed by a signal, out of memory, ``os._exit``)."""


#: Per-process state of a worker: whether it is one, and its initializer's failure.
_STATE: dict = {}


def is_worker_process() -> bool:
    """True in a worker process of :func:`process_map` (False in its parent, and while a
    one-worker map runs in this process)."""
    return _STATE.get("worker", False)


def default_start_method() -> str:
    """``"fork"`` on Linux (the workers share the parent's loaded data), ``"spawn"`` elsewhere."""
    return "fork" if sys.platform.startswith("linux") else "spawn"


def failure_reason(error: BaseException) -> str:
    """What went wrong, for a message: a project error's own message (it names what and
    where), what ran out and what to try when memory or disk ran out, else the exception's
    type and message."""
    if isinstance(error, BlendVOCAError):  # its message already says what and where
        return str(error)
    if ran_out_of(error):
        return str(out_of_resources(error))
    return f"{type(error).__name__}: {error}"


def _guarded_init(initializer, initargs) -> None:
    """Run ``initializer(*initargs)``; a failure is kept and raised by every task."""
    _STATE.pop("init_error", None)
    if initializer is None:
        return
    try:
        initializer(*initargs)
    except Exception as error:  # reported to the parent by the tasks
        _STATE["init_error"] = f"a worker process could not start: {failure_reason(error)}"


def _start_worker(parent: int, initializer, initargs) -> None:
    """A pool process's set-up: it ends with ``parent`` and leaves Ctrl-C to it, then the initializer."""
    _STATE["worker"] = True
    leave_interrupts_to_the_parent()
    die_with_parent(parent)
    _guarded_init(initializer, initargs)


def _call_chunk(function, chunk) -> list:
    if "init_error" in _STATE:
        raise WorkerStartError(_STATE["init_error"])
    return [function(item) for item in chunk]


def _chunks(items: Iterable, size: int) -> Iterator[list]:
    iterator = iter(items)
    while chunk := list(itertools.islice(iterator, size)):
        yield chunk


def _how_it_ended(processes) -> str:
    """How the first worker that ended on its own ended ("killed by SIGKILL", "exit status 3");
    "" when none is known any more (the pool may forget a worker that died at once)."""
    for process in processes:
        process.join(timeout=1.0)
        code = process.exitcode
        if code is None or code == -signal.SIGTERM:  # still running, or ended by the pool's clean-up
            continue
        if code < 0:
            try:
                return f"killed by {signal.Signals(-code).name}"
            except ValueError:
                return f"killed by signal {-code}"
        return f"exit status {code}"
    return ""


def _end_workers(processes) -> None:
    """Kill the workers still running (the caller stopped early); the pool then shuts down at once."""
    for process in processes:
        if process.is_alive():
            process.kill()


def process_map(function: Callable, items: Iterable, *, workers: int, initializer: Callable | None = None,
                initargs: tuple = (), desc: str | None = None, unit: str = "item", ordered: bool = True,
                chunksize: int = 1, start_method: str | None = None) -> Iterator:
    """``function(item)`` for each of ``items``, in ``workers`` processes; yields the results.

    Parameters
    ----------
    function : callable
        Picklable under ``start_method`` (a module-level function; any callable under fork).
    items : iterable
        A sized collection is submitted at once (as ``ProcessPoolExecutor.map``); any other
        iterable is read lazily, a few chunks per worker ahead of the results.
    workers : int
        Processes; at most one per chunk is started. 1 (or a single item) runs everything
        in this process, the initializer included, with the same errors.
    initializer, initargs : callable, tuple
        ``initializer(*initargs)`` once per worker (once in this process for one worker);
        when it raises, every task raises :class:`WorkerStartError` with its message.
    desc, unit : str
        A progress bar with this title and unit (none without ``desc``).
    ordered : bool
        Yield the results in the order of ``items`` (True) or as they complete.
    chunksize : int
        Items per task sent to a worker (many small items: fewer messages).
    start_method : str, optional
        ``multiprocessing`` start method; default :func:`default_start_method`.

    Raises
    ------
    WorkerStartError
        The initializer failed (in a worker or in this process).
    WorkerDied
        A worker process died while the map ran ("``desc``: a worker process died
        (killed by SIGKILL: killed, or out of memory) ...").
    Exception
        What ``function`` raised, for the first item that raised it (the other workers
        are ended).
    """
    if chunksize < 1:
        raise ValueError(f"process_map: chunksize must be >= 1, got {chunksize!r}")
    sized = hasattr(items, "__len__")
    total = len(items) if sized else None
    progress = bar(total=total, desc=desc, unit=unit, disable=desc is None)
    try:
        if workers <= 1 or (sized and total <= 1):
            yield from _serial(function, items, initializer, initargs, progress)
        else:
            chunks = _chunks(items, chunksize)
            if sized:
                chunks = list(chunks)
                workers = min(workers, len(chunks))
            yield from _pooled(function, chunks, workers, initializer, initargs, progress, ordered=ordered,
                               desc=desc, start_method=start_method or default_start_method())
    finally:
        progress.close()


def _serial(function, items, initializer, initargs, progress) -> Iterator:
    _guarded_init(initializer, initargs)
    try:
        for item in items:
            if "init_error" in _STATE:
                raise WorkerStartError(_STATE["init_error"])
            yield function(item)
            progress.update()
    finally:
        _STATE.pop("init_error", None)


def _pooled(function, chunks, workers, initializer, initargs, progress, *, ordered, desc, start_method) -> Iterator:
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context(start_method),
                               initializer=_start_worker, initargs=(os.getpid(), initializer, initargs))
    processes = {}  # every worker the pool started (the pool forgets them when it breaks)
    ahead = None if isinstance(chunks, list) else 2 * workers + 2
    chunks = iter(chunks)
    pending = collections.deque()
    done = False
    try:
        while True:
            while not done and (ahead is None or len(pending) < ahead):
                chunk = next(chunks, None)
                if chunk is None:
                    done = True
                    break
                pending.append((pool.submit(_call_chunk, function, chunk), len(chunk)))
                processes.update(pool._processes or {})
            if not pending:
                break
            if ordered:
                future, size = pending.popleft()
            else:
                finished = wait([f for f, _ in pending], return_when=FIRST_COMPLETED).done
                future, size = next(entry for entry in pending if entry[0] in finished)
                pending.remove((future, size))
            results = future.result()
            processes.update(pool._processes or {})
            yield from results
            progress.update(size)
    except BrokenProcessPool:
        where = f"{desc}: " if desc else ""
        how = _how_it_ended(processes.values())
        raise WorkerDied(f"{where}a worker process died ({how + ': ' if how else ''}killed, or out of memory); "
                         "rerun the same command to continue") from None
    except BaseException:  # Ctrl-C, a task's error, the caller closing the generator: no worker outlives the map
        processes.update(pool._processes or {})
        _end_workers(processes.values())
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
