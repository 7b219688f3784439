"""Speaker splits: VOCASET's standard 8/2/2 split and the same proportions for other corpora."""

from __future__ import annotations

from collections.abc import Sequence

from blendvoca.errors import DataError

# VOCA = FaceFormer = SAiD.
VOCASET_SPLITS: dict[str, tuple[str, ...]] = {
    "train": tuple(f"FaceTalk_{s}_TA" for s in (
        "170725_00137", "170728_03272", "170811_03274", "170904_00128",
        "170904_03276", "170912_03278", "170913_03279", "170915_00223")),
    "val": ("FaceTalk_170811_03275_TA", "FaceTalk_170908_03277_TA"),
    "test": ("FaceTalk_170731_00024_TA", "FaceTalk_170809_00138_TA"),
}
VOCASET_SUBJECTS: tuple[str, ...] = tuple(sorted(s for names in VOCASET_SPLITS.values() for s in names))
VOCASET_SENTENCES: tuple[str, ...] = tuple(f"sentence{i:02d}" for i in range(1, 41))
NUM_VERTICES = 5023
FPS = 60


def proportional_split(subjects: Sequence[str]) -> dict[str, list[str]]:
    """Split speakers in VOCASET's 8/2/2 proportions, in the given order.

    The last ``round(N / 6)`` speakers are test, the ``round(N / 6)`` before them
    validation (each at least one when ``N >= 3``), the rest train: 12 -> 8/2/2,
    6 -> 4/1/1, 3 -> 1/1/1.

    Parameters
    ----------
    subjects : sequence of str
        Speaker names, at least 3, no duplicates.

    Returns
    -------
    dict
        ``{"train": [...], "val": [...], "test": [...]}``.
    """
    subjects = list(subjects)
    if len(set(subjects)) != len(subjects):
        raise DataError(f"proportional_split: duplicate speaker names in {subjects}")
    if len(subjects) < 3:
        raise DataError(f"proportional_split: need at least 3 speakers for train/val/test, got {len(subjects)}")
    k = max(1, round(len(subjects) / 6))
    return {"train": subjects[: -2 * k], "val": subjects[-2 * k: -k], "test": subjects[-k:]}


def corpus_splits(subjects: Sequence[str]) -> dict[str, list[str]]:
    """The standard split restricted to ``subjects`` when they are VOCASET's, else ``proportional_split``."""
    subjects = list(subjects)
    if subjects and set(subjects) <= set(VOCASET_SUBJECTS):
        return {k: [s for s in v if s in subjects] for k, v in VOCASET_SPLITS.items()}
    return proportional_split(sorted(subjects))
