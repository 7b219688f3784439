"""The options of an evaluation: one frozen :class:`EvaluationSettings`.

``evaluate_split(generated, dataset, split, settings)`` reads every option from it;
:meth:`EvaluationSettings.to_dict` is what a result records of it
(``protocol.evaluation``, only where a setting differs from the protocol's default),
:meth:`EvaluationSettings.from_dict` reads that back.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from benchmark.metrics.bootstrap import BOOTSTRAP_RESAMPLES
from benchmark.metrics.multimodality import PAIRS_PER_WINDOW

__all__ = ["FD_RESAMPLES", "RECORDED", "WIND_RESAMPLES", "EvaluationSettings"]

#: Bootstrap resamples of FD (closed form per resample: cheap).
FD_RESAMPLES = 200
#: Bootstrap resamples of WInD (one GMM fit of the generated set per resample).
WIND_RESAMPLES = 20

#: The settings a result records (those that change the numbers). The models
#: (``extractor``, ``syncnet``, ``sync_expert``) are recorded by the runner with their
#: digests (``protocol.vae``, ``protocol.lipsync_models``); ``workers`` and
#: ``wind_cache`` change no number.
RECORDED = ("samples_for_multimodality", "wind_components", "wind_repeats", "seed", "vertex", "lipsync",
            "resamples", "fd_resamples", "wind_resamples", "mesh")
_AT_LEAST = {"samples_for_multimodality": 1, "wind_components": 1, "wind_repeats": 1, "seed": 0, "resamples": 0,
             "fd_resamples": 0, "wind_resamples": 0, "workers": 1}


@dataclass(frozen=True)
class EvaluationSettings:
    """Every option of :func:`benchmark.evaluation.evaluate_split`; the defaults are the protocol's.

    Attributes
    ----------
    extractor : feature extractor, path to a VAE state_dict, or None for the
        published VAE (asset ``said-vae``).
    samples_for_multimodality : int
        Pairs per window for multimodality (36).
    wind_components, wind_repeats, seed : int
        WInD mixture size, number of repeated fits and first seed (also seeds the
        bootstrap).
    syncnet : SyncNet module, path to weights, True (the manifest asset
        ``syncnet-weights``), or None (skip SyncNet).
    sync_expert : object with ``sync(coeffs (T, 32), audio (N,)) -> .offset, .confidence``,
        a path for ``benchmark.lipsync.load_expert``, or None (skip).
    vertex, lipsync : bool
        Compute vertex-space (and energy) and lip-sync metrics.
    resamples, fd_resamples, wind_resamples : int
        Bootstrap resamples of the per-sentence metrics, FD and WInD.
    workers : int
        Processes for the WInD fits and the per-sentence vertex and geometric lip-sync
        metrics (forked, single-threaded each: the scores do not depend on it).
    wind_cache : True, path or None
        Where the ground-truth WInD fits are kept (True: ``<user cache>/wind-gmm``,
        None or False: nowhere); the scores do not depend on it.
    mesh : bool or None
        Score the mesh space (against ``dataset.vertices``): None when the dataset
        can give its source meshes (a warning when it cannot), True always (an error
        when it cannot), False never.
    """

    extractor: object = None
    samples_for_multimodality: int = PAIRS_PER_WINDOW
    wind_components: int = 5
    wind_repeats: int = 10
    seed: int = 0
    syncnet: object = None
    sync_expert: object = None
    vertex: bool = True
    lipsync: bool = True
    resamples: int = BOOTSTRAP_RESAMPLES
    fd_resamples: int = FD_RESAMPLES
    wind_resamples: int = WIND_RESAMPLES
    workers: int = 2
    wind_cache: object = True
    mesh: bool | None = None

    def __post_init__(self):
        for name, low in _AT_LEAST.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"EvaluationSettings.{name}: expected an integer >= {low}, got {value!r}")
        for name in ("vertex", "lipsync"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"EvaluationSettings.{name}: expected True or False, got {getattr(self, name)!r}")
        if self.mesh not in (None, True, False):
            raise ValueError(f"EvaluationSettings.mesh: expected None, True or False, got {self.mesh!r}")

    def to_dict(self) -> dict:
        """The :data:`RECORDED` settings that differ from the defaults, ``{name: value}``
        (empty for a run with the protocol's settings: its result records nothing)."""
        default = EvaluationSettings()
        return {name: getattr(self, name) for name in RECORDED if getattr(self, name) != getattr(default, name)}

    @classmethod
    def from_dict(cls, record) -> EvaluationSettings:
        """The settings a result recorded (:meth:`to_dict`): the defaults with ``record``'s values."""
        unknown = sorted(set(record) - set(RECORDED))
        if unknown:
            raise ValueError(f"EvaluationSettings.from_dict: unknown setting(s) {unknown}; recorded ones: "
                             f"{', '.join(RECORDED)}")
        return cls(**record)

    def replace(self, **changes) -> EvaluationSettings:
        """These settings with ``changes`` (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)
