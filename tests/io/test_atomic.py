import errno
import os

import pytest

from blendvoca.io.atomic import atomic_write


def test_failed_write_leaves_the_target_and_no_temporary(tmp_path):
    path = tmp_path / "out.txt"
    path.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_write(path, "w") as f:
            f.write("new")
            raise RuntimeError("stop")
    assert path.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_a_full_disk_error_names_the_target(tmp_path, monkeypatch):
    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")  # as the kernel reports it: no file name

    monkeypatch.setattr(os, "fsync", full)
    path = tmp_path / "deep" / "out.bin"
    with pytest.raises(OSError) as caught:
        with atomic_write(path) as f:
            f.write(b"x")
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(path)
    assert list(path.parent.iterdir()) == []
