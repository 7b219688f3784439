"""The ``codetalker`` method of the benchmark (``python -m benchmark.run --method codetalker``).

Without ``official``, training runs both stages on the BlendVOCA train split. With
``--config official=vocaset_stage2.pth.tar --config official_stage1=vocaset_stage1.pth.tar``
the authors' released weights are used as they are.
"""

from __future__ import annotations

import os
from pathlib import Path

from baselines.codetalker.model import CodeTalker
from baselines.codetalker.official import load_official
from baselines.codetalker.presets import HELP, PREFIXES, PRESETS, resolve_config
from baselines.codetalker.train import split_budget, train_stage1, train_stage2
from baselines.common.chunking import ChunkedDecoder
from baselines.common.device import precision_config
from baselines.common.vertex_method import StyleVertexMethod, training_limits
from blendvoca.errors import UserError

__all__ = ["CodeTalkerMethod"]


class CodeTalkerMethod(ChunkedDecoder, StyleVertexMethod):
    """CodeTalker (vertex output, one sample per training-speaker style).

    Parameters
    ----------
    preset : {"cpu-demo", "paper"}, default "cpu-demo"
    official : str or os.PathLike, optional
        The authors' ``vocaset_stage2.pth.tar`` (with ``official_stage1``); then nothing is trained.
    official_stage1 : str or os.PathLike, optional
        The authors' ``vocaset_stage1.pth.tar``, the VQ-VAE that ``official`` decodes with.
    official_wav2vec2 : "base", "tiny" or dict, default "base"
        wav2vec 2.0 architecture of those files (the released ones: base-960h).
    resolved : dict, optional
        Ignored (the resolved config reported by :meth:`config`).
    **overrides
        Flat keys of :func:`baselines.codetalker.presets.resolve_config`.
    """

    name = "codetalker"
    label = "CodeTalker"
    checkpoint_file = "codetalker.pt"
    # The authors' VQ-VAE adds positional-table row b to batch item b
    # (vqvae.PositionalEncoding): a style's output depends on its batch position, so
    # each style is predicted alone, at position 0, as the authors do.
    batch_styles = False

    presets, preset_prefixes, preset_help = PRESETS, PREFIXES, HELP

    def __init__(self, preset: str = "cpu-demo", official: str | os.PathLike | None = None,
                 official_stage1: str | os.PathLike | None = None, official_wav2vec2="base", resolved: dict | None = None,
                 mixed_precision: str = "off", **overrides):
        # recorded in the JSON config
        official = None if official is None else os.fspath(official)
        official_stage1 = None if official_stage1 is None else os.fspath(official_stage1)
        super().__init__(preset=preset, official=official, official_stage1=official_stage1,
                         official_wav2vec2=official_wav2vec2, **precision_config(mixed_precision), **overrides)
        self.use_preset(resolve_config(preset, **overrides), mixed_precision)
        if (official is None) != (official_stage1 is None):
            raise UserError("CodeTalkerMethod: expected both official (stage 2) and official_stage1 (stage 1) paths, "
                            f"got official={official!r}, official_stage1={official_stage1!r}")
        if official is not None:
            self.use_official(load_official(official, official_stage1, wav2vec2_config=official_wav2vec2))

    @classmethod
    def from_official_checkpoint(cls, path: str | os.PathLike, **config) -> CodeTalkerMethod:
        """The method with the authors' stage-2 file ``path`` (``benchmark.run --checkpoint FILE``).

        The stage-1 file is ``official_stage1`` when given, else the sibling named like
        ``path`` with ``stage2`` replaced by ``stage1`` (the released files' names).
        """
        config.pop("official", None)
        stage1 = config.pop("official_stage1", None)
        path = Path(os.fspath(path))
        if stage1 is None:
            if "stage2" not in path.name:
                raise UserError(f"CodeTalker: cannot tell the stage-1 file for {path}; expected a name with 'stage2' "
                                "(vocaset_stage2.pth.tar) or --config official_stage1=PATH")
            stage1 = path.with_name(path.name.replace("stage2", "stage1"))
            if not stage1.is_file():
                raise UserError(f"CodeTalker: expected the stage-1 file {stage1} next to {path}, not found "
                                "(or pass --config official_stage1=PATH)")
        return cls(official=path, official_stage1=stage1, **config)

    def build_network(self, num_subjects: int, vertice_dim: int) -> None:
        self.network = CodeTalker({**self.settings["model"], "num_subjects": num_subjects, "vertice_dim": vertice_dim},
                                  {**self.settings["stage1"], "in_dim": vertice_dim})

    def fit(self, train, val, request):
        t = self.settings["training"]
        seed = int(request.seed)
        steps, seconds = training_limits(request.budget, t["max_steps"], t["max_seconds"])
        (s1, t1), (s2, t2) = split_budget(steps, seconds, t["stage1_fraction"])
        vq = self.network.autoencoder
        for p in vq.parameters():
            p.requires_grad_(True)
        h1 = train_stage1(vq, train, val, training=t, seed=seed, max_steps=s1, max_seconds=t1,
                          mixed_precision=self.mixed_precision)
        for p in vq.parameters():
            p.requires_grad_(False)
        # the half-budget call (``on_checkpoint``) comes in stage 2, the stage that makes the animation
        h2 = train_stage2(self.network, train, val, self.subjects, training=t, seed=seed + 1, max_steps=s2,
                          max_seconds=t2, on_checkpoint=request.on_checkpoint,
                          fractions=request.checkpoint_fractions,
                          step_offset=int(h1["steps"]), mixed_precision=self.mixed_precision)
        return {"stage1": h1, "stage2": h2, "steps": h1["steps"] + h2["steps"], "seconds": h1["seconds"] + h2["seconds"]}

    def network_state(self) -> dict:
        return {**super().network_state(), "stage1_config": self.network.stage1}

    def network_from_state(self, payload: dict) -> CodeTalker:
        return CodeTalker(payload["model_config"], payload["stage1_config"])
