"""Corpora a BlendVOCA folder can be built from: the dataset adapter registry.

Each entry maps a dataset name (``python -m blendvoca.build --dataset NAME``) to
the :class:`DatasetAdapter` that builds it, as a lazy ``"module:attr"`` string
(a :class:`~blendvoca.registry.Registry`): nothing is imported until that dataset is
asked for, so a corpus with heavy readers costs the others nothing. Every adapter is
called the same way::

    adapter(root, out, *, workers=None, shapes="speech", delta=0.1,
            report=True, **declared) -> blendvoca.builder.BuildSummary

and declares the options it takes besides these (``DatasetAdapter.options``: the
posed corpora's ``pose_fit``).

``root`` is the corpus as distributed (see ``docs/datasets.md``), ``out`` the
BlendVOCA folder to write (the layout, splits and manifest of
:mod:`blendvoca.format`). An adapter refuses a ``root`` in another layout with a
:class:`~blendvoca.errors.UserError` whose message names the files it expected
(one ``error:`` line, exit 2). Options a corpus has no use for are accepted and
ignored (a coefficient corpus fits nothing, so ``delta`` does not apply to it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from blendvoca.errors import UserError
from blendvoca.registry import Registry

#: The options every adapter takes (a corpus ignores those it has no use for).
COMMON_OPTIONS: tuple[str, ...] = ("workers", "shapes", "delta", "report")

#: Dataset name -> ``"module:attr"`` of its :class:`DatasetAdapter` (imported on first use).
DATASETS: dict[str, str] = {
    # meshes in FLAME topology: rig retargeted per speaker, sentences fitted
    "vocaset": "blendvoca.datasets.vocaset:ADAPTER",
    # ARKit coefficient corpora: read, remapped to arkit52, resampled to 60 fps
    "beat": "blendvoca.datasets.beat:ADAPTER",
    "unitalker": "blendvoca.datasets.unitalker:ADAPTER",
    "3d-etf": "blendvoca.datasets.etf3d:ADAPTER",
    # a rig's own controls, mapped onto ARKit (blendvoca.names.controls_to_arkit); long takes cut into utterances
    "facegood": "blendvoca.datasets.facegood:ADAPTER",
    # Live Link Face takes (CSV + WAV or video): the rate from the timecodes, the head pose kept
    "livelink": "blendvoca.datasets.livelink:ADAPTER",
    # vertex corpora of other topologies: posed meshes, rig retargeted with the user's landmark file
    "biwi": "blendvoca.datasets.biwi:ADAPTER",
    "multiface": "blendvoca.datasets.multiface:ADAPTER",
}


@dataclass(frozen=True)
class DatasetAdapter:
    """A corpus's build function and the options it declares besides :data:`COMMON_OPTIONS`.

    Calling it calls ``build``; ``options`` tells the command line what it may pass
    (``("pose_fit",)`` for the posed corpora), so nothing reads the function's signature.
    ``default_root``, when given, finds the corpus without ``--root`` (its files named in
    ``data_manifest.yaml``, through the asset resolver): the build is then called with
    ``root=None``.
    """

    build: Callable
    options: tuple[str, ...] = ()
    default_root: Callable | None = None

    def __call__(self, root, out, **options):
        return self.build(root, out, **options)

    def takes(self, option: str) -> bool:
        """Whether this adapter accepts ``option`` (a common one or one it declares)."""
        return option in COMMON_OPTIONS or option in self.options


class UnknownDatasetError(UserError):
    """A dataset name with no adapter in :data:`DATASETS`."""


def _check_adapter(obj, name: str) -> None:
    if not isinstance(obj, DatasetAdapter):
        raise TypeError(f"dataset {name!r}: {DATASETS.get(name)} is {type(obj).__name__}, expected a DatasetAdapter")


#: The adapter registry over :data:`DATASETS`.
ADAPTERS = Registry("dataset", DATASETS, error=UnknownDatasetError, check=_check_adapter, where="--dataset")


def dataset_names() -> tuple[str, ...]:
    """The names ``--dataset`` accepts, sorted."""
    return tuple(sorted(ADAPTERS.names()))


def adapter(name: str) -> DatasetAdapter:
    """The adapter of dataset ``name``, imported now.

    Raises
    ------
    UnknownDatasetError
        For a name not in :data:`DATASETS`; the message lists the known names and
        the close matches.
    """
    return ADAPTERS.get(name)
