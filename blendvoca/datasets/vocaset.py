"""The VOCASET adapter: the build proper (``--dataset vocaset --root DIR``, alias ``--vocaset DIR``).

VOCASET is a mesh corpus: every speaker's rig is retargeted from the ARKit
reference rig and every sentence fitted (:func:`blendvoca.builder.build_dataset`,
``docs/build.md``). This module only gives it the adapter signature of
:mod:`blendvoca.datasets`.
"""

from __future__ import annotations

from blendvoca.builder.pipeline import BuildSummary, build_dataset
from blendvoca.datasets import DatasetAdapter


def build(root, out, *, workers: int | None = None, shapes: str = "speech", delta: float = 0.1,
          report: bool = True) -> BuildSummary:
    """Build BlendVOCA from the VOCASET corpus at ``root`` (official or processed layout) into ``out``.

    ``root=None`` builds the bundled synthetic corpus. See
    :func:`blendvoca.builder.build_dataset` for the parameters and what it raises.
    """
    return build_dataset(out, root, workers=workers, shapes=shapes, delta=delta, report=report)


#: The ``--dataset vocaset`` adapter (:data:`blendvoca.datasets.DATASETS`).
ADAPTER = DatasetAdapter(build)
