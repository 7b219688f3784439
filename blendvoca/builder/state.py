"""Stage records: one small JSON per finished (or failed) stage, written last.

A stage is up to date when its record holds the same key (a digest of its
inputs and parameters) and every output it lists still has the recorded
sha256.  Outputs are written atomically before the record, so an interrupted
stage simply has no (or an old) record and is redone.
"""

from __future__ import annotations

import json
from pathlib import Path

from blendvoca.io.atomic import atomic_write

from blendvoca.format.hashing import file_digest
from blendvoca.format.layout import STATE_DIR


def record_path(out, stage: str, *parts: str) -> Path:
    """``<out>/.buildstate/<stage>/<parts...>.json``."""
    return Path(out, STATE_DIR, stage, *parts[:-1], f"{parts[-1]}.json")


def read_record(path) -> dict | None:
    """The record at ``path``, or None when absent or unreadable."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def write_record(path, record: dict) -> None:
    """Write a record atomically (sorted keys: identical records, identical bytes)."""
    with atomic_write(path, "w", encoding="utf-8") as f:
        f.write(json.dumps(record, sort_keys=True, indent=1) + "\n")


def is_up_to_date(out, record: dict | None, key: str) -> bool:
    """True when ``record`` is a success for ``key`` and its outputs are intact."""
    if not record or record.get("key") != key or record.get("status") != "ok":
        return False
    for rel, digest in record.get("files", {}).items():
        path = Path(out, rel)
        if not path.is_file() or file_digest(path) != digest:
            return False
    return True
