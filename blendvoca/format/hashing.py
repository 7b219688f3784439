"""Content digests and stage keys: the sha256 a manifest lists for each file, and what decides
whether a build stage is up to date."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from blendvoca.assets import sha256_of as file_digest  # one sha256 of a file's bytes for assets and builds


#: Rows converted at a time by ``array_digest(..., dtype=...)``.
_DIGEST_ROWS = 16


def array_digest(*arrays, dtype=None) -> str:
    """sha256 over the dtype, shape and bytes of each array (order matters).

    ``dtype``: the digest of each array converted to ``dtype`` (e.g. float32
    frames digested as the float64 arrays they stand for), converted a few rows
    at a time instead of as a whole copy; the same digest as converting first.
    """
    h = hashlib.sha256()
    for array in arrays:
        array = np.asarray(array)
        target = array.dtype if dtype is None else np.dtype(dtype)
        h.update(f"{target.str}{array.shape}".encode())
        if not array.size:
            continue
        if target == array.dtype:
            # The buffer itself (the bytes tobytes() would copy first).
            h.update(memoryview(np.ascontiguousarray(array).reshape(-1)).cast("B"))
            continue
        for start in range(0, array.shape[0], _DIGEST_ROWS):
            rows = np.ascontiguousarray(array[start:start + _DIGEST_ROWS], dtype=target)
            h.update(memoryview(rows.reshape(-1)).cast("B"))
    return h.hexdigest()


def content_digest(path) -> str:
    """sha256 of a file's bytes, or of a folder's files: each file's relative path
    (``/``-separated) and :func:`file_digest`, in sorted order (names and contents
    decide it, not timestamps)."""
    path = Path(path)
    if path.is_file():
        return file_digest(path)
    if not path.is_dir():
        raise FileNotFoundError(f"content_digest: expected a file or a folder at {path}, found neither")
    h = hashlib.sha256()
    for rel in sorted(p.relative_to(path).as_posix() for p in path.rglob("*") if p.is_file()):
        h.update(f"{rel}\0{file_digest(path / rel)}\n".encode("utf-8"))
    return h.hexdigest()


def stage_key(record: dict) -> str:
    """sha256 of a JSON-serialisable description of a stage's inputs and parameters."""
    text = json.dumps(record, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def files_digests(root, relpaths) -> dict:
    """``{relpath: sha256}`` for files under ``root``."""
    root = Path(root)
    return {rel: file_digest(root / rel) for rel in sorted(relpaths)}
