"""Staging folders: a folder output is written beside its place and moved there when complete.

:func:`staged_folder` is how a tool that writes a whole folder (a synthetic corpus, the
leaderboard site) leaves either the complete new folder or what was there before: never
a half-written one, whatever interrupts it.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from blendvoca.io.atomic import permissions_for

__all__ = ["staged_folder"]


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
        if not final.exists():
            os.rename(tmp, final)
        elif not replace:
            raise FileExistsError(f"{final} exists (written while this output was made); nothing of it was changed")
        else:
            old = tmp.with_name(tmp.name[: -len(".tmp")] + ".old.tmp")
            os.rename(final, old)
            os.rename(tmp, final)
            shutil.rmtree(old)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
