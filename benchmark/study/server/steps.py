"""What a participant sees, in order: consent (before the session exists), instructions, the
sound check, the practice trial, then one screen per question of each trial of the slot, then
the completion code. The next step is computed from the database alone, so a reload or a
restarted server resumes where the participant stopped.
"""

from __future__ import annotations

from dataclasses import dataclass

from benchmark.study.design import Study

__all__ = ["Screen", "next_step", "question_screens", "SOUND_CHECK_ATTEMPTS"]

#: A participant may type the sound check's word this many times before the study goes on
#: with the session marked as failing it (the analysis excludes it).
SOUND_CHECK_ATTEMPTS = 3


@dataclass(frozen=True)
class Screen:
    """One question of one trial: the unit a participant answers (one per page)."""
    trial: str
    question: str
    index: int          # 0-based among the participant's screens
    practice: bool
    first_of_trial: bool


def practice_trials(study: Study, slot_trials: tuple[str, ...]) -> list[str]:
    """The practice trial shown first: the design's first one, unless the slot already has one."""
    by_id = study.trials_by_id()
    if any(by_id[t].kind == "practice" for t in slot_trials):
        return []
    return [t.id for t in study.trials if t.kind == "practice"][:1]


def question_screens(study: Study, slot: int) -> list[Screen]:
    """Every (trial, question) screen of a slot, in the order shown."""
    slots = {s.slot: s for s in study.participants}
    trials = slots[slot].trials
    by_id = study.trials_by_id()
    screens = []
    for trial_id in [*practice_trials(study, trials), *trials]:
        trial = by_id[trial_id]
        for k, question_id in enumerate(trial.questions):
            screens.append(Screen(trial_id, question_id, len(screens), trial.kind == "practice", k == 0))
    return screens


def next_step(study: Study, participant, answered: set[tuple[str, str]]) -> tuple[str, Screen | None]:
    """``(step, screen)``: step is ``instructions``, ``sound_check``, ``question`` (with its
    screen) or ``done``."""
    if participant.instructions_read_at is None:
        return "instructions", None
    if study.sound_check is not None and participant.sound_check_passed is None:
        return "sound_check", None
    for screen in question_screens(study, participant.slot):
        if (screen.trial, screen.question) not in answered:
            return "question", screen
    return "done", None
