"""A hand-made A/B study and its export, for the analysis tests: three rows, two questions,
six sentences, an attention check and a practice trial; eleven participants of whom five
are excluded for known reasons."""

from __future__ import annotations

from pathlib import Path

from benchmark.study.answers import write_answers
from benchmark.study.design import Slot, SoundCheck, Stimulus, Study, Trial, question, write_study

ROWS = ("ours", "voca", "faceformer")
SENTENCES = [("S1", "sentence01"), ("S1", "sentence02"), ("S1", "sentence03"),
             ("S2", "sentence01"), ("S2", "sentence02"), ("S2", "sentence03")]
QUESTIONS = ("lipsync", "realism")
# participant -> (status, seconds, sound check passed, attention answer); the reasons they are left out
PEOPLE = {
    "p1": ("complete", 300.0, True, "left"), "p2": ("complete", 310.0, True, "left"),
    "p3": ("complete", 290.0, True, "left"), "p4": ("complete", 500.0, True, "left"),
    "p5": ("complete", 200.0, True, "left"), "p6": ("complete", 130.0, True, "left"),
    "p7": ("complete", 400.0, True, "right"),       # failed the attention check
    "p8": ("complete", 60.0, True, "left"),         # too fast
    "p9": ("incomplete", None, True, "left"),       # did not finish
    "p10": ("complete", 250.0, False, "left"),      # failed the sound check
    "p11": ("complete", 90.0, True, "right"),       # too fast and failed the attention check
}
EXCLUDED = {"attention": 2, "too_fast": 2, "incomplete": 1, "sound_check": 1}
KEPT = ["p1", "p2", "p3", "p4", "p5", "p6"]


def make_study(folder: Path, *, rows=ROWS) -> Study:
    stimuli = {}
    for row in rows:
        for subject, sentence in SENTENCES:
            stimuli[f"{row}-{subject}-{sentence}"] = Stimulus(
                path=f"stimuli/{row}-{subject}-{sentence}.mp4", sha256="0" * 64, row=row, subject=subject,
                sentence=sentence, seconds=2.0)
    trials = []
    for other in rows[1:]:
        for k, (subject, sentence) in enumerate(SENTENCES):
            pair = [f"{rows[0]}-{subject}-{sentence}", f"{other}-{subject}-{sentence}"]
            trials.append(Trial(f"{other}-{k}", "ab", tuple(pair if k % 2 == 0 else pair[::-1]), QUESTIONS))
    trials.append(Trial("attention-0", "attention", (f"{rows[0]}-S1-sentence01", f"{rows[1]}-S2-sentence02"),
                        QUESTIONS, expected="left"))
    trials.append(Trial("practice-0", "practice", (f"{rows[0]}-S1-sentence01", f"{rows[1]}-S1-sentence01"),
                        QUESTIONS))
    study = Study(design="ab", seed=0, questions=tuple(question(q, "ab") for q in QUESTIONS), stimuli=stimuli,
                  trials=tuple(trials), participants=tuple(Slot(k, tuple(t.id for t in trials))
                                                           for k in range(len(PEOPLE))),
                  sound_check=SoundCheck("stimuli/sound.mp4", "0" * 64, "apple"), min_seconds=120.0,
                  rows={row: {"result": f"{row}.json", "label": row} for row in rows})
    folder.mkdir(parents=True, exist_ok=True)
    write_study(study, folder)
    return study


def ours_preferred(participant: str, trial: Trial, question_id: str) -> bool:
    """Who prefers ours: everybody on lip sync; on realism all but one sentence in three."""
    if question_id == "lipsync":
        return True
    return not trial.id.endswith(("-2", "-5"))


def make_export(folder: Path, study: Study, *, people=PEOPLE) -> tuple[list, list]:
    answers, participants = [], []
    for slot, (participant, (status, seconds, sound, attention)) in enumerate(people.items()):
        participants.append({"participant": participant, "slot": slot, "status": status,
                             "started_at": "2026-01-01T00:00:00Z", "finished_at": None, "seconds": seconds,
                             "sound_check_passed": sound, "platform": "prolific", "platform_id": participant})
        for trial in study.trials:
            shown = [study.stimuli[s].row for s in trial.stimuli]
            for q in trial.questions:
                if trial.kind == "attention":
                    choice = attention
                elif trial.kind == "practice":
                    choice = "right"
                else:
                    ours_left = shown[0] == study_first_row(study)
                    choice = "left" if ours_left == ours_preferred(participant, trial, q) else "right"
                answers.append({"participant": participant, "slot": slot, "trial": trial.id, "kind": trial.kind,
                                "question": q, "choice": choice, "rows": "|".join(shown),
                                "stimuli": "|".join(trial.stimuli), "subject": study.stimuli[trial.stimuli[0]].subject,
                                "sentence": study.stimuli[trial.stimuli[0]].sentence,
                                "expected": trial.expected, "rt_ms": 1500, "answered_at": "2026-01-01T00:01:00Z"})
    write_answers(folder / "export", answers, participants)
    return answers, participants


def study_first_row(study: Study) -> str:
    return next(iter(study.rows))
