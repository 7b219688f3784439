"""Who sees what: the items of a study, their left/right order, and each participant slot's trials.

Pure functions of the rows, the chosen sentences and a seed (no files): :mod:`benchmark.study.create`
turns their output into the design's trials and slots.

- A/B (CodeTalker, CDFace): an item is a pair of rows on one sentence. The first left/right
  order of a pair alternates over its sentences (from a seeded start) and each further
  judgement of an item flips it, so every row is shown left about half the time.
- MOS (CDFace): an item is one row on one sentence (its samples shown together).
- Dealing (:func:`deal`): the items, in a seeded order, are laid out cyclically and cut into
  consecutive runs of ``per_participant``; a run never holds an item twice (``per_participant``
  <= the items) and the runs of ``participants`` slots cover every item at least ``judgements``
  times (``participants * per_participant >= items * judgements``), items differing by at most one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from blendvoca.errors import UserError


@dataclass(frozen=True)
class Item:
    """What one judgement is about: ``rows`` (A/B: the pair in its first order, left first;
    MOS: one row) on ``sentence`` (index into the chosen sentences)."""

    id: str
    rows: tuple[str, ...]
    sentence: int


def ab_items(rows, num_sentences: int, rng: np.random.Generator) -> list[Item]:
    """Every pair of ``rows`` on every sentence; a pair's first order alternates over its sentences."""
    items = []
    for a, b in combinations(rows, 2):
        start = int(rng.integers(2))
        for k in range(num_sentences):
            pair = (a, b) if (k + start) % 2 == 0 else (b, a)
            items.append(Item(f"i{len(items) + 1:04d}", pair, k))
    return items


def mos_items(rows, num_sentences: int) -> list[Item]:
    """Every row on every sentence."""
    return [Item(f"i{k * len(rows) + j + 1:04d}", (row,), k) for k in range(num_sentences)
            for j, row in enumerate(rows)]


def slots_needed(num_items: int, judgements: int, per_participant: int) -> int:
    """The fewest participants that give every item ``judgements`` judgements, ``per_participant`` each."""
    return math.ceil(num_items * judgements / per_participant)


def per_participant_for(num_items: int, judgements: int, participants: int, asked: int | None) -> int:
    """The items each participant judges: ``asked``, else the fewest that cover every item
    ``judgements`` times. Raises :class:`UserError` when the design cannot."""
    if num_items < 1:
        raise UserError("the study has no items to judge")
    if judgements < 1:
        raise UserError(f"--judgements must be at least 1, got {judgements}")
    if participants < 1:
        raise UserError(f"--participants must be at least 1, got {participants}")
    if participants < judgements:
        raise UserError(f"--participants {participants} cannot give every item {judgements} judgements: a participant "
                        f"judges an item once, so at least {judgements} participants are needed")
    if asked is None:
        return math.ceil(num_items * judgements / participants)
    if asked < 1:
        raise UserError(f"--per-participant must be at least 1, got {asked}")
    if asked > num_items:
        raise UserError(f"--per-participant {asked} is more than the {num_items} items (a participant judges an item "
                        "once)")
    if participants * asked < num_items * judgements:
        raise UserError(f"--participants {participants} x --per-participant {asked} = {participants * asked} judgements "
                        f"cannot give each of the {num_items} items {judgements} judgements ({num_items * judgements}); "
                        f"ask for at least {slots_needed(num_items, judgements, asked)} participants")
    return asked


def deal(num_items: int, participants: int, per_participant: int,
         rng: np.random.Generator) -> list[list[tuple[int, int]]]:
    """Per slot, its ``(item index, judgement index)`` pairs (judgement 0 is an item's first).

    Slot ``s`` takes positions ``s * per_participant`` .. ``(s + 1) * per_participant - 1`` of the
    cyclic sequence of the items in a seeded order; position ``p`` is judgement ``p // num_items``
    of its item."""
    order = rng.permutation(num_items)
    slots = []
    for s in range(participants):
        positions = range(s * per_participant, (s + 1) * per_participant)
        slots.append([(int(order[p % num_items]), p // num_items) for p in positions])
    return slots


def place(trials: list, attention: list, practice, rng: np.random.Generator) -> list:
    """A slot's order: ``practice`` first, then ``trials`` shuffled with the ``attention`` checks
    at random positions (never first, never two in a row where avoidable)."""
    body = [trials[i] for i in rng.permutation(len(trials))]
    gaps = list(range(1, len(body) + 1)) if body else [0]
    chosen = sorted(rng.choice(gaps, size=min(len(attention), len(gaps)), replace=False).tolist()) if attention else []
    while len(chosen) < len(attention):  # more checks than trials: append the rest
        chosen.append(len(body))
    out = list(body)
    for offset, (gap, check) in enumerate(zip(chosen, attention)):
        out.insert(gap + offset, check)
    return ([practice] if practice is not None else []) + out


def left_counts(pairs) -> dict[str, list[int]]:
    """For each row, ``[times shown left, times shown]`` over ``pairs`` of (left row, right row)."""
    counts: dict[str, list[int]] = {}
    for left, right in pairs:
        counts.setdefault(left, [0, 0])
        counts.setdefault(right, [0, 0])
        counts[left][0] += 1
        counts[left][1] += 1
        counts[right][1] += 1
    return counts
