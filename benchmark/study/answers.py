"""The exported answers (``STUDY/export/answers.csv``, ``answers.json``, ``participants.csv``):
the one owner of the format, which the analysis reads.

Columns of ``answers.csv`` (one row per answer to one question of one trial)::

    participant, slot, trial, kind, question, choice, rows, stimuli, subject, sentence,
    expected, rt_ms, answered_at

``rows`` and ``stimuli`` are the trial's rows and stimulus ids joined by ``|`` in screen order
(A/B: left then right; MOS: the one rated). ``choice`` is ``left``/``right`` or ``1``-``5``.
``expected`` is the attention check's answer (empty otherwise). ``answered_at`` is ISO 8601 UTC.

Columns of ``participants.csv``::

    participant, slot, status, started_at, finished_at, seconds, sound_check_passed,
    platform, platform_id

``status`` is ``complete`` or ``incomplete``; ``platform`` is ``prolific``, ``mturk`` or empty and
``platform_id`` its participant id (no other personal data is stored).
``answers.json`` holds ``{"answers": [...], "participants": [...]}`` with the same fields.
"""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

from blendvoca.errors import DataError

ANSWER_COLUMNS = ("participant", "slot", "trial", "kind", "question", "choice", "rows", "stimuli", "subject",
                  "sentence", "expected", "rt_ms", "answered_at")
PARTICIPANT_COLUMNS = ("participant", "slot", "status", "started_at", "finished_at", "seconds",
                       "sound_check_passed", "platform", "platform_id")
EXPORT_FOLDER = "export"
_INTEGER = {"slot", "rt_ms"}
_FLOAT = {"seconds"}
_BOOLEAN = {"sound_check_passed"}


def _typed(record: dict, where: str) -> dict:
    out = {}
    for key, value in record.items():
        if value in ("", None):
            out[key] = None
        elif key in _INTEGER:
            out[key] = int(value)
        elif key in _FLOAT:
            out[key] = float(value)
        elif key in _BOOLEAN:
            out[key] = value if isinstance(value, bool) else str(value).lower() == "true"
        else:
            out[key] = str(value)
    return out


def _write_csv(path: Path, columns, records) -> None:
    temporary = path.with_name(path.name + ".partial")
    with open(temporary, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="raise")
        writer.writeheader()
        for record in records:
            writer.writerow({key: "" if record.get(key) is None else record[key] for key in columns})
    os.replace(temporary, path)


def write_answers(folder, answers: list[dict], participants: list[dict]) -> list[Path]:
    """Write the three export files into ``folder`` (each complete or not at all)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    _write_csv(folder / "answers.csv", ANSWER_COLUMNS, answers)
    _write_csv(folder / "participants.csv", PARTICIPANT_COLUMNS, participants)
    temporary = folder / "answers.json.partial"
    temporary.write_text(json.dumps({"answers": [{k: a.get(k) for k in ANSWER_COLUMNS} for a in answers],
                                     "participants": [{k: p.get(k) for k in PARTICIPANT_COLUMNS}
                                                      for p in participants]}, indent=1) + "\n", encoding="utf-8")
    os.replace(temporary, folder / "answers.json")
    return [folder / "answers.csv", folder / "participants.csv", folder / "answers.json"]


def _read_csv(path: Path, columns) -> list[dict]:
    if not path.is_file():
        raise DataError(f"{path}: not found; run python -m benchmark.study export STUDY first")
    with open(path, newline="", encoding="utf-8") as handle:
        reader = csv.DictReader(handle)
        missing = [c for c in columns if c not in (reader.fieldnames or ())]
        if missing:
            raise DataError(f"{path}: expected the columns {', '.join(columns)}; missing {', '.join(missing)}")
        return [_typed({c: row[c] for c in columns}, str(path)) for row in reader]


def read_answers(folder) -> tuple[list[dict], list[dict]]:
    """``(answers, participants)`` from an export folder, typed (ints, floats, booleans, None)."""
    folder = Path(folder)
    return _read_csv(folder / "answers.csv", ANSWER_COLUMNS), _read_csv(folder / "participants.csv",
                                                                       PARTICIPANT_COLUMNS)
