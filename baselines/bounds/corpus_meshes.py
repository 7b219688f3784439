"""``corpus-meshes``: the source meshes themselves, as a vertex-output row (the mesh-space
floor: 0 against the meshes, and its coefficient fit is the build's own)."""

from __future__ import annotations

import numpy as np

from benchmark.methods.base import Method
from blendvoca.errors import MethodError

__all__ = ["CorpusMeshesMethod"]


class CorpusMeshesMethod(Method):
    """Reference row: each utterance's own source mesh sequence (``dataset.vertices``).

    A vertex-output method, scored as vertex rows are: in mesh space its meshes
    against themselves (0), in rig space the runner's fit of them (the build's QP on
    the same meshes, about 0). Beside ``ground-truth`` (0 in rig space, the rig's
    floor in mesh space) it marks the floor of each reference space. It reads the
    source corpus of the build, so the build's recorded VOCASET must be reachable
    (``benchmark.run --vocaset DIR``). On a build without source meshes
    (``dataset.vertex_space == "rig"``, a coefficient corpus) its vertices are the rig at
    the ground-truth coefficients, so its rig-space row is the floor the protocol's fit
    (the rate bound's smoothing) leaves any vertex method.
    """

    name = "corpus-meshes"
    label = "corpus meshes"
    stochastic = False
    reference = True
    learns = False
    output = "vertices"
    #: the sentence's own source meshes: no new recording can be animated
    new_audio = False

    contract = 3

    def train(self, dataset, request):
        self._dataset = dataset

    def generate(self, utterance, *, samples=1, seed=0):
        dataset = getattr(self, "_dataset", None)
        if dataset is None:
            raise MethodError("corpus-meshes reads the build's source meshes in train(); it has no checkpoint")
        frames = np.asarray(dataset.vertices(utterance.subject, utterance.sentence), dtype=np.float64)
        return np.repeat(frames[None], int(samples), axis=0)
