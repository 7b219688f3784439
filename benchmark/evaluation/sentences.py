"""Per-sentence work of the vertex and lip-sync families: each speaker's rig regions and
the map of a per-sentence function over the scored sentences."""

from __future__ import annotations

import sys

import numpy as np

from blendvoca import rig_regions as regions
from blendvoca.runtime.processes import process_map
from blendvoca.runtime.threads import limited_threads

__all__ = ["by_metric", "map_sentences", "rig_regions"]


def _rig_deltas(rig, names) -> np.ndarray:
    rig_names = tuple(rig.names)
    if tuple(names) == rig_names:
        return np.asarray(rig.deltas, dtype=np.float64)
    missing = [n for n in names if n not in rig_names]
    if missing:
        raise ValueError(f"evaluate_split: the rig lacks the blendshapes {missing}")
    return np.asarray(rig.deltas, dtype=np.float64)[[rig_names.index(n) for n in names]]


def rig_regions(rigs, names) -> dict:
    """``{subject: (neutral (V, 3), deltas (K, V, 3) in the order of names, lip indices,
    upper-face indices)}`` of every speaker's rig."""
    out = {}
    for subject, rig in rigs.items():
        neutral = np.asarray(rig.neutral, dtype=np.float64)
        deltas = _rig_deltas(rig, names)
        out[subject] = neutral, deltas, regions.lip_vertices(deltas, names), regions.upper_face_vertices(neutral)
    return out


def by_metric(per_key: dict) -> dict:
    """``{key: {name: value}}`` -> ``{name: {key: value}}``."""
    values = {}
    for key, sentence in per_key.items():
        for name, value in sentence.items():
            values.setdefault(name, {})[key] = value
    return values


#: The per-sentence function of the running `map_sentences` (read by its forked workers).
_SENTENCE_TASK = None


def _run_sentence_task(key):
    with limited_threads(1):  # small matrix products: one BLAS thread is faster here
        return _SENTENCE_TASK(key)


def map_sentences(task, keys, *, workers: int, desc: str) -> dict:
    """``{key: task(key)}`` over ``keys``, in ``workers`` forked processes (Linux; else here;
    :func:`blendvoca.runtime.processes.process_map`, with its Ctrl-C and dying-worker handling).

    ``task`` is pure numpy work over one sentence (no torch: an OpenMP runtime used
    before a fork is not safe in the child), so the values do not depend on ``workers``.
    """
    global _SENTENCE_TASK
    keys = list(keys)
    _SENTENCE_TASK = task
    try:
        workers = workers if sys.platform.startswith("linux") else 1
        return dict(zip(keys, process_map(_run_sentence_task, keys, workers=workers, desc=desc, unit="sentence",
                                          chunksize=max(1, len(keys) // (8 * workers)), start_method="fork")))
    finally:
        _SENTENCE_TASK = None
