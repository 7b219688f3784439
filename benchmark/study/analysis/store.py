"""The study's verdict stored in the studied rows' result files (``analyze --board DIR --store``),
as their ``human_preference`` part (:class:`benchmark.results.HumanPreference`), which the
leaderboard's "human preference" column reads.

Per row and question: the share of answers preferring this row to the study's reference row
(``1 - share_a`` of the reference's comparison with it) with its interval, the Bradley-Terry
log-strength relative to the reference, and the MOS, each where the study has it.
"""

from __future__ import annotations

import dataclasses
from datetime import datetime, timezone

from benchmark import results as result_files
from benchmark.results import HumanPreference


def preference_records(record: dict, study_name: str) -> dict:
    """``{row: human_preference JSON}`` for every row of the analysis ``record``."""
    reference = record["reference"]
    date = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    out = {}
    for row in record["rows"]:
        questions = {}
        for question in record["questions"]:
            entry = {}
            for p in record["preference"]:
                if p["question"] == question and p["a"] == reference and p["b"] == row:
                    entry.update(share=1 - p["share_a"], ci95=[1 - p["ci95"][1], 1 - p["ci95"][0]],
                                 answers=p["answers"])
            for s in record["bradley_terry"].get(question, {}).get("strengths", []):
                if s["row"] == row:
                    entry.update(log_strength=s["log_strength"], strength_ci95=s["ci95"])
            for m in record["mos"]:
                if m["question"] == question and m["row"] == row:
                    entry.update(mos=m["mean"], mos_ci95=m["ci95"], answers=m["ratings"])
            if entry:
                questions[question] = entry
        if questions or row == reference:
            out[row] = {"study": study_name, "reference": reference, "design": record["design"],
                        "participants": record["exclusions"]["kept"], "date": date, "questions": questions}
    return out


def store_preferences(chosen: dict, record: dict, study_name: str) -> list:
    """Write each studied row's ``human_preference`` into its result file (``chosen``:
    :func:`~benchmark.study.analysis.board.board_results`), each file atomically; the paths written."""
    written = []
    updated = []
    for row, data in preference_records(record, study_name).items():
        path, result = chosen[row]
        part = HumanPreference.from_json(data, "human_preference")
        updated.append((path, result_files.check(dataclasses.replace(result, human_preference=part).to_json(),
                                                 str(path))))
    for path, result in updated:  # every record checked before any file is replaced
        written.append(result_files.write(path, result))
    return written
