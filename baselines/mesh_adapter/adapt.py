"""Vertex sequence -> BlendVOCA coefficient track through the speaker's rig.

The fit itself is :func:`blendvoca.fit.vertex_tracks.adapted_coefficients` (shared with the
runner's vertex-output methods); this module resolves the adapter's vertex subset.
"""

from __future__ import annotations

import numpy as np

from blendvoca.fit.vertex_tracks import FLAME_NUM_VERTICES, adapted_coefficients, rig_fit_vertices

__all__ = ["adapted_coefficients", "resolve_vertex_subset"]


def resolve_vertex_subset(subset):
    """Vertex indices for a config's ``vertex_subset`` (None, ``"flame-head"`` or a list)."""
    if subset is None:
        return None
    if subset == "flame-head":
        return rig_fit_vertices(FLAME_NUM_VERTICES)
    return np.asarray(subset, dtype=np.int64)
