"""blendvoca.runtime.staging: a folder output appears whole or not at all."""

from __future__ import annotations

import stat

import pytest

from blendvoca.io.atomic import permissions_for
from blendvoca.runtime.staging import process_tag, move_into_place, process_staging, staged_folder


def _siblings(path):
    return sorted(p.name for p in path.parent.iterdir())


def test_a_completed_block_moves_the_folder_into_place_with_mkdir_permissions(tmp_path):
    final = tmp_path / "new" / "out"
    want = permissions_for(final, directory=True)
    with staged_folder(final) as tmp:
        assert tmp.parent == final.parent and tmp.is_dir() and not any(tmp.iterdir())
        (tmp / "a.txt").write_text("a")
        assert not final.exists()
    assert (final / "a.txt").read_text() == "a"
    assert stat.S_IMODE(final.stat().st_mode) == want
    assert _siblings(final) == ["out"]  # no temporary left


def test_a_failed_block_leaves_nothing_and_the_previous_folder_as_it_was(tmp_path):
    final = tmp_path / "out"
    final.mkdir()
    (final / "old.txt").write_text("old")
    for error in (RuntimeError("boom"), KeyboardInterrupt()):
        with pytest.raises(type(error)):
            with staged_folder(final, replace=True) as tmp:
                (tmp / "new.txt").write_text("new")
                raise error
        assert sorted(p.name for p in final.iterdir()) == ["old.txt"]
        assert _siblings(final) == ["out"]


def test_an_existing_folder_is_replaced_only_when_asked(tmp_path):
    final = tmp_path / "out"
    final.mkdir()
    (final / "old.txt").write_text("old")
    with pytest.raises(FileExistsError, match="exists .* nothing of it was changed"):
        with staged_folder(final) as tmp:
            (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in final.iterdir()) == ["old.txt"] and _siblings(final) == ["out"]
    with staged_folder(final, replace=True) as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in final.iterdir()) == ["new.txt"] and _siblings(final) == ["out"]


def test_move_into_place_replaces_only_when_asked(tmp_path):
    final = tmp_path / "out"
    for content in ("first", "second"):
        staging = tmp_path / f".out.{content}.partial"
        (staging / "f").parent.mkdir()
        (staging / "f").write_text(content)
        assert move_into_place(staging, final, replace=True) == final
        assert (final / "f").read_text() == content
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging, no old copy
    (tmp_path / ".out.third.partial").mkdir()
    with pytest.raises(FileExistsError, match="nothing of it was changed"):
        move_into_place(tmp_path / ".out.third.partial", final, replace=False)
    assert (final / "f").read_text() == "second"


def test_process_staging_removes_the_leftovers_of_dead_processes_of_this_host_only(tmp_path):
    import os
    import subprocess
    import sys

    dead = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                              text=True, check=True).stdout)
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        killed = tmp_path / f".out.{process_tag(dead)}.partial"
        own = tmp_path / f".out.{process_tag(os.getpid())}.partial"
        kept = [tmp_path / f".out.{process_tag(live.pid)}.partial",  # a live process's, another host's, another output's
                tmp_path / f".out.elsewhere.example-{dead}.partial", tmp_path / f".other.{process_tag(dead)}.partial"]
        for folder in (killed, own, *kept):
            (folder / "x").mkdir(parents=True)
        staging = process_staging(tmp_path / "out")
        assert staging == own and list(staging.iterdir()) == []  # this process's leftover: emptied
        assert not killed.exists() and all(folder.is_dir() for folder in kept)
    finally:
        live.kill()
        live.wait()
