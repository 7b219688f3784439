"""The ``said`` method of the benchmark (``python -m benchmark.run --method said``).

Registered lazily by ``benchmark.methods`` as ``"baselines.said.plugin:SAiDMethod"``.
Only this module imports the benchmark.
"""

from __future__ import annotations

import copy
import os
from pathlib import Path

import torch

from baselines.common.checkpoint import load_checkpoint_file
from baselines.common.device import checked_precision, method_device, precision_config
from baselines.common.presets import preset_help, preset_options
from baselines.said.dataset import dataset_pairs, mirror_for
from baselines.said.official import is_official_state, model_from_state
from baselines.said.official_pipeline import OfficialSAiD
from baselines.said.pipeline import SAiD, check_sampling
from baselines.said.presets import DEFAULT_PRESET, HELP, PRESETS
from baselines.said.train import train_said
from benchmark.methods.base import Method, TrainingRequest
from blendvoca.errors import DataError, UserError
from blendvoca.names import BLENDVOCA_NAMES
from blendvoca.runtime.progress import progress_bars

CHECKPOINT_FILE = "said.pt"


class SAiDMethod(Method):
    """SAiD: conditional diffusion over blendshape coefficients (stochastic).

    Parameters
    ----------
    preset : {"cpu-demo", "paper"}, default "cpu-demo"
    resolved : dict, optional
        Ignored: the resolved config that :meth:`config` reports (so that the saved
        config can be passed back to the constructor).
    **overrides
        Flat keys of :func:`baselines.said.presets.resolve_config` (``channels``,
        ``num_steps``, ``sampler``, ``guidance``, ``encoder``, ``wav2vec2_path``, ``lr`` ...).
    """

    name = "said"
    stochastic = True
    #: sampling keys a trained checkpoint can be scored with (``--checkpoint DIR --config guidance=2``)
    sampling_options = ("sampler", "num_steps", "guidance", "eta")

    @classmethod
    def config_schema(cls):
        """The constructor's keys plus every flat key of the presets, typed from their values."""
        return super().config_schema().with_presets(PRESETS, default=DEFAULT_PRESET, extra=preset_options(encoder=True),
            help=preset_help(HELP))

    def __init__(self, preset: str = "cpu-demo", resolved: dict | None = None, mixed_precision: str = "off",
                 **overrides):
        super().__init__(preset=preset, **precision_config(mixed_precision), **overrides)
        #: autocast of the training loss on a GPU (docs/gpu.md); nothing on the CPU
        self.mixed_precision = checked_precision(mixed_precision)
        self.said = SAiD.from_preset(BLENDVOCA_NAMES, preset, **overrides)

    def config(self) -> dict:
        """Constructor arguments plus the resolved nested config."""
        return {**super().config(), "resolved": self.said.config}

    contract = 3

    def train(self, dataset, request: TrainingRequest) -> None:
        """Train on the dataset's train split, select on its val split, within ``request.budget``;
        ``request.on_checkpoint``: the runner's checkpoint call, made when a run without a time
        limit has done the ``checkpoint_fractions`` of its steps (:func:`baselines.said.train.train_said`);
        the authors' weights train nothing and make no call. ``request.device``: where the network
        trains and then samples (None: where it is, the CPU unless moved by :meth:`to`);
        the initial weights are drawn on the CPU, so they are the same on every device."""
        device = request.device
        if isinstance(self.said, OfficialSAiD):
            if device is not None:
                self.to(device)
            return  # the authors' published weights: nothing to train
        names = tuple(dataset.names)
        if names != self.said.names:
            raise DataError(f"SAiDMethod.train: expected dataset columns {self.said.names}, got {names}")
        # the initial weights from the seed too (the constructor drew them from the global RNG):
        # a step budget then gives the same model in every process
        torch.manual_seed(int(request.seed))
        target = self.said.device if device is None else method_device(device)
        self.said = SAiD(self.said.config, self.said.names).to(target)
        val = dataset_pairs(dataset, "val") if dataset.split("val") else None
        train_said(
            self.said,
            dataset_pairs(dataset, "train"),
            val,
            seed=request.seed,
            max_steps=request.budget.max_steps,
            max_seconds=request.budget.max_seconds,
            mirror=mirror_for(names),
            on_checkpoint=request.on_checkpoint,
            fractions=request.checkpoint_fractions,
            mixed_precision=self.mixed_precision,
        )

    def to(self, device) -> SAiDMethod:
        """This method with its network on ``device`` (sampling runs there); returns self."""
        self.said.to(method_device(device))
        return self

    @property
    def lookahead_s(self) -> float | None:
        """Seconds of audio after frame ``t`` that frame ``t`` needs: one chunk (:attr:`SAiD.lookahead_s`);
        None for the authors' weights, which sample the whole utterance in one chain."""
        return None if isinstance(self.said, OfficialSAiD) else self.said.lookahead_s

    def generate(self, utterance, *, samples=1, seed=0):
        """Return ``(S, T, 32)`` coefficient tracks in [0, 1] sampled for the utterance's audio (speaker-independent);
        an utterance longer than ``chunk_frames`` (default 10 training windows) goes chunk by chunk
        (:mod:`baselines.common.chunking`). The sampler's own bar stays off (the runner draws one per split)."""
        with progress_bars(False):
            return self.said.generate(utterance.audio, utterance.num_frames, samples=int(samples), seed=int(seed))

    def generate_many(self, utterances, *, samples=1, seeds):
        """``(S, T_i, 32)`` tracks for several utterances, batched into one chain (``benchmark.run --sentence-batch N``)."""
        pairs = [(utterance.audio, utterance.num_frames) for utterance in utterances]
        with progress_bars(False):
            return self.said.generate_many(pairs, samples=int(samples), seeds=[int(seed) for seed in seeds])

    def with_sampling_options(self, **options) -> SAiDMethod:
        """The same trained network sampling with another ``sampler``, ``num_steps``, ``guidance`` or ``eta``."""
        self.check_sampling_options(options)
        if isinstance(self.said, OfficialSAiD):
            raise UserError("SAiDMethod: the authors' weights sample with their inference settings; "
                            "set the DDIM steps with --config official_steps=N")
        config = copy.deepcopy(self.said.config)
        config["sampling"].update(options)
        check_sampling(config["sampling"], config["diffusion"]["num_train_steps"])
        twin = copy.copy(self)
        twin._config = {**self._config, **options}
        twin.said = SAiD(config, self.said.names, model=self.said.model).to(self.said.device)
        twin.said.history = self.said.history
        return twin

    def save(self, directory: str | os.PathLike) -> None:
        """Write the config and the checkpoint ``said.pt`` into ``directory`` (not for published weights)."""
        if isinstance(self.said, OfficialSAiD):
            raise UserError("SAiDMethod.save: the authors' published weights are used from their file; nothing to save")
        Method.save(self, directory)
        self.said.save(Path(os.fspath(directory)) / CHECKPOINT_FILE)

    @classmethod
    def from_official_checkpoint(cls, path: str | os.PathLike, *, official_steps: int | None = None,
                                 **config) -> SAiDMethod:
        """The method with the authors' ``SAiD.pth`` (``benchmark.run --checkpoint SAiD.pth``; detected by its keys).

        It samples with the authors' inference settings (DDIM 1000, gamma 2);
        ``official_steps`` (``--config official_steps=50``) sets fewer DDIM steps.
        """
        path = Path(os.fspath(path))
        state = load_checkpoint_file(path, where="SAiDMethod")
        if not is_official_state(state):
            raise DataError(f"SAiDMethod: {path} is a file but not the authors' SAID_UNet1D state_dict; "
                            "expected that or a directory written by SAiDMethod.save")
        method = cls(**config)
        method.said = OfficialSAiD(model_from_state(state, where=str(path)),
                                   {"num_steps": int(official_steps)} if official_steps else None)
        return method

    @classmethod
    def load(cls, directory: str | os.PathLike) -> SAiDMethod:
        """Rebuild from :meth:`save`'s output."""
        method = super().load(directory)
        method.said = SAiD.load(Path(os.fspath(directory)) / CHECKPOINT_FILE)
        return method
