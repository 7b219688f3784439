"""The 3D-ETF adapter (``--dataset 3d-etf --root DIR``): EmoTalk's 52 ARKit-compatible weights.

3D-ETF (EmoTalk, ICCV 2023) is a public download since July 2025 (the link in
psyai-net/EmoTalk_release issue 35), in a layout its authors do not document. UniTalker redistributes it processed (its corpora D3, 3D-ETF
HDTF, and D4, 3D-ETF RAVDESS) in its own layout, which this adapter reads
(:func:`blendvoca.datasets.unitalker.unitalker_layout_takes`): ``train.json``,
``val.json``, ``test.json`` naming ``(T, 52)`` ``.npy`` weights of annotation type
``3DETF_blendshape_weight`` and their audio. The columns are in EmoTalk's order
(the ``etf52`` convention: alphabetical, then tongueOut). See ``docs/datasets.md``.
"""

from __future__ import annotations

import functools

from blendvoca.datasets.coefficients import coefficient_adapter
from blendvoca.datasets.unitalker import unitalker_layout_takes

#: UniTalker's ``annot_type`` of its 3D-ETF corpora (D3, D4).
ANNOT_TYPE = "3DETF_blendshape_weight"


#: The ``--dataset 3d-etf`` adapter (:data:`blendvoca.datasets.DATASETS`): UniTalker's D3 or D4 folder.
ADAPTER = coefficient_adapter(functools.partial(unitalker_layout_takes, annot_type=ANNOT_TYPE, convention="etf52"),
                              dataset="3d-etf", title="3D-ETF", convention="etf52")
