"""The ``cdface`` method of the benchmark (``python -m benchmark.run --method cdface``).

Registered lazily by ``benchmark.methods`` as ``"baselines.cdface.plugin:CDFaceMethod"``.
Only this module imports the benchmark.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from baselines.cdface.closure import lip_pair_for
from baselines.cdface.generate import chunk_lengths
from baselines.cdface.parts import face_parts
from baselines.cdface.pipeline import CONTROL_MODES, CDFace
from baselines.cdface.presets import DEFAULT_PRESET, HELP, PRESETS, resolve_config
from baselines.cdface.train import load_sentences, moving_vertices, prepare_sentences, train_cdface
from baselines.common.chunking import FPS, generate_utterance_in_chunks
from baselines.common.device import checked_precision, method_device, precision_config
from baselines.common.presets import preset_help, preset_options
from benchmark.methods.base import Method, TrainingRequest
from benchmark.methods.contract import OUTPUT_VERTICES
from blendvoca.errors import DataError, UserError
from blendvoca.rig_regions import lip_vertices
from blendvoca.runtime.progress import progress_bars

CHECKPOINT_FILE = "cdface.pt"


def dataset_lips(dataset, subjects):
    """Union of every rig's :func:`blendvoca.rig_regions.lip_vertices` (None without rigs)."""
    lips = []
    for s in subjects:
        try:
            rig = dataset.rig(s)
        except (FileNotFoundError, KeyError, ValueError):
            continue
        lips.append(lip_vertices(np.asarray(rig.deltas), list(rig.names)))
    return np.unique(np.concatenate(lips)) if lips else None


def dataset_parts(dataset, subjects, active=None):
    """Face parts from the mean template of ``subjects``, every rig's lip vertices in the lip part,
    only the ``active`` vertices modelled (default all)."""
    templates = np.stack([dataset.template(s) for s in subjects])
    return face_parts(templates.mean(axis=0), dataset_lips(dataset, subjects), active)


