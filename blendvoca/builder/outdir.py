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
  ``.<output>.<random>.tmp`` inside its own output folders, and outputs whose
  sha256 is still the one its stage record holds.
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
from blendvoca.format.layout import DATA_DIRS, DATA_FILES, MANIFEST_FILE, REPORT_DIR, STATE_DIR
from blendvoca.format.manifest import BUILD_TOOL, written_by_build
from blendvoca.io.atomic import atomic_write

MARKER = "build.json"
LOCK = "lock"
#: Folders and top-level files a build writes (everything else in ``--out`` is left alone).
OUTPUT_DIRS = (*DATA_DIRS, REPORT_DIR, STATE_DIR)
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
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as error:
        raise unwritable(error, out) from None
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
                    raise OutputDirError(f"another build (pid {holder}) is writing to {out}; wait for it to "
                                         "finish, or use another --out") from None
                time.sleep(0.1)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
        yield path
    finally:
        os.close(fd)  # releases the flock; the file itself stays (it is ours)


def remove_stale_temporaries(out) -> int:
    """Delete the temporaries of killed atomic writes in the build's own files; return the count.

    ``atomic_write`` names them ``.<name>.<random>.tmp`` beside the target. Only
    the build's output folders (:data:`OUTPUT_DIRS`) and its top-level files
    (:data:`OUTPUT_FILES`) are looked at; the caller holds the build lock, so no
    other build's in-flight temporaries can be among them.
    """
    out = Path(out)
    count = 0
    for name in os.listdir(out):
        if name.endswith(".tmp") and any(name.startswith(f".{target}.") for target in OUTPUT_FILES):
            os.unlink(out / name)
            count += 1
    for folder in OUTPUT_DIRS:
        for dirpath, _, filenames in os.walk(out / folder):
            for name in filenames:
                if name.startswith(".") and name.endswith(".tmp"):
                    os.unlink(os.path.join(dirpath, name))
                    count += 1
    return count


def remove_own_outputs(out, record: dict | None) -> list[str]:
    """Delete the outputs a stage record lists whose sha256 is still the recorded one.

    Files changed since (someone else's now) and missing files are left as they
    are. Returns the relative paths removed.
    """
    removed = []
    for rel, digest in sorted(((record or {}).get("files") or {}).items()):
        path = Path(out, rel)
        if path.is_file() and file_digest(path) == digest:
            path.unlink()
            removed.append(rel)
    return removed
