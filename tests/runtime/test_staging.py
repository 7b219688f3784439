"""blendvoca.runtime.staging: a folder output appears whole or not at all."""

from __future__ import annotations

import stat

import pytest

from blendvoca.io.atomic import permissions_for
from blendvoca.runtime.staging import staged_folder


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
