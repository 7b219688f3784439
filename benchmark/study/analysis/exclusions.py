"""The exclusions a study declares, applied to its exported answers, with their counts.

A participant is left out when they
  - failed an attention check (a trial of kind ``attention`` answered otherwise than its
    ``expected`` answer, in any of its questions),
  - finished faster than ``study.min_seconds`` (``seconds``, else ``finished_at - started_at``;
    CodeTalker discards submissions under two minutes),
  - did not finish (``status`` other than ``complete``),
  - failed the sound check (``sound_check_passed`` false, when the study has one).
Practice trials are never counted, whoever answered them. A participant may hit several
reasons: each reason counts them, ``excluded`` counts them once.
"""

from __future__ import annotations

from datetime import datetime

from blendvoca.errors import DataError

REASONS = ("attention", "too_fast", "incomplete", "sound_check")
REASON_TEXT = {"attention": "failed an attention check", "too_fast": "finished faster than the minimum time",
               "incomplete": "did not finish", "sound_check": "failed the sound check"}


def _elapsed(started: str, finished: str) -> float | None:
    """Seconds between two ISO 8601 times (None when either does not parse)."""
    try:
        return (datetime.fromisoformat(finished.replace("Z", "+00:00"))
                - datetime.fromisoformat(started.replace("Z", "+00:00"))).total_seconds()
    except ValueError:
        return None


def _reasons(study, record: dict, attention_failed: set) -> list[str]:
    reasons = []
    participant = record["participant"]
    if participant in attention_failed:
        reasons.append("attention")
    complete = record.get("status") == "complete"
    seconds = record.get("seconds")
    if seconds is None and record.get("started_at") and record.get("finished_at"):
        seconds = _elapsed(record["started_at"], record["finished_at"])
    if complete and seconds is not None and study.min_seconds and seconds < study.min_seconds:
        reasons.append("too_fast")
    if not complete:
        reasons.append("incomplete")
    if study.sound_check is not None and record.get("sound_check_passed") is False:
        reasons.append("sound_check")
    return reasons


def apply_exclusions(study, answers: list[dict], participants: list[dict], where: str = "the export"):
    """``(kept answers, counts)``: the answers of the participants kept, practice and attention
    trials dropped; ``counts`` is the JSON-ready summary (per reason, totals, a one-line summary)."""
    trials = study.trials_by_id()
    known = {p["participant"] for p in participants}
    strangers = sorted({a["participant"] for a in answers} - known)
    if strangers:
        raise DataError(f"{where}: answers of participants that participants.csv does not list: "
                        f"{', '.join(map(str, strangers[:5]))}")
    attention_failed = set()
    for answer in answers:
        kind = answer.get("kind") or (trials[answer["trial"]].kind if answer["trial"] in trials else None)
        if kind != "attention":
            continue
        expected = answer.get("expected")
        if expected is None and answer["trial"] in trials:
            expected = trials[answer["trial"]].expected
        if expected is not None and answer.get("choice") != expected:
            attention_failed.add(answer["participant"])
    per_reason = {reason: 0 for reason in REASONS}
    excluded = set()
    for record in participants:
        reasons = _reasons(study, record, attention_failed)
        for reason in reasons:
            per_reason[reason] += 1
        if reasons:
            excluded.add(record["participant"])
    kept, practice = [], 0
    for answer in answers:
        kind = answer.get("kind") or (trials[answer["trial"]].kind if answer["trial"] in trials else None)
        if kind == "practice":
            practice += 1
            continue
        if answer["participant"] in excluded or kind == "attention":
            continue
        if kind not in ("ab", "mos"):
            raise DataError(f"{where}: answer to trial {answer['trial']!r} has kind {kind!r}; "
                            "expected ab, mos, attention or practice")
        kept.append(answer)
    total = len(participants)
    counts = {
        "participants": total,
        "kept": total - len(excluded),
        "excluded": len(excluded),
        "by_reason": per_reason,
        "min_seconds": study.min_seconds,
        "answers": len(answers),
        "answers_kept": len(kept),
        "practice_answers_ignored": practice,
    }
    parts = [f"{per_reason[r]} {REASON_TEXT[r]}" for r in REASONS if per_reason[r]]
    counts["summary"] = (f"{total} participants, {len(excluded)} excluded" + (f" ({'; '.join(parts)})" if parts else "")
                         + f", {total - len(excluded)} kept; {len(kept)} of {len(answers)} answers analysed")
    return kept, counts
