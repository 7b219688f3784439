"""Content digests and stage keys: what decides whether a build stage is up to date."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np


def array_digest(*arrays) -> str:
    """sha256 over the dtype, shape and bytes of each array (order matters)."""
    h = hashlib.sha256()
    for array in arrays:
        array = np.ascontiguousarray(array)
        h.update(f"{array.dtype.str}{array.shape}".encode())
        # The buffer itself (the bytes tobytes() would copy first).
        h.update(memoryview(array.reshape(-1)).cast("B") if array.size else b"")
    return h.hexdigest()


def file_digest(path, chunk: int = 1 << 20) -> str:
    """sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def stage_key(record: dict) -> str:
    """sha256 of a JSON-serialisable description of a stage's inputs and parameters."""
    text = json.dumps(record, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def files_digests(root, relpaths) -> dict:
    """``{relpath: sha256}`` for files under ``root``."""
    root = Path(root)
    return {rel: file_digest(root / rel) for rel in sorted(relpaths)}
