"""The kept answers coded as arrays, one entry per answer to one question.

An A/B answer becomes a judgement of a *comparison* (an unordered pair of rows, oriented
``A`` vs ``B``: the reference row is A when it is in the pair, else the row listed first
in the study), whether A was chosen, who answered (participant) and what was judged
(item: the sentence, ``subject/sentence``). A MOS answer becomes a rating 1-5 of a row.
The *unit* is what several participants judged alike (the same stimuli and question):
the agreement step compares participants within units.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from blendvoca.errors import DataError


def study_rows(study) -> list[str]:
    """The study's rows in its order (``study.rows``, else as its stimuli name them)."""
    rows = list(study.rows)
    for stimulus in study.stimuli.values():
        if stimulus.row not in rows:
            rows.append(stimulus.row)
    return rows


def _index(values: list, value) -> int:
    try:
        return values.index(value)
    except ValueError:
        values.append(value)
        return len(values) - 1


@dataclass
class Judgements:
    """Coded answers: parallel integer arrays of length ``size`` and the names they index.

    A/B (``kind="ab"``): ``row_a``, ``row_b`` (row indices, oriented), ``value`` 1 when A was chosen.
    MOS (``kind="mos"``): ``row_a`` the row rated (``row_b`` = -1), ``value`` the rating 1-5.
    """

    kind: str
    rows: list
    questions: list
    participant: np.ndarray
    item: np.ndarray
    question: np.ndarray
    row_a: np.ndarray
    row_b: np.ndarray
    value: np.ndarray
    unit: np.ndarray
    participants: list = field(default_factory=list)
    items: list = field(default_factory=list)
    units: list = field(default_factory=list)

    @property
    def size(self) -> int:
        return int(self.value.size)


def _empty(kind, rows, questions) -> Judgements:
    z = np.zeros(0, dtype=np.int64)
    return Judgements(kind, list(rows), list(questions), z, z, z, z, z, z, z)


def _answer_rows(study, answer: dict) -> list[str]:
    if answer.get("rows"):
        return answer["rows"].split("|")
    stimuli = (answer.get("stimuli") or "").split("|")
    return [study.stimuli[s].row for s in stimuli if s in study.stimuli]


def _answer_item(study, answer: dict) -> tuple:
    if answer.get("subject") and answer.get("sentence"):
        return answer["subject"], answer["sentence"]
    stimuli = [s for s in (answer.get("stimuli") or "").split("|") if s in study.stimuli]
    if stimuli:
        return study.stimuli[stimuli[0]].subject, study.stimuli[stimuli[0]].sentence
    return ("", answer.get("trial") or "")


def ab_judgements(study, answers: list[dict], rows: list[str], reference: str | None) -> Judgements:
    """The A/B answers of ``answers`` (kind ``ab``) coded; answers comparing a row with itself are left out."""
    questions = [q.id for q in study.questions]
    chosen = [a for a in answers if a.get("kind") == "ab"]
    if not chosen:
        return _empty("ab", rows, questions)
    rows = list(rows)
    participants, items, units = [], [], []
    columns = {name: [] for name in ("participant", "item", "question", "row_a", "row_b", "value", "unit")}
    for answer in chosen:
        shown = _answer_rows(study, answer)
        if len(shown) != 2:
            raise DataError(f"answer to trial {answer['trial']!r}: an A/B trial shows two rows, found {shown}")
        if shown[0] == shown[1]:
            continue
        if answer["choice"] not in ("left", "right"):
            raise DataError(f"answer to trial {answer['trial']!r}: an A/B choice is left or right, "
                            f"found {answer['choice']!r}")
        picked = shown[0] if answer["choice"] == "left" else shown[1]
        pair = sorted(shown, key=lambda r: (r != reference, rows.index(r) if r in rows else len(rows), r))
        a, b = (_index(rows, r) for r in pair)
        columns["participant"].append(_index(participants, answer["participant"]))
        columns["item"].append(_index(items, _answer_item(study, answer)))
        if answer["question"] not in questions:
            raise DataError(f"answer to trial {answer['trial']!r}: unknown question {answer['question']!r}")
        columns["question"].append(questions.index(answer["question"]))
        columns["row_a"].append(a)
        columns["row_b"].append(b)
        columns["value"].append(int(picked == pair[0]))
        stimuli = tuple(sorted((answer.get("stimuli") or answer["trial"]).split("|")))
        columns["unit"].append(_index(units, (answer["question"], stimuli)))
    arrays = {k: np.asarray(v, dtype=np.int64) for k, v in columns.items()}
    return Judgements("ab", rows, questions, participants=participants, items=items, units=units, **arrays)


def mos_ratings(study, answers: list[dict], rows: list[str]) -> Judgements:
    """The MOS answers of ``answers`` (kind ``mos``) coded as ratings 1-5 of a row."""
    questions = [q.id for q in study.questions]
    rated = [a for a in answers if a.get("kind") == "mos"]
    if not rated:
        return _empty("mos", rows, questions)
    rows = list(rows)
    participants, items, units = [], [], []
    columns = {name: [] for name in ("participant", "item", "question", "row_a", "row_b", "value", "unit")}
    for answer in rated:
        shown = _answer_rows(study, answer)
        if len(shown) != 1:
            raise DataError(f"answer to trial {answer['trial']!r}: a MOS trial shows one row, found {shown}")
        try:
            rating = int(answer["choice"])
        except (TypeError, ValueError):
            rating = 0
        if not 1 <= rating <= 5:
            raise DataError(f"answer to trial {answer['trial']!r}: a MOS rating is 1 to 5, found {answer['choice']!r}")
        if answer["question"] not in questions:
            raise DataError(f"answer to trial {answer['trial']!r}: unknown question {answer['question']!r}")
        columns["participant"].append(_index(participants, answer["participant"]))
        columns["item"].append(_index(items, _answer_item(study, answer)))
        columns["question"].append(questions.index(answer["question"]))
        columns["row_a"].append(_index(rows, shown[0]))
        columns["row_b"].append(-1)
        columns["value"].append(rating)
        columns["unit"].append(_index(units, (answer["question"], answer.get("stimuli") or answer["trial"])))
    arrays = {k: np.asarray(v, dtype=np.int64) for k, v in columns.items()}
    return Judgements("mos", rows, questions, participants=participants, items=items, units=units, **arrays)
