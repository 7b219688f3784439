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


def test_written_files_get_the_permissions_of_a_plain_open_or_of_the_file_replaced(tmp_path):
    import stat

    mask = os.umask(0o027)
    try:
        new = tmp_path / "new.json"
        with atomic_write(new, "w") as f:
            f.write("{}")
        assert stat.S_IMODE(new.stat().st_mode) == 0o640  # 0o666 less the umask, not mkstemp's 0o600
        os.chmod(new, 0o604)
        with atomic_write(new, "w") as f:
            f.write("[]")
        assert stat.S_IMODE(new.stat().st_mode) == 0o604 and new.read_text() == "[]"
    finally:
        os.umask(mask)