class CDFaceMethod(Method):
    """CDFace: diverse code querying over separate lip and upper-face VQ priors (stochastic, vertices).

    Parameters
    ----------
    preset : {"cpu-demo", "paper"}, default "cpu-demo"
    control : {"none", "lips"}, default "none"
        ``"lips"``: every sample of a sentence shares one lip sample (lip codes
        fixed) and only the upper face varies (the paper's controlled synthesis).
    style : str, optional
        Training speaker whose style token animates every speaker (default the first).
    resolved : dict, optional
        Ignored: the resolved config that :meth:`config` reports.
    **overrides
        Flat keys of :func:`baselines.cdface.presets.resolve_config`.
    """

    name = "cdface"
    stochastic = True
    output = OUTPUT_VERTICES
    sampling_options = ("control", "style")

    @classmethod
    def config_schema(cls):
        """The constructor's keys plus every flat key of the presets, typed from their values."""
        return super().config_schema().with_presets(PRESETS, default=DEFAULT_PRESET, extra=preset_options(encoder=True),
            help=preset_help(HELP))

    def __init__(self, preset: str = "cpu-demo", control: str = "none", style: str | None = None,
                 resolved: dict | None = None, mixed_precision: str = "off", **overrides):
        if control not in CONTROL_MODES:
            raise UserError(f"cdface: expected control in {CONTROL_MODES}, got {control!r}")
        #: autocast of the training losses on a GPU (docs/gpu.md); nothing on the CPU
        self.mixed_precision = checked_precision(mixed_precision)
        kwargs = {"preset": preset, "control": control, **precision_config(mixed_precision), **overrides}
        if style is not None:
            kwargs["style"] = style
        super().__init__(**kwargs)
        self.preset, self.control, self.style, self.overrides = preset, control, style, dict(overrides)
        self.resolved = resolve_config(preset, **overrides)
        self.label = "cdface (lips fixed)" if control == "lips" else None
        self.cdface = None

    def config(self) -> dict:
        """Constructor arguments plus the resolved nested config."""
        return {**super().config(), "resolved": self.resolved}

    contract = 3

    def train(self, dataset, request: TrainingRequest) -> None:
        """Train the two part priors and the querying model on the train split within
        ``request.budget``; ``request.on_checkpoint``: the runner's checkpoint call, made at the
        ``checkpoint_fractions`` of the querying stage (the last one) when it has a step limit
        (:func:`baselines.cdface.train.train_cdface`). ``request.device``: where the networks train and then sample (None: the CPU); they are built
        and the frozen audio features computed on the CPU first, so a seed gives the same
        initial weights and inputs on every device."""
        train = list(dataset.split("train"))
        if not train:
            raise DataError("cdface: the dataset has no training speakers")
        everyone = [s for split in ("train", "val", "test") for s in dataset.split(split)]
        loaded = load_sentences(dataset, train)
        active = moving_vertices(loaded, self.resolved["model"]["active_threshold"])
        parts = dataset_parts(dataset, everyone, active)
        torch.manual_seed(int(request.seed))  # the initial weights too: a step budget then gives the same model every run
        self.cdface = CDFace(self.resolved, parts, train, {s: dataset.template(s) for s in everyone})
        sentences = prepare_sentences(self.cdface, loaded, epsilon=self.resolved["loss"]["epsilon"],
                                      lip_pair=lip_pair_for(dataset.template(train[0]), dataset_lips(dataset, train)))
        del loaded
        self.cdface.model.to(method_device(request.device))
        budget = request.budget
        train_cdface(self.cdface, sentences, seed=request.seed, max_steps=budget.max_steps,
                     max_seconds=budget.max_seconds, on_checkpoint=request.on_checkpoint,
                     fractions=request.checkpoint_fractions, mixed_precision=self.mixed_precision)

    def to(self, device):
        """This method with its networks on ``device`` (sampling runs there; the frozen audio encoder
        stays on the CPU); returns self."""
        if self.cdface is not None:
            self.cdface.model.to(method_device(device))
        return self

    @property
    def chunk_frames(self) -> int:
        """Frames per chunk of a long utterance (:func:`baselines.cdface.generate.chunk_lengths`)."""
        return chunk_lengths(self.resolved)[0]

    @property
    def chunk_overlap(self) -> int:
        """Frames two chunks share (:func:`baselines.cdface.generate.chunk_lengths`)."""
        return chunk_lengths(self.resolved)[1]

    @property
    def lookahead_s(self) -> float:
        """Audio after frame ``t`` that frame ``t`` needs, in seconds, at worst: one chunk (the audio
        encoder sees the chunk as a whole before the first frame is queried)."""
        return self.chunk_frames / FPS

    def generate(self, utterance, *, samples=1, seed=0):
        """``(S, T, V, 3)`` vertices in metres on the speaker's template (the training data's topology); a long utterance chunk by chunk,
        each chunk restarting with its overlap as context (:mod:`baselines.common.chunking`)."""
        if self.cdface is None:
            raise RuntimeError("cdface: train or load the method before generate")

        def whole(part, *, samples, seed):
            return self.cdface.generate(part.audio, part.num_frames, subject=part.subject, samples=samples, seed=seed,
                                        control=self.control, style=self.style)

        with progress_bars(False):  # the per-frame bar of the sampler stays off (the runner draws one per split)
            return generate_utterance_in_chunks(whole, utterance, samples=int(samples), seed=int(seed),
                                                chunk_frames=self.chunk_frames, overlap_frames=self.chunk_overlap)

    def styles(self) -> tuple[str, ...]:
        """The speakers with a stored template, the training speakers first (the first is the default)."""
        if self.cdface is None:
            return ()
        first = [s for s in self.cdface.styles if s in self.cdface.templates]
        return tuple(first + sorted(s for s in self.cdface.templates if s not in first))

    def with_sampling_options(self, **options) -> CDFaceMethod:
        """The same trained model sampling with another ``control`` or ``style``."""
        self.check_sampling_options(options)
        twin = type(self)(**{**self.config(), **options})
        twin.cdface = self.cdface
        return twin

    def save(self, directory) -> None:
        """Write the config and the checkpoint ``cdface.pt`` into ``directory``."""
        if self.cdface is None:
            raise RuntimeError("cdface: nothing to save before training")
        super().save(directory)
        self.cdface.save(Path(directory) / CHECKPOINT_FILE)

    @classmethod
    def load(cls, directory) -> CDFaceMethod:
        """Rebuild from :meth:`save`'s output."""
        method = super().load(directory)
        method.cdface = CDFace.load(Path(directory) / CHECKPOINT_FILE)
        return method
