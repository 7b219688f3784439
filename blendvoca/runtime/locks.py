"""Exclusive locks on a file (``flock``): one writer of an output at a time.

:func:`held_lock` is the lock of an output that several processes could write at once
(a result file and its tracks, a ``leaderboard.reproduce`` work folder). It is an
``flock`` on a small file holding the holder's pid: the kernel drops it when the holder
exits, however it ends, so a killed process never leaves a lock behind.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import time
from collections.abc import Iterator
from pathlib import Path

__all__ = ["LockHeld", "held_lock"]


class LockHeld(RuntimeError):
    """Another process holds the lock; ``holder`` is its pid as it wrote it ("" when unknown)."""

    def __init__(self, path, holder: str):
        super().__init__(f"{path} is held by process {holder or 'unknown'}")
        self.path, self.holder = Path(path), holder


@contextlib.contextmanager
def held_lock(path, *, wait: float = 0.0) -> Iterator[Path]:
    """Hold an exclusive ``flock`` on ``path`` (made when missing, never followed as a
    link) for the block; the file stays (it holds the last holder's pid). ``path`` may be
    an existing folder: the folder itself is locked, nothing is written into it.

    Parameters
    ----------
    path : path-like
    wait : float
        Seconds to wait for another holder to let go (0: try once).

    Raises
    ------
    LockHeld
        Another process still holds it after ``wait`` seconds.
    OSError
        The lock file cannot be made or opened (a read-only folder, a link in its place).
    """
    path = Path(path)
    folder = path.is_dir() and not path.is_symlink()
    flags = (os.O_RDONLY | getattr(os, "O_DIRECTORY", 0)) if folder else (os.O_RDWR | os.O_CREAT)
    fd = os.open(path, flags | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0), 0o644)
    try:
        deadline = time.monotonic() + max(0.0, float(wait))
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except OSError as error:
                if error.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise
                if time.monotonic() >= deadline:
                    holder = "" if folder else os.pread(fd, 32, 0).decode("ascii", errors="replace").strip()
                    raise LockHeld(path, holder) from None
                time.sleep(0.05)
        if not folder:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
        yield path
    finally:
        os.close(fd)  # releases the flock
