"""The ``mesh-adapter`` method plug-in."""

from __future__ import annotations

import os
import sys

from baselines.common.track_lookup import TrackLookupMethod
from blendvoca.errors import UserError
from blendvoca.names import BLENDVOCA_NAMES
from blendvoca.runtime.progress import bar

from .adapt import adapted_coefficients, resolve_vertex_subset
from .config import adapter_config, read_adapter_config
from .sequences import find_sequences, read_vertex_sequence

__all__ = ["MeshAdapterMethod"]


class MeshAdapterMethod(TrackLookupMethod):
    """Coefficient tracks fitted to another method's vertex outputs.

    ``train`` reads the outputs stored for the dataset's subjects, fits each with
    the speaker's rig (the QP of ``blendvoca.fit``) and keys the tracks by
    (subject, sentence); ``generate`` returns the utterance's track. The result is labelled with the
    config's ``name``.

    Parameters
    ----------
    config : str or os.PathLike
        Path of the YAML adapter file (see :mod:`baselines.mesh_adapter.config`).
    split : str
        Split whose sentences must all have outputs.
    adapter : dict, optional
        The resolved adapter settings a saved checkpoint carries (its config round trip; not set by hand).
    **settings
        Inline settings instead of (or overriding) the file: ``vertices``,
        ``fps``, ``template``, ``delta``, ``vertex_subset``, ``max_frame_mismatch``,
        ``name``.
    """

    name = "mesh-adapter"
    stochastic = False
    #: train fits stored outputs, whatever the seed: ``benchmark.run --seeds`` is refused
    learns = False

    def __init__(self, config: str | os.PathLike | None = None, split: str = "test", adapter: dict | None = None,
                 **settings):
        # paths as text: they are recorded in the JSON config
        config = None if config is None else os.fspath(config)
        settings = {k: os.fspath(v) if isinstance(v, os.PathLike) else v for k, v in settings.items()}
        super().__init__(config=config, split=split, **settings)
        if adapter is not None:  # resolved settings, as saved with a trained method
            self.adapter = adapter_config(adapter, where="mesh-adapter saved settings")
        elif config is not None:
            base = read_adapter_config(config).to_dict()
            base.update(settings)
            self.adapter = adapter_config(base, where=f"mesh-adapter config {config}")
        elif settings:
            self.adapter = adapter_config(settings, where="mesh-adapter settings")
        else:
            raise UserError("mesh-adapter: expected config=PATH.yaml (--config config=PATH.yaml) or inline "
                            "settings such as vertices=DIR, got neither")
        self.label = self.adapter.name
        self.reference = self.adapter.reference
        self.max_frame_mismatch = self.adapter.max_frame_mismatch

    def config(self) -> dict:
        return {**super().config(), "adapter": self.adapter.to_dict()}

    contract = 3

    def train(self, dataset, request):
        """Fit every stored output of a dataset subject with that speaker's rig.

        Nothing is learned (no steps, so no ``on_checkpoint`` call: the run is not
        checked for convergence) and no ground truth is read: the outputs in the adapter's
        ``vertices`` folder are turned into coefficient tracks once, keyed by
        (subject, sentence). ``split`` names the split whose sentences must all have
        an output (checked here, so a missing file fails before scoring starts).
        """
        outputs = find_sequences(self.adapter.vertices)
        wanted = [(s, q) for s in dataset.split(self._config["split"]) for q in dataset.sentences(s)]
        missing = [f"{s}/{q}" for s, q in wanted if (s, q) not in outputs]
        if missing:
            raise FileNotFoundError(
                f"mesh-adapter ({self.adapter.name}): no vertex output for {len(missing)} of {len(wanted)} sentences in "
                f"{self.adapter.vertices}, e.g. {missing[:3]}; expected <subject>/<sentence>.npy or "
                f"<subject>/<sentence>/*.ply"
            )
        subset = resolve_vertex_subset(self.adapter.vertex_subset)
        names = tuple(getattr(dataset, "names", None) or BLENDVOCA_NAMES)
        known = set(dataset.subjects)
        items = sorted(key for key in outputs if key[0] in known)
        rigs = {}
        iterator = bar(items, desc=f"mesh-adapter ({self.adapter.name}): fit", unit="sentence", file=sys.stderr)
        tracks, poses = {}, {}
        for subject, sentence in iterator:
            if subject not in rigs:
                rig = dataset.rig(subject)
                rigs[subject] = rig.select(names) if tuple(rig.names) != names else rig
            rig = rigs[subject]
            path = outputs[(subject, sentence)]
            removed = []
            try:
                coeffs = adapted_coefficients(read_vertex_sequence(path), rig.neutral, rig.deltas,
                                              fps=self.adapter.fps, template=self.adapter.template,
                                              delta=self.adapter.delta, vertex_subset=subset, poses=removed)
            except ValueError as exc:
                raise ValueError(f"mesh-adapter ({self.adapter.name}): {subject}/{sentence} ({path}): {exc}") from exc
            tracks[(subject, sentence)] = coeffs
            if removed and removed[0] is not None:
                poses[(subject, sentence)] = removed[0].summary()
        self._tracks = tracks
        #: Head pose removed from each output before fitting (degrees, mm), FLAME topology only.
        self.removed_pose = poses
        if poses:
            deg = max(p["rotation_deg_max"] for p in poses.values())
            mm = max(p["translation_mm_max"] for p in poses.values())
            print(f"mesh-adapter ({self.adapter.name}): head pose removed from {len(poses)} outputs "
                  f"(up to {deg:.2f} degrees, {mm:.1f} mm)", file=sys.stderr)
