"""The ``faceformer`` method of the benchmark (``python -m benchmark.run --method faceformer``).

Without ``official``, :meth:`FaceFormerMethod.train` trains on the BlendVOCA train
split's vertex sequences. With ``--config official=PATH/vocaset.pth`` the authors'
released weights are used as they are (their 8 VOCASET styles).
"""

from __future__ import annotations

import os

from baselines.common.chunking import ChunkedDecoder
from baselines.common.device import precision_config
from baselines.common.vertex_method import StyleVertexMethod, training_limits
from baselines.faceformer.model import Faceformer
from baselines.faceformer.official import load_official
from baselines.faceformer.presets import HELP, PRESETS, resolve_config
from baselines.faceformer.train import train_faceformer

__all__ = ["FaceFormerMethod"]


class FaceFormerMethod(ChunkedDecoder, StyleVertexMethod):
    """FaceFormer (vertex output, one sample per training-speaker style).

    Parameters
    ----------
    preset : {"cpu-demo", "paper"}, default "cpu-demo"
    official : str or os.PathLike, optional
        Path of the authors' ``vocaset.pth``; then nothing is trained.
    official_wav2vec2 : "base", "tiny" or dict, default "base"
        wav2vec 2.0 architecture of that file (the released one: base-960h).
    resolved : dict, optional
        Ignored (the resolved config reported by :meth:`config`).
    **overrides
        Flat keys of :func:`baselines.faceformer.presets.resolve_config`.
    """

    name = "faceformer"
    label = "FaceFormer"
    checkpoint_file = "faceformer.pt"

    presets, preset_help = PRESETS, HELP

    def __init__(self, preset: str = "cpu-demo", official: str | os.PathLike | None = None, official_wav2vec2="base",
                 resolved: dict | None = None, mixed_precision: str = "off", **overrides):
        official = None if official is None else os.fspath(official)  # recorded in the JSON config
        super().__init__(preset=preset, official=official, official_wav2vec2=official_wav2vec2,
                         **precision_config(mixed_precision), **overrides)
        self.use_preset(resolve_config(preset, **overrides), mixed_precision)
        if official is not None:
            self.use_official(load_official(official, wav2vec2_config=official_wav2vec2))

    @classmethod
    def from_official_checkpoint(cls, path: str | os.PathLike, **config) -> FaceFormerMethod:
        """The method with the authors' ``vocaset.pth`` (``benchmark.run --checkpoint FILE``)."""
        config.pop("official", None)
        return cls(official=os.fspath(path), **config)

    def build_network(self, num_subjects: int, vertice_dim: int) -> None:
        self.network = Faceformer({**self.settings["model"], "num_subjects": num_subjects, "vertice_dim": vertice_dim})

    def fit(self, train, val, request):
        t = self.settings["training"]
        steps, seconds = training_limits(request.budget, t["max_steps"], t["max_seconds"])
        return train_faceformer(self.network, train, val, self.subjects, training=t, seed=int(request.seed),
                                max_steps=steps, max_seconds=seconds, on_checkpoint=request.on_checkpoint,
                                fractions=request.checkpoint_fractions, mixed_precision=self.mixed_precision)

    def network_from_state(self, payload: dict) -> Faceformer:
        return Faceformer(payload["model_config"])
