"""``python -m benchmark.study export STUDY [--db URL]``: the answers as CSV and JSON in STUDY/export.

Writes ``answers.csv``, ``participants.csv`` and ``answers.json`` through
:func:`benchmark.study.answers.write_answers` (columns in that module), and
``completion_codes.csv`` (participant, platform, platform_id, completion_code) for approving
submissions on the platform. Practice answers are not exported.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

from benchmark.study.answers import EXPORT_FOLDER, write_answers
from benchmark.study.design import read_study
from blendvoca.errors import UserError

__all__ = ["export_records", "export_study"]


def _iso(moment) -> str | None:
    return None if moment is None else moment.isoformat().replace("+00:00", "Z")


def export_records(study, store) -> tuple[list[dict], list[dict]]:
    """``(answers, participants)`` records in :mod:`benchmark.study.answers`' columns."""
    by_id = study.trials_by_id()
    people = store.all_participants()
    public = {p.id: p for p in people}
    answers = []
    for a in store.all_answers():
        trial = by_id.get(a["trial"])
        if trial is None or trial.kind == "practice":
            continue
        stimuli = [study.stimuli[s] for s in trial.stimuli]
        participant = public[a["participant_id"]]
        answers.append({
            "participant": participant.public_id, "slot": participant.slot, "trial": trial.id, "kind": trial.kind,
            "question": a["question"], "choice": a["choice"], "rows": "|".join(s.row for s in stimuli),
            "stimuli": "|".join(trial.stimuli), "subject": stimuli[0].subject if stimuli else None,
            "sentence": stimuli[0].sentence if stimuli else None, "expected": trial.expected,
            "rt_ms": a["rt_ms"], "answered_at": _iso(a["answered_at"])})
    participants = []
    for p in people:
        seconds = (p.finished_at - p.started_at).total_seconds() if p.finished_at else None
        participants.append({
            "participant": p.public_id, "slot": p.slot, "status": "complete" if p.finished_at else "incomplete",
            "started_at": _iso(p.started_at), "finished_at": _iso(p.finished_at),
            "seconds": None if seconds is None else round(seconds, 3),
            "sound_check_passed": p.sound_check_passed if study.sound_check is not None else None,
            "platform": p.platform, "platform_id": p.platform_id})
    return answers, participants


def export_study(folder, db_url: str | None = None) -> list[Path]:
    """Write STUDY/export (answers.csv, participants.csv, answers.json, completion_codes.csv)."""
    from benchmark.study.server.store import open_store

    from benchmark.study.server.store import DB_FILE

    folder = Path(folder)
    study = read_study(folder)
    if db_url is None and not (folder / DB_FILE).is_file():
        raise UserError(f"{folder}: no answers yet ({folder / DB_FILE} does not exist); serve the study first "
                        "(python -m benchmark.study serve), or give --db URL")
    store = open_store(folder, db_url)
    try:
        answers, participants = export_records(study, store)
        out = folder / EXPORT_FOLDER
        written = write_answers(out, answers, participants)
        codes = out / "completion_codes.csv"
        temporary = codes.with_name(codes.name + ".partial")
        with open(temporary, "w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(["participant", "platform", "platform_id", "completion_code", "status"])
            for p in store.all_participants():
                writer.writerow([p.public_id, p.platform or "", p.platform_id or "", p.completion_code,
                                 "complete" if p.finished_at else "incomplete"])
        os.replace(temporary, codes)
    finally:
        store.close()
    return [*written, codes]


def add_arguments(parser) -> None:
    parser.add_argument("study", help="the study folder")
    parser.add_argument("--db", metavar="URL", default=None,
                        help="database URL (default sqlite:///STUDY/answers.sqlite)")


def run(args) -> int:
    written = export_study(args.study, args.db)
    for path in written:
        print(path)
    return 0
