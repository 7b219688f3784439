import hashlib
import os

import pytest

from blendvoca.format.hashing import content_digest


def test_content_digest_of_a_file_is_its_sha256(tmp_path):
    path = tmp_path / "weights.pth"
    path.write_bytes(b"\x00\x01weights")
    assert content_digest(path) == hashlib.sha256(b"\x00\x01weights").hexdigest()


def test_content_digest_of_a_folder_follows_names_and_contents_not_timestamps(tmp_path):
    folder = tmp_path / "ckpt"
    (folder / "sub").mkdir(parents=True)
    (folder / "said.json").write_text("{}")
    (folder / "sub" / "said.pt").write_bytes(b"abc")
    first = content_digest(folder)
    os.utime(folder / "said.json", (1, 1))
    assert content_digest(folder) == first
    (folder / "sub" / "said.pt").write_bytes(b"abd")
    changed = content_digest(folder)
    assert changed != first
    (folder / "sub" / "said.pt").rename(folder / "sub" / "other.pt")
    assert content_digest(folder) not in (first, changed)
    with pytest.raises(FileNotFoundError, match="expected a file or a folder at .*missing"):
        content_digest(tmp_path / "missing")
