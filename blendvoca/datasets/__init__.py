"""Corpora a BlendVOCA folder can be built from: the dataset adapter registry.

Each entry maps a dataset name (``python -m blendvoca.build --dataset NAME``) to
the adapter that builds it, as a lazy ``"module:callable"`` string: nothing is
imported until that dataset is asked for, so a corpus with heavy readers costs
the others nothing. Every adapter has one signature::

    build(root, out, *, workers=None, shapes="speech", delta=0.1,
          report=True, progress=True) -> blendvoca.builder.BuildSummary

``root`` is the corpus as distributed (see ``docs/datasets.md``), ``out`` the
BlendVOCA folder to write (the layout, splits and manifest of
:mod:`blendvoca.format`). An adapter refuses a ``root`` in another layout with a
:class:`~blendvoca.errors.UserError` whose message names the files it expected
(one ``error:`` line, exit 2). Options a corpus has no use for are accepted and
ignored (a coefficient corpus fits nothing, so ``delta`` does not apply to it).
"""

from __future__ import annotations

import difflib
import importlib
from collections.abc import Callable

from blendvoca.errors import UserError

#: Dataset name -> ``"module:callable"`` of its adapter (imported on first use).
DATASETS: dict[str, str] = {
    # meshes in FLAME topology: rig retargeted per speaker, sentences fitted
    "vocaset": "blendvoca.datasets.vocaset:build",
    # ARKit coefficient corpora: read, remapped to arkit52, resampled to 60 fps
    "beat": "blendvoca.datasets.beat:build",
    "unitalker": "blendvoca.datasets.unitalker:build",
    "3d-etf": "blendvoca.datasets.etf3d:build",
    # vertex corpora of other topologies: posed meshes, rig retargeted with the user's landmark file
    "biwi": "blendvoca.datasets.biwi:build",
    "multiface": "blendvoca.datasets.multiface:build",
}


class UnknownDatasetError(UserError):
    """A dataset name with no adapter in :data:`DATASETS`."""


def dataset_names() -> tuple[str, ...]:
    """The names ``--dataset`` accepts, sorted."""
    return tuple(sorted(DATASETS))


def adapter(name: str) -> Callable:
    """The build function of dataset ``name``, imported now.

    Raises
    ------
    UnknownDatasetError
        For a name not in :data:`DATASETS`; the message lists the known names and
        the close matches.
    """
    target = DATASETS.get(name)
    if target is None:
        close = difflib.get_close_matches(str(name), DATASETS, n=3)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise UnknownDatasetError(f"--dataset: unknown dataset {name!r}{hint}; known: {', '.join(dataset_names())}")
    module, _, attribute = target.partition(":")
    return getattr(importlib.import_module(module), attribute)
