"""Staging folders: a folder output is written beside its place and moved there when complete.

:func:`staged_folder` is how a tool that writes a whole folder (a synthetic corpus, the
leaderboard site, a converted checkpoint) leaves either the complete new folder or what
was there before: never a half-written one, whatever interrupts it.

An output written over more than one block (a run's tracks, from generation to the
result file; a trained method, saved by its training) is staged in a folder named by
its process, :func:`process_staging`, and moved in with :func:`move_into_place`: a
process killed on the way (``kill -9`` skips every clean-up) leaves a folder that the
next writer of the same output on this host removes.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import tempfile
from collections.abc import Iterator
from pathlib import Path

from blendvoca.io.atomic import permissions_for

from .lifetime import is_running

__all__ = ["move_into_place", "process_staging", "process_tag", "staged_folder"]

_PARTIAL = ".partial"


@contextlib.contextmanager
def staged_folder(final, *, replace: bool = False) -> Iterator[Path]:
    """A new, empty temporary folder beside ``final`` to write into; ``final`` when the block ends.

    When the block completes, the folder gets the permissions a plain ``mkdir`` of
    ``final`` would have (not ``mkdtemp``'s private ones) and is renamed to ``final``;
    when it raises (Ctrl-C included), the temporary folder is removed and ``final``
    is as it was.

    Parameters
    ----------
    final : path-like
        Where the folder goes; its parent is made when missing.
    replace : bool
        An existing ``final`` is replaced (moved aside, the new folder moved in, then
        the old one removed). Only a caller that checked the folder is its own
        (a previous output, an explicit ``--overwrite``) passes True: without it an
        existing ``final`` raises ``FileExistsError`` and nothing of it is touched.
    """
    final = Path(final).expanduser()
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent))
    try:
        yield tmp
        os.chmod(tmp, permissions_for(final, directory=True))
        move_into_place(tmp, final, replace=replace)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def move_into_place(staging, final, *, replace: bool) -> Path:
    """Rename the complete folder ``staging`` to ``final`` (its sibling); returns ``final``.

    An existing ``final`` is replaced when ``replace`` (moved aside, the new folder moved
    in, then the old one removed); without it an existing ``final`` raises
    ``FileExistsError`` and nothing of it is touched.
    """
    staging, final = Path(staging), Path(final)
    if not final.exists():
        os.rename(staging, final)
        return final
    if not replace:
        raise FileExistsError(f"{final} exists (written while this output was made); nothing of it was changed")
    stem, _, suffix = staging.name.rpartition(".")
    old = staging.with_name(f"{stem}.old.{suffix}")
    shutil.rmtree(old, ignore_errors=True)
    os.rename(final, old)
    os.rename(staging, final)
    shutil.rmtree(old)
    return final


def process_tag(pid: int) -> str:
    """``<host>-<pid>``: the process a staging folder belongs to (dots of the host name kept)."""
    return f"{socket.gethostname() or 'host'}-{pid}"


def process_staging(final) -> Path:
    """A new, empty folder ``.<final's name>.<host>-<pid>.partial`` beside ``final``, this
    process's staging of it (move it in with :func:`move_into_place`, or remove it).

    Staging folders of ``final`` left by processes of this host that are gone are removed
    first (this process's own leftover too: a reused process id); those of live processes,
    which may be writing the same output, and of another host sharing the folder, stay.
    """
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    head = f".{final.name}.{process_tag('')}"
    for path in final.parent.iterdir():
        pid = path.name[len(head):-len(_PARTIAL)]
        if path.name.startswith(head) and path.name.endswith(_PARTIAL) and pid.isdigit() and path.is_dir() \
                and (int(pid) == os.getpid() or not is_running(int(pid))):
            shutil.rmtree(path, ignore_errors=True)
    staging = final.parent / f"{head}{os.getpid()}{_PARTIAL}"
    staging.mkdir()
    return staging
