"""Atomic file writes: a reader never sees a half-written output.

The temporary beside the target is named ``.blendvoca-<pid>-<name>.<random>.tmp``
(:func:`temporary_prefix`): the prefix marks it as written by BlendVOCA and the pid
says which process wrote it, so a clean-up after a killed write
(:func:`blendvoca.builder.outdir.remove_stale_temporaries`) removes only files
whose names it made, and only those of processes that are no longer running.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import stat
import tempfile
from pathlib import Path

#: Every temporary written here: ``.blendvoca-<pid>-<target name>.<random>.tmp``.
TEMPORARY = re.compile(r"^\.blendvoca-(?P<pid>[0-9]+)-(?P<target>.+)\.[^.]+\.tmp$")


def temporary_prefix(name: str, pid: int | None = None) -> str:
    """The prefix of the temporaries written for target ``name`` by process ``pid`` (default: this one)."""
    return f".blendvoca-{os.getpid() if pid is None else int(pid)}-{name}."


def temporary_owner(name: str) -> int | None:
    """The pid of the process that made temporary ``name``, or None when the name is not one of ours."""
    match = TEMPORARY.match(name)
    return int(match["pid"]) if match else None


@contextlib.contextmanager
def atomic_write(path, mode: str = "wb", **kwargs):
    """Open a temporary file beside ``path``; on success rename it over ``path``.

    On an exception (including KeyboardInterrupt) the temporary file is removed and
    ``path`` is left as it was. An ``OSError`` that names no file (a write failing
    on a full disk) is raised again naming ``path``.
    """
    path = Path(path)
    if path.is_dir():  # os.replace would fail only after the write, naming the temporary
        raise IsADirectoryError(errno.EISDIR, "a folder is there; expected the path of a file to write", str(path))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=temporary_prefix(path.name), suffix=".tmp")
    except OSError as error:
        raise _naming(error, path) from None
    try:
        # mkstemp makes the file private (0600); give it the permissions that the file
        # it replaces had, or that a plain open() would give a new one
        os.chmod(tmp, permissions_for(path))
        with os.fdopen(fd, mode, **kwargs) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as error:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(error, OSError) and error.filename is None and error.errno is not None:
            raise _naming(error, path) from None
        raise


def permissions_for(path, *, directory: bool = False) -> int:
    """The permission bits for an output written to ``path`` through a temporary
    (``mkstemp`` and ``mkdtemp`` make it private): those of what is at ``path`` now,
    or, for a new one, those a plain ``open()`` (``0o666``) or ``mkdir`` (``0o777``)
    would give under the umask."""
    try:
        return stat.S_IMODE(Path(path).stat().st_mode)
    except FileNotFoundError:
        return (0o777 if directory else 0o666) & ~_umask()


def _umask() -> int:
    """The process's umask (read from /proc where it is there: setting it to read it races with threads)."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _naming(error: OSError, path: Path) -> OSError:
    if error.filename is not None or error.errno is None:
        return error
    return OSError(error.errno, error.strerror or str(error), str(path))
