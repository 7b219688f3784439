"""``study.json``, a study's design: the one owner of the format.

:func:`read_study` and :func:`write_study` are the only ways in and out; :func:`verify_stimuli`
refuses a study whose stimuli are missing or changed (their sha256 is in the design).

Format (``"format": "blendvoca-study-1"``)::

    {
      "format": "blendvoca-study-1",
      "design": "ab" | "mos",
      "seed": 0,
      "questions": [{"id": "lipsync", "prompt": "...", "choices": ["left", "right"] | ["1", ..., "5"]}],
      "stimuli": {stimulus_id: {"path": "stimuli/....mp4", "sha256", "row", "subject", "sentence",
                                "sample", "seconds",
                                "samples": [k, ...]  (the row's samples shown side by side, left to right),
                                "role": "item" | "attention" | "practice",
                                "fps", "width", "height", "frames"}},
      "trials": [{"id", "kind": "ab" | "mos" | "attention" | "practice",
                  "stimuli": [stimulus_id, ...]   (ab, attention, practice: [left, right]; mos: [one]),
                  "questions": [question_id, ...],
                  "expected": "left" | "right" | null   (attention checks: the unmistakable answer),
                  "item": item_id | null   (ab/mos: the item judged; an A/B item's two
                                            left/right orders are two trials of one item)}],
      "participants": [{"slot": 0, "trials": [trial_id, ...]}]   (the order each participant sees),
      "sound_check": {"path", "sha256", "answer",   (the word a participant must type)
                      "accepted": [...],  (every accepted spelling, lower case; answer included)
                      "prompt": "...",    (what the page asks)
                      "source": "..."},   (where the sound came from)
      "min_seconds": 120,   (a session finished faster is excluded, as CodeTalker does)
      "judgements_per_item": 3,
      "rows": {row: {"result": path, "result_sha256", "recipe_id", "label"}},
      "created": {"date", "command", "git_revision"},
      "settings": {"size", "fps", "max_seconds", "samples", "participants", "per_participant",
                   "attention_checks", "attention", "backend", "sentences": [[subject, sentence], ...]}
    }

Fields added after the first version (``samples``, ``role``, ``fps``, ``width``, ``height``,
``frames`` of a stimulus; ``item`` of a trial; ``accepted``, ``prompt``, ``source`` of the
sound check; ``settings``) have defaults, so a design written without them still reads.
A MOS study's attention checks are A/B trials (the ground truth against a motionless or
mismatched face) asking the question ``"attention"`` (:data:`ATTENTION_QUESTION`), whose
choices are ``"left"``/``"right"``; it is not a rating and the analysis leaves it out of the MOS.

Paths are relative to the study folder. Choices: an A/B question is answered ``"left"`` or
``"right"`` (forced choice, as CodeTalker and CDFace ask); a MOS question ``"1"`` to ``"5"``.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

from blendvoca.errors import DataError, UserError

FORMAT = "blendvoca-study-1"
STUDY_FILE = "study.json"
DESIGNS = ("ab", "mos")
TRIAL_KINDS = ("ab", "mos", "attention", "practice")
AB_CHOICES = ("left", "right")
MOS_CHOICES = ("1", "2", "3", "4", "5")

#: The question of a MOS study's attention checks (an A/B lip-sync question, left or right).
ATTENTION_QUESTION = "attention"

# The papers' wording (CodeTalker Sec. 4.4; CDFace Sec. IV-C adds diversity and expressiveness).
QUESTION_PROMPTS = {
    "ab": {
        "lipsync": "Comparing the lips of the two faces, which one is more in sync with the audio?",
        "realism": "Comparing the two full faces, which one looks more realistic?",
        "diversity": "Comparing the two faces, which one shows more varied motion?",
        "expressiveness": "Comparing the two faces, which one is more expressive?",
    },
    "mos": {
        "lipsync": "How well are the lips in sync with the audio? (1 = not at all, 5 = perfectly)",
        "realism": "How realistic does the face look? (1 = not at all, 5 = like a real person)",
        "diversity": "How varied is the motion across the samples? (1 = identical, 5 = very varied)",
        "expressiveness": "How expressive is the face? (1 = not at all, 5 = very)",
    },
}


@dataclass(frozen=True)
class Question:
    id: str
    prompt: str
    choices: tuple[str, ...]


@dataclass(frozen=True)
class Stimulus:
    path: str
    sha256: str
    row: str
    subject: str
    sentence: str
    sample: int = 0
    seconds: float = 0.0
    samples: tuple[int, ...] = ()
    role: str = "item"
    fps: float = 0.0
    width: int = 0
    height: int = 0
    frames: int = 0


@dataclass(frozen=True)
class Trial:
    id: str
    kind: str
    stimuli: tuple[str, ...]
    questions: tuple[str, ...]
    expected: str | None = None
    item: str | None = None


@dataclass(frozen=True)
class Slot:
    slot: int
    trials: tuple[str, ...]


@dataclass(frozen=True)
class SoundCheck:
    path: str
    sha256: str
    answer: str
    accepted: tuple[str, ...] = ()
    prompt: str = "Type the word you hear."
    source: str = ""

    def accepts(self, typed: str) -> bool:
        """Whether ``typed`` (any case, surrounding spaces and final punctuation ignored) is the answer."""
        text = " ".join(str(typed).strip().strip(".!?").lower().split())
        return text in {a.lower() for a in (self.answer, *self.accepted)}


@dataclass(frozen=True)
class Study:
    design: str
    seed: int
    questions: tuple[Question, ...]
    stimuli: dict[str, Stimulus]
    trials: tuple[Trial, ...]
    participants: tuple[Slot, ...]
    sound_check: SoundCheck | None
    min_seconds: float = 120.0
    judgements_per_item: int = 3
    rows: dict[str, dict] = field(default_factory=dict)
    created: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)

    def question(self, question_id: str) -> Question:
        for question in self.questions:
            if question.id == question_id:
                return question
        raise KeyError(question_id)

    def trial(self, trial_id: str) -> Trial:
        return self.trials_by_id()[trial_id]

    def trials_by_id(self) -> dict[str, Trial]:
        return {trial.id: trial for trial in self.trials}

    def to_json(self) -> dict:
        data = asdict(self)
        return {"format": FORMAT, **data}


def question(question_id: str, design: str) -> Question:
    """The papers' wording of ``question_id`` for ``design`` ("ab" or "mos"); ``"attention"``:
    the A/B lip-sync question a MOS study's attention checks ask (left or right)."""
    if question_id == ATTENTION_QUESTION and design == "mos":
        return Question(ATTENTION_QUESTION, QUESTION_PROMPTS["ab"]["lipsync"], AB_CHOICES)
    prompts = QUESTION_PROMPTS[design]
    if question_id not in prompts:
        raise UserError(f"unknown question {question_id!r}: expected one of {', '.join(prompts)}")
    return Question(question_id, prompts[question_id], AB_CHOICES if design == "ab" else MOS_CHOICES)


def sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _tuple_fields(cls, data: dict, where: str, tuples=()):
    try:
        return cls(**{key: tuple(value) if key in tuples else value for key, value in data.items()})
    except TypeError as error:
        raise DataError(f"{where}: {error}") from None


def study_from_json(data: dict, where: str) -> Study:
    """A :class:`Study` from the parsed JSON, checked: ``where`` names the file in errors."""
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        found = data.get("format") if isinstance(data, dict) else type(data).__name__
        raise DataError(f"{where}: expected a study design of format {FORMAT!r}, found {found!r}")
    body = {key: value for key, value in data.items() if key != "format"}
    try:
        body["questions"] = tuple(_tuple_fields(Question, q, where, ("choices",)) for q in body["questions"])
        body["stimuli"] = {key: _tuple_fields(Stimulus, s, where, ("samples",)) for key, s in body["stimuli"].items()}
        body["trials"] = tuple(_tuple_fields(Trial, t, where, ("stimuli", "questions")) for t in body["trials"])
        body["participants"] = tuple(_tuple_fields(Slot, p, where, ("trials",)) for p in body["participants"])
        if body.get("sound_check") is not None:
            body["sound_check"] = _tuple_fields(SoundCheck, body["sound_check"], where, ("accepted",))
    except (KeyError, AttributeError, TypeError) as error:
        raise DataError(f"{where}: malformed study design ({error!r})") from None
    study = _tuple_fields(Study, body, where)
    check_study(study, where)
    return study


