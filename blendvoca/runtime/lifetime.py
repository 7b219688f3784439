"""A worker process lives no longer than the process that started it.

A pool worker blocks on its task queue, whose pipe it holds both ends of: when
its parent (a build, an evaluation, a render) dies without closing the pool
(SIGKILL, SIGTERM: what ``timeout``, ``docker stop`` and systemd send) the worker
would wait forever, and keep the copies it inherited of the parent's descriptors.
Each worker of :func:`blendvoca.runtime.processes.process_map` therefore

* asks the kernel to kill it when its parent dies (Linux ``PR_SET_PDEATHSIG``),
* runs a watchdog thread that ends it when its parent changes (every platform;
  also covers the moment before the request above took effect),
* leaves Ctrl-C to the parent: the terminal sends SIGINT to the whole
  process group, and the parent alone reports it (``interrupted: ...``)
  and stops the pool; a worker ends at once and silently instead of printing a
  ``KeyboardInterrupt`` traceback of its own.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

#: Seconds between two looks of the watchdog at the parent process.
WATCH_INTERVAL = 0.5
_PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int) -> bool:
    """Make this process end when process ``parent`` (its parent) ends.

    Parameters
    ----------
    parent : int
        The pid of the process that started this worker.

    Returns
    -------
    bool
        True when the kernel will signal this process on its parent's death
        (Linux); the watchdog thread runs either way.
    """
    armed = _request_death_signal()
    if os.getppid() != parent:  # the parent died before the request took effect
        os._exit(1)
    thread = threading.Thread(target=_watch, args=(parent,), name="blendvoca-parent-watchdog", daemon=True)
    thread.start()
    return armed


def _request_death_signal() -> bool:
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):  # pragma: no cover - no prctl in this C library
        return False


def _watch(parent: int) -> None:
    """Watchdog thread: end the process (no clean-up: its parent is gone) once it is orphaned."""
    event = threading.Event()
    while not event.wait(WATCH_INTERVAL):
        if os.getppid() != parent:
            os._exit(1)


def leave_interrupts_to_the_parent() -> None:
    """Ctrl-C ends this worker at once and without a traceback (the default action of SIGINT).

    The parent, which gets the same SIGINT, reports the interruption and shuts the
    pool down (the temporaries a killed build write leaves are removed by the next
    build: :func:`blendvoca.builder.outdir.remove_stale_temporaries`).
    """
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:  # a parent started with SIGINT ignored
        signal.signal(signal.SIGINT, signal.SIG_DFL)              # (nohup, a background job) keeps it ignored


def is_running(pid: int) -> bool:
    """True when a process ``pid`` exists (and is not a zombie) on this machine; True
    where that cannot be told (not a POSIX system: ``os.kill`` would end the process)."""
    if pid <= 0:
        return False
    if os.name != "posix":
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's process
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as stat:
            return stat.read().rpartition(")")[2].split()[0] != "Z"
    except (OSError, IndexError):
        return True
