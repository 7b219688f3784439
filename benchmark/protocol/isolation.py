"""What a method's code may not change of the process that scores it (issue 56).

A plug-in runs in the runner's process (its ``train``, ``generate``, ``generate_many``).
:func:`plugin_call` brackets each such call: the torch thread count and the signal
handlers the evaluation relies on are put back as they were (a plug-in calling
``torch.set_num_threads(1)`` no longer changes the last digits of FD, WInD and energy),
and child processes the call started and left running are ended and named. What the
evaluation then used is recorded in the result (``protocol.threads``,
:func:`evaluation_threads`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
from collections.abc import Iterator
from pathlib import Path

__all__ = ["GUARDED_SIGNALS", "evaluation_threads", "live_children", "plugin_call", "warn_notes"]

#: Signals whose handlers a plug-in may not keep changed (SIGALRM: the generate time limit's).
GUARDED_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT", "SIGALRM",
                                                           "SIGPIPE", "SIGCHLD", "SIGUSR1", "SIGUSR2")
                        if hasattr(signal, name))


def live_children() -> dict:
    """``{pid: command line}`` of this process's live children (read from ``/proc``; empty
    where there is none)."""
    me, found = os.getpid(), {}
    proc = Path("/proc")
    if not proc.is_dir():
        return found
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            fields = stat[stat.rindex(")") + 2:].split()
            if int(fields[1]) != me or fields[0] == "Z":
                continue
            cmd = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode("utf-8", "replace").strip()
        except (OSError, ValueError, IndexError):
            continue
        found[int(entry.name)] = cmd or stat[stat.index("(") + 1:stat.rindex(")")]
    return found


def _end(pids) -> None:
    """SIGTERM, then after 2 s SIGKILL, to ``pids`` (their process groups too when they lead one)."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        alive = []
        for pid in pids:
            try:
                os.kill(pid, sig)
                alive.append(pid)
            except (ProcessLookupError, PermissionError):
                pass
        deadline = time.monotonic() + 2.0
        while alive and time.monotonic() < deadline:
            for pid in list(alive):
                try:
                    if os.waitpid(pid, os.WNOHANG)[0] == pid:
                        alive.remove(pid)
                except ChildProcessError:
                    alive.remove(pid)
            time.sleep(0.05)
        pids = alive
        if not pids:
            return


def _torch():
    return sys.modules.get("torch")


def evaluation_threads() -> dict:
    """``{"torch": n}`` (torch's intra-op threads, where torch is loaded): what the
    evaluation computes with, recorded in ``protocol.threads``."""
    torch = _torch()
    return {} if torch is None else {"torch": int(torch.get_num_threads())}


@contextlib.contextmanager
def plugin_call(what: str, *, notes: list | None = None) -> Iterator[None]:
    """Run a block of a method's code, then put back what it may not change.

    Parameters
    ----------
    what : str
        The call, for the messages (``"method 'x', subject 'A', sentence 's01': generate"``).
    notes : list, optional
        Receives one line per thing the call changed and that was put back (threads,
        signal handlers, children ended); the runner prints them as warnings.
    """
    torch = _torch()
    threads = None if torch is None else torch.get_num_threads()
    handlers = {sig: signal.getsignal(sig) for sig in GUARDED_SIGNALS}
    children = set(live_children())
    try:
        yield
    finally:
        changed = []
        torch = _torch()
        if torch is not None and threads is not None and torch.get_num_threads() != threads:
            changed.append(f"torch threads {torch.get_num_threads()} -> {threads}")
            torch.set_num_threads(threads)
        for sig, handler in handlers.items():
            try:
                if signal.getsignal(sig) is not handler and handler is not None:
                    changed.append(f"{signal.Signals(sig).name} handler")
                    signal.signal(sig, handler)
            except (ValueError, OSError):  # off the main thread: nothing was changed there either
                pass
        left = {pid: cmd for pid, cmd in live_children().items() if pid not in children}
        if left:
            _end(list(left))
            changed.append(f"{len(left)} child process(es) it left running, ended: "
                           + "; ".join(f"pid {pid} ({cmd[:60]})" for pid, cmd in sorted(left.items())))
        if changed and notes is not None:
            notes.append(f"{what} changed the runner's process; put back: {', '.join(changed)}")


def warn_notes(notes) -> None:
    """Print each distinct note of :func:`plugin_call` once, as a ``warning:`` line on stderr."""
    seen = set()
    for note in notes:
        key = note.split(" changed ", 1)[-1]
        if key not in seen:
            seen.add(key)
            print(f"warning: {note}", file=sys.stderr)