def check_study(study: Study, where: str) -> None:
    """Every reference in the design resolves; choices and kinds are the known ones."""
    if study.design not in DESIGNS:
        raise DataError(f"{where}: design {study.design!r} is not one of {', '.join(DESIGNS)}")
    question_ids = {q.id for q in study.questions}
    trial_ids = set()
    for trial in study.trials:
        if trial.id in trial_ids:
            raise DataError(f"{where}: trial {trial.id!r} appears twice")
        trial_ids.add(trial.id)
        if trial.kind not in TRIAL_KINDS:
            raise DataError(f"{where}: trial {trial.id!r} has kind {trial.kind!r}, expected one of {TRIAL_KINDS}")
        missing = [s for s in trial.stimuli if s not in study.stimuli]
        if missing:
            raise DataError(f"{where}: trial {trial.id!r} names stimuli that are not in the design: {missing}")
        unknown = [q for q in trial.questions if q not in question_ids]
        if unknown:
            raise DataError(f"{where}: trial {trial.id!r} asks unknown questions {unknown}")
        if trial.kind == "attention":
            choices = {c for q in study.questions if q.id in trial.questions for c in q.choices}
            if trial.expected not in choices:
                raise DataError(f"{where}: attention check {trial.id!r} expects {trial.expected!r}, not one of its "
                                f"questions' choices {sorted(choices)}")
    for slot in study.participants:
        unknown = [t for t in slot.trials if t not in trial_ids]
        if unknown:
            raise DataError(f"{where}: participant slot {slot.slot} names unknown trials {unknown[:3]}")


def read_study(folder) -> Study:
    """The design of the study in ``folder`` (its ``study.json``)."""
    path = Path(folder) / STUDY_FILE
    if not path.is_file():
        raise UserError(f"{folder}: not a study folder (no {STUDY_FILE}); make one with python -m benchmark.study create")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise DataError(f"{path}: not a JSON file ({error})") from None
    return study_from_json(data, str(path))


def write_study(study: Study, folder) -> Path:
    """Write ``study.json`` into ``folder`` atomically (a temporary file renamed into place)."""
    check_study(study, "the study being written")
    path = Path(folder) / STUDY_FILE
    temporary = path.with_name(path.name + ".partial")
    temporary.write_text(json.dumps(study.to_json(), indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    temporary.replace(path)
    return path


def verify_stimuli(study: Study, folder) -> None:
    """Refuse a study whose stimuli (or sound check) are missing or changed since ``create``."""
    folder = Path(folder).resolve()
    entries = [(key, s.path, s.sha256) for key, s in study.stimuli.items()]
    if study.sound_check is not None:
        entries.append(("sound check", study.sound_check.path, study.sound_check.sha256))
    for key, relative, expected in entries:
        path = (folder / relative).resolve()
        if folder not in path.parents:
            raise DataError(f"{folder / STUDY_FILE}: stimulus {key!r} points outside the study folder: {relative}")
        if not path.is_file():
            raise DataError(f"{folder / STUDY_FILE}: stimulus {key!r} is missing: {path}")
        if sha256_of(path) != expected:
            raise DataError(f"{folder / STUDY_FILE}: stimulus {key!r} changed since the study was created "
                            f"(sha256 differs): {path}")
