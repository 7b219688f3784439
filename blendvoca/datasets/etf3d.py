"""The 3D-ETF adapter (``--dataset 3d-etf --root DIR``): EmoTalk's 52 ARKit-compatible weights.

3D-ETF (EmoTalk, ICCV 2023) is given out on request by its authors, in a layout
they do not publish. UniTalker redistributes it processed (its corpora D3, 3D-ETF
HDTF, and D4, 3D-ETF RAVDESS) in its own layout, which this adapter reads
(:func:`blendvoca.datasets.unitalker.unitalker_layout_takes`): ``train.json``,
``val.json``, ``test.json`` naming ``(T, 52)`` ``.npy`` weights of annotation type
``3DETF_blendshape_weight`` and their audio. The columns are in EmoTalk's order
(the ``etf52`` convention: alphabetical, then tongueOut). See ``docs/datasets.md``.
"""

from __future__ import annotations

from blendvoca.builder.pipeline import BuildSummary
from blendvoca.datasets import DatasetAdapter
from blendvoca.datasets.coefficients import build_coefficient_dataset
from blendvoca.datasets.unitalker import unitalker_layout_takes

#: UniTalker's ``annot_type`` of its 3D-ETF corpora (D3, D4).
ANNOT_TYPE = "3DETF_blendshape_weight"


def build(root, out, *, workers: int | None = None, shapes: str = "speech", delta: float = 0.1,
          report: bool = True, progress: bool = True) -> BuildSummary:
    """Build the BlendVOCA folder of a 3D-ETF corpus (UniTalker's D3 or D4 folder) at ``root`` into ``out``.

    ``workers``, ``shapes`` and ``delta`` do not apply (nothing is fitted; every shape
    of the corpus is kept). See :func:`blendvoca.datasets.coefficients.build_coefficient_dataset`.
    """
    takes = unitalker_layout_takes(root, annot_type=ANNOT_TYPE, convention="etf52")
    return build_coefficient_dataset(out, root, takes, dataset="3d-etf", title="3D-ETF", convention="etf52",
                                     report=report, progress=progress)


#: The ``--dataset 3d-etf`` adapter (:data:`blendvoca.datasets.DATASETS`).
ADAPTER = DatasetAdapter(build)
