"""``blendshape_residuals.pickle``: the per-speaker blendshape offsets in the layout SAiD's training reads.

SAiD's training script (``--blendshape_residuals_path``) loads a pickled
``{speaker: {blendshape name: (V_head, 3) ndarray}}``, the offsets of each
blendshape from the speaker's neutral head, on the head crop of FLAME
(``templates_head/<speaker>.obj`` vertices, in ``flame-head-idx`` order), and
stacks each speaker's values in insertion order as its ``(K, V_head, 3)`` basis,
so the names go in the coefficient files' column order.
"""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np

from blendvoca.assets import load_index_list
from blendvoca.format.items import read_rig
from blendvoca.format.layout import RESIDUALS_FILE, residuals_path, rig_path
from blendvoca.io.atomic import atomic_write

__all__ = ["RESIDUALS_FILE", "blendshape_residuals", "write_blendshape_residuals"]


def blendshape_residuals(rigs: dict, head_index: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """Return ``{speaker: {name: delta[head_index] (V_head, 3) float64}}`` in each rig's name order.

    Parameters
    ----------
    rigs : dict of str -> blendvoca.rig.Rig
        Full-topology speaker rigs (``deltas`` ``(K, V, 3)``).
    head_index : (V_head,) ndarray of int
        The head crop's vertex indices.
    """
    head_index = np.asarray(head_index, dtype=np.int64)
    out = {}
    for speaker, rig in rigs.items():
        if head_index.size and head_index.max() >= rig.num_vertices:
            raise ValueError(f"blendshape_residuals: head index {head_index.max()} out of range for speaker {speaker} "
                             f"with {rig.num_vertices} vertices")
        out[speaker] = {name: np.ascontiguousarray(delta[head_index], dtype=np.float64)
                        for name, delta in zip(rig.names, rig.deltas)}
    return out


def write_blendshape_residuals(out, subjects, head_index=None) -> Path | None:
    """Write ``<out>/blendshape_residuals.pickle`` from ``<out>/rigs/<subject>.npz`` (atomically).

    Subjects without a rig file (failed speakers) are left out; returns None when no
    rig exists.  ``head_index`` defaults to the ``flame-head-idx`` asset.
    """
    out = Path(out)
    rigs = {s: read_rig(out, s) for s in subjects if rig_path(out, s).is_file()}
    if not rigs:
        return None
    if head_index is None:
        head_index = load_index_list("flame-head-idx")
    path = residuals_path(out)
    with atomic_write(path, "wb") as f:
        pickle.dump(blendshape_residuals(rigs, head_index), f, protocol=4)
    return path
