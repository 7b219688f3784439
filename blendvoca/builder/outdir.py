"""The output folder of a build: what the build may write, delete and lock.

Rules (docs/build.md, "What happens when"):

* ``--out`` is either empty / absent, or a folder a previous build marked with
  ``.buildstate/build.json``; anything else is refused, so the build never
  deletes or overwrites files it did not write.
* ``--out`` may not be the corpus, lie inside it, or contain it.
* One build at a time per folder: ``.buildstate/lock`` is held with ``flock``
  for the whole build (the kernel releases it when the process dies, so a
  crashed build never blocks the next one).
* Files the build removes (temporaries of killed writes, outputs of sentences
  that failed or left the corpus) are only ever its own: temporaries named
  ``.blendvoca-<pid>-<output>.<random>.tmp`` by a process no longer running,
  inside its own output folders, and outputs whose sha256 is still the one its
  stage record holds.
* Nothing is written through a symbolic link: a link among the build's own
  folders and files (a previous build's sub-folder replaced by a link to
  another folder, a file replaced by a link) is refused before anything is written.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import time
from pathlib import Path

from blendvoca.errors import OutputDirError
from blendvoca.format.hashing import file_digest
from blendvoca.format.layout import DATA_DIRS, DATA_FILES, MANIFEST_FILE, ORACLE_COEFFS_DIR, REPORT_DIR, STATE_DIR
from blendvoca.format.manifest import BUILD_TOOL, written_by_build
from blendvoca.io.atomic import atomic_write, temporary_owner
from blendvoca.runtime.lifetime import is_running

MARKER = "build.json"
LOCK = "lock"
#: Folders and top-level files a build writes (everything else in ``--out`` is left alone).
OUTPUT_DIRS = (*DATA_DIRS, ORACLE_COEFFS_DIR, REPORT_DIR, STATE_DIR)
OUTPUT_FILES = (*DATA_FILES, MANIFEST_FILE)
#: errno values that mean "the output cannot be written" (fatal for the build, never a per-item failure).
FATAL_ERRNOS = {errno.ENOSPC, errno.EROFS, errno.EACCES, errno.EPERM, getattr(errno, "EDQUOT", errno.ENOSPC)}


def check_output_dir(out: Path, vocaset: Path) -> None:
    """Refuse an ``--out`` that is a file, the corpus, inside the corpus, or holding it.

    Raises
    ------
    OutputDirError
    """
    if out.exists() and not out.is_dir():
        raise OutputDirError(f"--out {out} is a file; expected a folder (empty, new, or a previous build)")
    if out == vocaset:
        raise OutputDirError(f"--out {out} is the input corpus (--vocaset); choose another folder")
    if vocaset in out.parents:
        raise OutputDirError(f"--out {out} is inside the input corpus {vocaset}; choose a folder outside it")
    if out in vocaset.parents:
        raise OutputDirError(f"--out {out} contains the input corpus {vocaset}; choose a folder that does not")


def is_build_folder(out: Path) -> bool:
    """True when ``out`` holds the marker a build writes (``.buildstate/build.json``), or is
    a build from before the marker existed (``.buildstate/`` and a manifest by ``blendvoca.build``)."""
    if (out / STATE_DIR / MARKER).is_file():
        return True
    if not (out / STATE_DIR).is_dir():
        return False
    return written_by_build(out)


def claim_output_dir(out: Path) -> None:
    """Create ``out`` (or accept it: empty or a previous build) and mark it as a build folder.

    Raises
    ------
    OutputDirError
        ``out`` holds files and no build marker, or cannot be written (read-only,
        permissions, disk full); the message names the path.
    """
    refuse_links(out)
    if out.is_dir() and not is_build_folder(out):
        entries = sorted(p.name for p in out.iterdir())
        if entries:
            raise OutputDirError(
                f"--out {out} is not empty and not a BlendVOCA build (no {STATE_DIR}/{MARKER}); it holds "
                f"{entries[:5]}{' ...' if len(entries) > 5 else ''}. The build only writes into an empty folder "
                "or a previous build's: choose a new --out"
            )
    try:
        (out / STATE_DIR).mkdir(parents=True, exist_ok=True)
        if not (out / STATE_DIR / MARKER).is_file():
            with atomic_write(out / STATE_DIR / MARKER, "w", encoding="utf-8") as f:
                f.write(json.dumps({"tool": BUILD_TOOL, "layout": 1}, sort_keys=True) + "\n")
    except OSError as error:
        raise unwritable(error, out) from None


def refuse_links(out: Path) -> None:
    """Refuse a symbolic link among the build's own folders and files in ``out``.

    The build writes into :data:`OUTPUT_DIRS` and :data:`OUTPUT_FILES`; a link
    there (a previous build's ``audio/`` replaced by a link to another folder, a
    CSV replaced by a link to the user's file) would make it write, or delete,
    outside ``out``. ``out`` itself is taken as the user named it (resolved).

    Raises
    ------
    OutputDirError
        Naming the first link found and where it points.
    """
    if not out.is_dir():
        return
    for name in (*OUTPUT_DIRS, *OUTPUT_FILES):
        top = out / name
        if os.path.islink(top):
            raise _link_error(out, top)
        if name not in OUTPUT_DIRS or not top.is_dir():
            continue
        for dirpath, dirnames, filenames in os.walk(top):  # never follows links
            for entry in sorted(dirnames + filenames):
                path = os.path.join(dirpath, entry)
                if os.path.islink(path):
                    raise _link_error(out, Path(path))


def _link_error(out: Path, link: Path) -> OutputDirError:
    return OutputDirError(f"{link} is a symbolic link (to {os.readlink(link)}); the build writes only real files "
                          f"and folders inside --out {out}, never through a link: remove the link (the build "
                          "rewrites what it holds) or choose a new --out")


def unwritable(error: OSError, out) -> OutputDirError:
    """The error raised when the output cannot be written: names the file and the reason."""
    where = error.filename or out
    return OutputDirError(f"cannot write {where}: {error.strerror or error} (output folder {out}); "
                          f"no {MANIFEST_FILE} is left claiming partial outputs: fix this and rerun the same command")


def is_fatal_write_error(error: BaseException) -> bool:
    """True for an OSError that means the output folder cannot be written (disk full, read-only, ...)."""
    return isinstance(error, OSError) and error.errno in FATAL_ERRNOS


@contextlib.contextmanager
def build_lock(out: Path, wait: float = 3.0):
    """Hold ``<out>/.buildstate/lock`` for the duration; a second build on ``out`` is refused.

    The lock is an ``flock``: the kernel drops it when the holder (and the worker
    processes it forked) exit, however they end. A lock still held after ``wait``
    seconds means another build is running.

    Raises
    ------
    OutputDirError
        Another process holds the lock (its pid is named).
    """
    import fcntl

    path = out / STATE_DIR / LOCK
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
    except OSError as error:
        if error.errno == errno.ELOOP:
            raise _link_error(out, path) from None
        raise unwritable(error, out) from None
    _HELD_LOCKS.add(fd)
    try:
        deadline = time.monotonic() + wait
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                # A killed build's worker processes may take a moment to exit (and drop the lock).
                if time.monotonic() >= deadline:
                    holder = os.pread(fd, 64, 0).decode("ascii", errors="replace").strip() or "unknown"
                    if holder.isdigit() and not is_running(int(holder)):
                        # only processes that build started can hold its lock now (an older version's workers)
                        raise OutputDirError(f"the build (pid {holder}) that wrote to {out} is no longer running, "
                                             f"but processes it started still hold its lock {path} (`fuser -v "
                                             f"{path}` lists them): end them, then rerun") from None
                    raise OutputDirError(f"another build (pid {holder}) is writing to {out}; wait for it to "
                                         "finish, or use another --out") from None
                time.sleep(0.1)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
        yield path
    finally:
        _HELD_LOCKS.discard(fd)
        os.close(fd)  # releases the flock; the file itself stays (it is ours)


#: Descriptors of the build locks this process holds (see :func:`drop_inherited_locks`).
_HELD_LOCKS: set = set()


def drop_inherited_locks() -> None:
    """Close, in a forked worker process, its copies of the parent's lock descriptors.

    An ``flock`` belongs to the open file, which a fork shares: as long as any
    process holds a copy of the descriptor, the lock stays taken. A worker
    therefore closes its copies at start (the parent's lock is unaffected), so
    that nothing but the build process itself holds the build's lock.
    """
    for fd in list(_HELD_LOCKS):
        try:
            os.close(fd)
        except OSError:
            pass
    _HELD_LOCKS.clear()


def remove_stale_temporaries(out) -> int:
    """Delete the temporaries of killed atomic writes in the build's own files; return the count.

    ``atomic_write`` names them ``.blendvoca-<pid>-<name>.<random>.tmp`` beside
    the target (:func:`blendvoca.io.atomic.temporary_owner`). Only such names
    whose process is no longer running are removed, and only in the build's
    output folders (:data:`OUTPUT_DIRS`) and beside its top-level files
    (:data:`OUTPUT_FILES`): a user's own ``.notes.tmp`` is never taken for one.
    """
    out = Path(out)
    running: dict[int, bool] = {}

    def stale(name: str) -> bool:
        pid = temporary_owner(name)
        if pid is None:
            return False
        if pid not in running:
            running[pid] = pid == os.getpid() or is_running(pid)
        return not running[pid]

    count = 0
    for name in os.listdir(out):
        if stale(name) and any(name.startswith(f".blendvoca-{temporary_owner(name)}-{target}.")
                               for target in OUTPUT_FILES):
            os.unlink(out / name)
            count += 1
    for folder in OUTPUT_DIRS:
        for dirpath, _, filenames in os.walk(out / folder):
            for name in filenames:
                if stale(name):
                    os.unlink(os.path.join(dirpath, name))
                    count += 1
    return count


def remove_own_outputs(out, record: dict | None) -> list[str]:
    """Delete the outputs a stage record lists whose sha256 is still the recorded one.

    Files changed since (someone else's now), missing files and paths that do not
    resolve to a file under ``out`` (``../``, absolute, through a link: a tampered
    record) are left as they are. Returns the relative paths removed.
    """
    removed = []
    base = Path(out).resolve()
    for rel, digest in sorted(((record or {}).get("files") or {}).items()):
        path = Path(out, rel)
        try:
            inside = path.resolve().is_relative_to(base) and not path.is_symlink()
        except (OSError, RuntimeError, ValueError):
            inside = False
        if inside and path.is_file() and file_digest(path) == digest:
            path.unlink()
            removed.append(rel)
    return removed
